// The farm client subcommands: submit, watch, status, cancel, fetch, workers. They talk to an
// alphorn-coordinator (proto/alphorn/v1/client_service.proto) and never render themselves.
#include "cli/commands.h"
#include "cli/farm_client.h"
#include "cli/progress.h"

#include "common/farm/convert.h"
#include "common/render/image_io.h"

#include <absl/strings/str_format.h>

#include <iostream>

namespace alphorn::cli {

namespace {

int exitCodeFor(const v1::JobStatus& status) {
    return status.state() == v1::JOB_STATE_DONE ? kExitOk : kExitJobFailed;
}

// How many times each pass's per-pass data (photon maps) was built, once the whole job was
// rendered in this coordinator process (1.00: never traced twice).
std::string duplication(const v1::JobStatus& s) {
    if (s.state() != v1::JOB_STATE_DONE || s.units_restored() != 0 || s.settings().passes() == 0)
        return "";
    return absl::StrFormat("pass data built %.2fx",
                           double(s.pass_data_builds()) / s.settings().passes());
}

// The job table: a header row, then one row per job; the last column holds what only some jobs
// have (photon radius, pass data duplication, error). `--json` prints the same fields.
void printStatusTable(const std::vector<v1::JobStatus>& jobs) {
    const char* format = "%-6s %-10s %-20s %9s  %13s  %13s  %4s  %s\n";
    std::cout << absl::StrFormat(format, "JOB", "STATE", "NAME", "SIZE", "PASSES", "UNITS", "PRIO",
                                 "NOTES");
    for (const v1::JobStatus& s : jobs) {
        std::string notes =
            s.has_photon_radius() ? absl::StrFormat("photon radius %.4g", s.photon_radius()) : "";
        const std::string estimate =
            s.has_error_estimate() || s.settings().has_target_error() ? statusErrorText(s) : "";
        for (const std::string& note :
             {estimate, s.target_reached() ? std::string("target reached") : std::string(),
              duplication(s), s.error().empty() ? "" : "error: " + s.error()})
            if (!note.empty()) notes += (notes.empty() ? "" : "  ") + note;
        std::cout << absl::StrFormat(
            format, std::to_string(s.job_id()), farm::jobStateName(s.state()), s.settings().name(),
            absl::StrFormat("%ux%u", s.width(), s.height()),
            absl::StrFormat("%u/%u", s.passes_done(), s.settings().passes()),
            absl::StrFormat("%u/%u", s.units_done(), s.units_total()),
            std::to_string(s.settings().priority()), notes);
    }
}

void printStatusLine(const v1::JobStatus& s) {
    printStatusTable({s});
}

}  // namespace

int runSubmit(FarmClient& client, const SubmitOptions& options, bool json) {
    v1::JobSettings settings;
    settings.set_passes(options.passes);
    settings.set_seed(options.seed);
    settings.set_tile_size(options.tile);
    settings.set_passes_per_unit(options.passesPerUnit);
    settings.set_priority(options.priority);
    settings.set_integrator_override(options.integrator);
    settings.set_name(options.name);
    if (options.targetError) {
        settings.set_target_error(*options.targetError);
        settings.set_passes(*options.maxPasses);  // the option parser insists on the cap
    }
    v1::JobStatus status = client.submit(options.scene, settings, json);
    if (!json)
        std::cerr << absl::StrFormat("job %u submitted: %ux%u, %u passes, %u units\n",
                                     status.job_id(), status.width(), status.height(),
                                     status.settings().passes(), status.units_total());
    if (!options.watch && options.output.empty()) {
        if (json)
            std::cout << toJson(status) << "\n";
        else
            std::cout << status.job_id() << "\n";
        return kExitOk;
    }
    status = client.watch(status.job_id(), json);
    if (status.state() != v1::JOB_STATE_DONE) {
        if (json) std::cout << toJson(status) << "\n";
        std::cerr << absl::StrFormat("job %u %s: %s\n", status.job_id(),
                                     farm::jobStateName(status.state()), status.error());
        return exitCodeFor(status);
    }
    if (!options.output.empty()) {
        client.fetchImages(status.job_id(), options.output, false);
        if (!json)
            std::cerr << "wrote " << options.output << " and " << pngPathFor(options.output)
                      << "\n";
    }
    if (json) std::cout << toJson(status) << "\n";
    return kExitOk;
}

Command addSubmitCommand(CLI::App& app) {
    auto options = std::make_shared<SubmitOptions>();
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto spp = std::make_shared<uint32_t>(0);
    CLI::App* sub = app.add_subcommand(
        "submit", "Submit a scene to a render farm (uploads only missing files).");
    sub->add_option("scene", options->scene, "Nori-format scene file")
        ->required()
        ->check(CLI::ExistingFile);
    auto* passes = sub->add_option("--passes", options->passes,
                                   "Number of passes (default: the scene's sampleCount)")
                       ->check(kPositiveCount);
    auto* sppOption = sub->add_option("--spp", *spp, "Samples per pixel (= passes)")
                          ->excludes(passes)
                          ->check(kPositiveCount);
    addTargetErrorOptions(*sub, options->targetError, options->maxPasses, {passes, sppOption});
    sub->add_option("--seed", options->seed, "Random seed; the image is a pure function of it");
    sub->add_option("--tile", options->tile, "Tile size in pixels (does not change the image)");
    sub->add_option("--passes-per-unit", options->passesPerUnit,
                    "Passes per work unit (does not change the image)");
    sub->add_option("--priority", options->priority, "Higher runs first; FIFO within a priority");
    sub->add_option("--name", options->name, "Job name (default: the scene's file name)");
    sub->add_option("--integrator", options->integrator,
                    "Use this integrator type instead of the scene's");
    sub->add_flag("--watch", options->watch, "Follow the job until it ends");
    sub->add_option("-o,--output", options->output,
                    "Wait for the job and write this EXR (and a PNG beside it)")
        ->check(kExrOutputPath);
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                if (*spp) options->passes = *spp;
                FarmClient client(*connection);
                return runSubmit(client, *options, connection->json);
            }};
}

Command addWatchCommand(CLI::App& app) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto jobId = std::make_shared<uint64_t>(0);
    CLI::App* sub =
        app.add_subcommand("watch", "Follow a farm job with a progress bar until it ends.");
    sub->add_option("job", *jobId, "Job id")->required();
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::JobStatus status = client.watch(*jobId, connection->json);
                if (connection->json)
                    std::cout << toJson(status) << "\n";
                else
                    printStatusLine(status);
                return exitCodeFor(status);
            }};
}

Command addStatusCommand(CLI::App& app) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto jobId = std::make_shared<uint64_t>(0);
    CLI::App* sub = app.add_subcommand("status", "Show farm jobs (all, or one).");
    sub->add_option("job", *jobId, "Job id (default: every job)");
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::ListJobsRequest request;
                request.set_job_id(*jobId);
                v1::ListJobsResponse response;
                FarmClient::check(
                    client.stub().ListJobs(client.context().get(), request, &response), "ListJobs");
                if (connection->json) {
                    std::cout << (*jobId ? toJson(response.jobs(0)) : toJson(response)) << "\n";
                } else if (response.jobs().empty()) {
                    std::cout << "no jobs (alphorn submit SCENE adds one)\n";
                } else {
                    printStatusTable({response.jobs().begin(), response.jobs().end()});
                }
                return kExitOk;
            }};
}

Command addCancelCommand(CLI::App& app) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto jobId = std::make_shared<uint64_t>(0);
    CLI::App* sub = app.add_subcommand("cancel", "Cancel a farm job.");
    sub->add_option("job", *jobId, "Job id")->required();
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::CancelJobRequest request;
                request.set_job_id(*jobId);
                v1::CancelJobResponse response;
                FarmClient::check(
                    client.stub().CancelJob(client.context().get(), request, &response),
                    "CancelJob");
                if (connection->json)
                    std::cout << toJson(response.status()) << "\n";
                else
                    printStatusLine(response.status());
                return kExitOk;
            }};
}

Command addFetchCommand(CLI::App& app) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto jobId = std::make_shared<uint64_t>(0);
    auto output = std::make_shared<std::string>();
    auto preview = std::make_shared<bool>(false);
    CLI::App* sub = app.add_subcommand("fetch", "Download a farm job's image (EXR and PNG).");
    sub->add_option("job", *jobId, "Job id")->required();
    sub->add_option("-o,--output", *output, "Output EXR path; a PNG is written beside it")
        ->required()
        ->check(kExrOutputPath);
    sub->add_flag("--preview", *preview, "The image merged so far, for a job still running");
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                client.fetchImages(*jobId, *output, *preview);
                if (connection->json)
                    std::cout << "{\"exr\":\"" << *output << "\",\"png\":\"" << pngPathFor(*output)
                              << "\"}\n";
                else
                    std::cerr << "wrote " << *output << " and " << pngPathFor(*output) << "\n";
                return kExitOk;
            }};
}

Command addWorkersCommand(CLI::App& app) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto all = std::make_shared<bool>(false);
    CLI::App* sub = app.add_subcommand("workers", "List the farm's workers.");
    sub->add_flag("--all", *all, "Include workers not seen recently");
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::ListWorkersRequest request;
                request.set_include_dead(*all);
                v1::ListWorkersResponse response;
                FarmClient::check(
                    client.stub().ListWorkers(client.context().get(), request, &response),
                    "ListWorkers");
                if (connection->json) {
                    std::cout << toJson(response) << "\n";
                    return kExitOk;
                }
                if (response.workers().empty()) {
                    std::cout << (*all ? "no workers\n"
                                       : "no workers seen recently (--all lists every worker)\n");
                    return kExitOk;
                }
                const char* format = "%-5s %-28s %5s %9s  %-8s %-5s %6s %13s  %s\n";
                std::cout << absl::StrFormat(format, "ID", "NAME", "CORES", "MEMORY", "VERSION",
                                             "STATE", "LEASES", "UNITS MERGED", "LAST SEEN");
                for (const auto& w : response.workers())
                    std::cout << absl::StrFormat(
                        format, std::to_string(w.worker_id()), w.name(), std::to_string(w.cores()),
                        absl::StrFormat("%.1f GiB", w.memory_bytes() / double(1 << 30)),
                        w.version(), w.alive() ? "alive" : "dead", std::to_string(w.leases()),
                        std::to_string(w.units_merged()),
                        absl::StrFormat("%.1f s ago", w.seconds_since_seen()));
                return kExitOk;
            }};
}

}  // namespace alphorn::cli
