// The farm client subcommands: submit, watch, status, cancel, fetch, workers, and the job and
// worker controls retry, pause, resume, priority, delete, logs, drain, undrain. They talk to an
// alphorn-coordinator (proto/alphorn/v1/client_service.proto) and never render themselves.
#include "cli/commands.h"
#include "cli/farm_client.h"
#include "cli/progress.h"

#include "common/core/image.h"
#include "common/farm/convert.h"
#include "common/farm/rpc.h"
#include "common/farm/utf8_text.h"

#include <absl/strings/numbers.h>
#include <absl/strings/str_format.h>

#include <algorithm>
#include <ctime>
#include <iostream>
#include <thread>
#include <vector>

namespace alphorn::cli {

namespace {

// Job and worker ids are whole numbers from 1. Read straight into an unsigned id, "-1" became
// 2^64 - 1 and the coordinator's answer was "no job 18446744073709551615", so the text is
// checked first.
const CLI::Validator kId(
    [](std::string& value) -> std::string {
        uint64_t id = 0;
        if (value.empty() || value.find_first_not_of("0123456789") != std::string::npos ||
            !absl::SimpleAtoi(value, &id) || id == 0)
            return "an id is a whole number from 1 to 18446744073709551615, got " + value;
        return "";
    },
    "ID");

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

// Local time as "2026-12-02 05:13:04" (`withDate`) or "12-02 05:13".
std::string localTime(double unixSeconds, bool withDate) {
    const std::time_t seconds = static_cast<std::time_t>(unixSeconds);
    std::tm local = {};
    ::localtime_r(&seconds, &local);
    char text[32] = {};
    std::strftime(text, sizeof text, withDate ? "%Y-%m-%d %H:%M:%S" : "%m-%d %H:%M", &local);
    return text;
}

// "running", or "paused" for a running job a client paused.
std::string jobStateText(const v1::JobStatus& s) {
    return s.paused() ? "paused" : farm::jobStateName(s.state());
}

// A column of a table printed for people: its header, the spaces before it, its least width,
// the most a text column may grow to (0: no limit) and whether it is aligned to the right.
struct Column {
    const char* header;
    const char* gap;
    size_t minWidth;
    size_t maxWidth = 0;
    bool right = false;
};

// The widest a column of names (jobs, owners, workers) grows; longer names are cut with "…".
constexpr size_t kMaxNameColumns = 40;

// Prints the header and the rows. Widths are counted in the columns a terminal shows, not in
// bytes, so that names in CJK, with emoji or with combining marks line up with the rest; a
// column is as wide as its widest cell (within its bounds). The last column is not padded.
void printTable(const std::vector<Column>& columns,
                const std::vector<std::vector<std::string>>& rows) {
    std::vector<size_t> widths;
    for (size_t c = 0; c < columns.size(); ++c) {
        size_t width = std::max(columns[c].minWidth, farm::displayWidth(columns[c].header));
        for (const auto& row : rows) width = std::max(width, farm::displayWidth(row[c]));
        if (columns[c].maxWidth > 0) width = std::min(width, columns[c].maxWidth);
        widths.push_back(width);
    }
    const auto printRow = [&](const std::vector<std::string>& cells) {
        std::string line;
        for (size_t c = 0; c < columns.size(); ++c) {
            if (c > 0) line += columns[c].gap;
            if (c + 1 == columns.size()) {
                line += cells[c];
            } else if (columns[c].right) {
                const size_t width = farm::displayWidth(cells[c]);
                line += std::string(widths[c] - std::min(width, widths[c]), ' ') + cells[c];
            } else {
                line += farm::fitToColumns(cells[c], widths[c]);
            }
        }
        std::cout << line << "\n";
    };
    std::vector<std::string> header;
    for (const Column& column : columns) header.push_back(column.header);
    printRow(header);
    for (const auto& row : rows) printRow(row);
}

// The job table: a header row, then one row per job; the last column holds what only some jobs
// have (photon radius, pass data duplication, error). `--json` prints the same fields (the
// owner is settings.owner, the submit time submitted_at_unix_seconds).
void printStatusTable(const std::vector<v1::JobStatus>& jobs) {
    const std::vector<Column> columns = {{"JOB", "", 6},
                                         {"STATE", " ", 10},
                                         {"NAME", " ", 20, kMaxNameColumns},
                                         {"OWNER", " ", 18, kMaxNameColumns},
                                         {"SUBMITTED", " ", 11},
                                         {"SIZE", " ", 9, 0, true},
                                         {"PASSES", "  ", 13, 0, true},
                                         {"UNITS", "  ", 13, 0, true},
                                         {"PRIO", "  ", 4, 0, true},
                                         {"NOTES", "  ", 0}};
    std::vector<std::vector<std::string>> rows;
    for (const v1::JobStatus& s : jobs) {
        std::string notes =
            s.has_photon_radius() ? absl::StrFormat("photon radius %.4g", s.photon_radius()) : "";
        const std::string estimate =
            s.has_error_estimate() || s.settings().has_target_error() ? statusErrorText(s) : "";
        for (const std::string& note :
             {estimate, s.target_reached() ? std::string("target reached") : std::string(),
              duplication(s), s.error().empty() ? "" : "error: " + s.error(),
              s.suspect().empty() ? "" : "SUSPECT: " + s.suspect()})
            if (!note.empty()) notes += (notes.empty() ? "" : "  ") + note;
        rows.push_back({std::to_string(s.job_id()), jobStateText(s), s.settings().name(),
                        s.settings().owner().empty() ? "-" : s.settings().owner(),
                        s.submitted_at_unix_seconds() > 0
                            ? localTime(s.submitted_at_unix_seconds(), false)
                            : "-",
                        absl::StrFormat("%ux%u", s.width(), s.height()),
                        absl::StrFormat("%u/%u", s.passes_done(), s.settings().passes()),
                        absl::StrFormat("%u/%u", s.units_done(), s.units_total()),
                        std::to_string(s.settings().priority()), notes});
    }
    printTable(columns, rows);
}

void printStatusLine(const v1::JobStatus& s) {
    printStatusTable({s});
}

// "alive", "draining" (a client drained it), "exiting" (stopping on SIGTERM), "silent" (no call
// for two heartbeat intervals: probably killed), "dead", "left" (exited after draining).
std::string workerStateText(const v1::WorkerInfo& w) {
    std::string state;
    switch (w.state()) {
        case v1::WORKER_STATE_SILENT:
            state = "silent";
            break;
        case v1::WORKER_STATE_DEAD:
            state = "dead";
            break;
        case v1::WORKER_STATE_LEFT:
            return "left";
        case v1::WORKER_STATE_ALIVE:
            state = "alive";
            break;
        default:
            state = w.alive() ? "alive" : "dead";  // a coordinator that predates the states
    }
    const char* draining = w.exiting() ? "exiting" : w.draining() ? "draining" : nullptr;
    if (!draining) return state;
    return state == "alive" ? draining : state + "," + draining;
}

void printWorkerTable(const std::vector<v1::WorkerInfo>& workers) {
    const std::vector<Column> columns = {{"ID", "", 5},
                                         {"NAME", " ", 28, kMaxNameColumns},
                                         {"CORES", " ", 5, 0, true},
                                         {"MEMORY", " ", 9, 0, true},
                                         {"VERSION", "  ", 8},
                                         {"ENGINE", " ", 16},
                                         {"STATE", " ", 15},
                                         {"LEASES", " ", 6, 0, true},
                                         {"UNITS MERGED", " ", 13, 0, true},
                                         {"SPEED", "  ", 30},
                                         {"LAST SEEN", " ", 0}};
    std::vector<std::vector<std::string>> rows;
    for (const auto& w : workers)
        rows.push_back(
            {std::to_string(w.worker_id()), w.name(), std::to_string(w.cores()),
             absl::StrFormat("%.1f GiB", w.memory_bytes() / double(1 << 30)), w.version(),
             w.engine_fingerprint().empty() ? "-" : w.engine_fingerprint(),
             w.quarantined().empty() ? workerStateText(w) : "quarantined",
             std::to_string(w.leases()), std::to_string(w.units_merged()),
             w.units_merged() > 0 ? speedText(w.samples_per_second(), w.rays_per_second()) : "-",
             absl::StrFormat("%.1f s ago", w.seconds_since_seen())});
    printTable(columns, rows);
    // Why each quarantined worker is: a sentence, too long for a column.
    for (const auto& w : workers)
        if (!w.quarantined().empty())
            std::cout << "worker " << w.worker_id() << " quarantined: " << w.quarantined() << "\n";
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
    settings.set_engine_fingerprint(options.engineFingerprint);
    settings.set_name(options.name);
    if (options.targetError) {
        settings.set_target_error(*options.targetError);
        settings.set_passes(*options.maxPasses);  // the option parser insists on the cap
        settings.set_adaptive(options.adaptive);
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
    sub->add_option("scene", options->scene, "Scene file: Nori XML, or pbrt-v4 for a .pbrt file")
        ->required()
        ->check(CLI::ExistingFile);
    auto* passes = sub->add_option("--passes", options->passes,
                                   "Number of passes (default: the scene's sampleCount)")
                       ->check(kPositiveCount);
    auto* sppOption = sub->add_option("--spp", *spp, "Samples per pixel (= passes)")
                          ->excludes(passes)
                          ->check(kPositiveCount);
    addTargetErrorOptions(*sub, options->targetError, options->maxPasses, options->adaptive,
                          {passes, sppOption});
    sub->add_option("--seed", options->seed, "Random seed; the image is a pure function of it")
        ->check(kSeed);
    sub->add_option("--tile", options->tile, "Tile size in pixels (does not change the image)");
    sub->add_option("--passes-per-unit", options->passesPerUnit,
                    "Passes per work unit (does not change the image)");
    sub->add_option("--priority", options->priority, "Higher runs first; FIFO within a priority");
    sub->add_option("--name", options->name, "Job name (default: the scene's file name)");
    sub->add_option("--integrator", options->integrator,
                    "Use this integrator type instead of the scene's");
    sub->add_option("--engine", options->engineFingerprint,
                    "Render only on workers of this engine fingerprint (16 hex digits, as "
                    "`alphorn workers` lists them); default: the coordinator's own build");
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
    sub->add_option("job", *jobId, "Job id")->check(kId)->required();
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
    sub->add_option("job", *jobId, "Job id (default: every job)")->check(kId);
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::ListJobsRequest request;
                request.set_job_id(*jobId);
                v1::ListJobsResponse response;
                client.callChecked("listing the jobs", "ListJobs", [&] {
                    return client.stub().ListJobs(client.context().get(), request, &response);
                });
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
    sub->add_option("job", *jobId, "Job id")->check(kId)->required();
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                v1::CancelJobRequest request;
                request.set_job_id(*jobId);
                v1::CancelJobResponse response;
                // Cancelling again is harmless: a job that ended (cancelled by the attempt
                // whose answer a coordinator restart lost, say) is answered with its status.
                client.callChecked(absl::StrFormat("cancelling job %u", *jobId), "CancelJob", [&] {
                    return client.stub().CancelJob(client.context().get(), request, &response);
                });
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
    sub->add_option("job", *jobId, "Job id")->check(kId)->required();
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
                client.callChecked("listing the workers", "ListWorkers", [&] {
                    return client.stub().ListWorkers(client.context().get(), request, &response);
                });
                if (connection->json) {
                    std::cout << toJson(response) << "\n";
                    return kExitOk;
                }
                if (response.workers().empty()) {
                    std::cout << (*all ? "no workers\n"
                                       : "no workers seen recently (--all lists every worker)\n");
                    return kExitOk;
                }
                printWorkerTable({response.workers().begin(), response.workers().end()});
                return kExitOk;
            }};
}

namespace {

// A control subcommand on one job: `alphorn NAME JOB [ARG]`, which calls `change` and prints
// what it says (stderr) and the job's row (stdout), or with --json the job's status.
using JobChange = std::function<v1::JobStatus(FarmClient&, uint64_t, std::string&)>;

Command addJobChangeCommand(CLI::App& app, const char* name, const char* description,
                            const std::function<void(CLI::App*)>& addArguments,
                            const JobChange& change) {
    auto connection = std::make_shared<FarmConnectionOptions>();
    auto jobId = std::make_shared<uint64_t>(0);
    CLI::App* sub = app.add_subcommand(name, description);
    sub->add_option("job", *jobId, "Job id")->check(kId)->required();
    if (addArguments) addArguments(sub);
    addConnectionOptions(sub, *connection);
    return {sub, [=] {
                FarmClient client(*connection);
                std::string said;
                const v1::JobStatus status = change(client, *jobId, said);
                if (connection->json) {
                    std::cout << toJson(status) << "\n";
                } else {
                    if (!said.empty()) std::cerr << said << "\n";
                    printStatusLine(status);
                }
                return kExitOk;
            }};
}

// The id of a retry or delete: the same on every attempt, so that a coordinator that made the
// change and restarted before its answer arrived recognises the call asked again and answers
// as the first time (RetryJobRequest.request_id).
std::string newRequestId() {
    return farm::generateToken().substr(0, 32);
}

// Runs a retry's or delete's call the way callChecked() does, asking again with the same request
// id after a coordinator restart. A coordinator older than request ids refuses the change asked
// again, which its first call may have made: the error then says so.
void callWithRequestId(FarmClient& client, const std::string& what, const char* rpc,
                       const std::function<grpc::Status()>& attempt) {
    int attempts = 0;
    const grpc::Status status = client.callRetrying(what, [&] {
        ++attempts;
        return attempt();
    });
    const bool refusedAsDone = status.error_code() == grpc::StatusCode::FAILED_PRECONDITION ||
                               status.error_code() == grpc::StatusCode::NOT_FOUND;
    if (attempts > 1 && refusedAsDone)
        fail(
            "%s: %s (asked again after the coordinator went away; a coordinator older than "
            "this client does not recognise a request asked again, and its first call may "
            "have done it: `alphorn status` shows the job)",
            rpc, status.error_message());
    FarmClient::check(status, rpc);
}

std::string eventKindText(v1::JobEventKind kind) {
    // JOB_EVENT_PRIORITY_CHANGED -> priority-changed
    std::string name = v1::JobEventKind_Name(kind);
    const std::string prefix = "JOB_EVENT_";
    if (name.rfind(prefix, 0) == 0) name = name.substr(prefix.size());
    for (char& c : name) c = c == '_' ? '-' : char(std::tolower(static_cast<unsigned char>(c)));
    return name;
}

void printEvent(const v1::JobEvent& event) {
    std::string who;
    if (event.worker_id() != 0) who = absl::StrFormat("worker %u", event.worker_id());
    if (event.has_unit())
        who += (who.empty() ? "" : " ") + absl::StrFormat("unit %u", event.unit_index());
    std::cout << absl::StrFormat("%s  %6u  %-16s %-20s %s\n",
                                 localTime(event.time_unix_seconds(), true), event.sequence(),
                                 eventKindText(event.kind()), who, event.message());
}

}  // namespace

std::vector<Command> addControlCommands(CLI::App& app) {
    std::vector<Command> commands;
    commands.push_back(addJobChangeCommand(
        app, "retry", "Run a failed or cancelled farm job again (same bytes as a fresh job).",
        [](CLI::App* sub) {
            sub->footer(
                "The job keeps its id. The units in its checkpoint stay merged (their sums are "
                "exact); the others are rendered again with their failed attempts forgotten, so "
                "the image is byte for byte that of a fresh job with the same scene, seed and "
                "passes.");
        },
        [](FarmClient& client, uint64_t jobId, std::string& said) {
            v1::RetryJobRequest request;
            request.set_job_id(jobId);
            request.set_request_id(newRequestId());
            v1::JobControlResponse response;
            callWithRequestId(client, absl::StrFormat("retrying job %u", jobId), "RetryJob", [&] {
                return client.stub().RetryJob(client.context().get(), request, &response);
            });
            said =
                absl::StrFormat("job %u runs again: %u of %u units kept from its checkpoint", jobId,
                                response.status().units_done(), response.status().units_total());
            return response.status();
        }));
    for (const bool pause : {true, false})
        commands.push_back(addJobChangeCommand(
            app, pause ? "pause" : "resume",
            pause ? "Pause a running farm job (no new leases; units out finish and merge)."
                  : "Resume a paused farm job.",
            nullptr, [pause](FarmClient& client, uint64_t jobId, std::string& said) {
                v1::SetJobPausedRequest request;
                request.set_job_id(jobId);
                request.set_paused(pause);
                v1::JobControlResponse response;
                // Pausing a paused job (or resuming a running one) changes nothing: safe to
                // ask again after a coordinator restart.
                client.callChecked(
                    absl::StrFormat("%s job %u", pause ? "pausing" : "resuming", jobId),
                    "SetJobPaused", [&] {
                        return client.stub().SetJobPaused(client.context().get(), request,
                                                          &response);
                    });
                said = pause
                           ? absl::StrFormat("job %u paused; units out, which may still finish: %u",
                                             jobId, response.status().units_leased())
                           : absl::StrFormat("job %u resumed", jobId);
                return response.status();
            }));
    auto priority = std::make_shared<int32_t>(0);
    commands.push_back(addJobChangeCommand(
        app, "priority",
        "Change a running farm job's priority (higher runs first; FIFO within a priority).",
        [priority](CLI::App* sub) {
            sub->add_option("priority", *priority, "The new priority (may be negative)")
                ->required();
        },
        [priority](FarmClient& client, uint64_t jobId, std::string& said) {
            v1::SetJobPriorityRequest request;
            request.set_job_id(jobId);
            request.set_priority(*priority);
            v1::JobControlResponse response;
            client.callChecked(
                absl::StrFormat("changing job %u's priority", jobId), "SetJobPriority", [&] {
                    return client.stub().SetJobPriority(client.context().get(), request, &response);
                });
            said = absl::StrFormat("job %u: priority %d", jobId, *priority);
            return response.status();
        }));

    {
        auto connection = std::make_shared<FarmConnectionOptions>();
        auto jobId = std::make_shared<uint64_t>(0);
        auto cancel = std::make_shared<bool>(false);
        CLI::App* sub = app.add_subcommand(
            "delete", "Delete a farm job now, with the uploaded files only it used.");
        sub->footer(
            "Removes the job's record, event log, images and scene bundle, and the uploaded "
            "files no other job uses (unless a client asked for them since the job was "
            "submitted). A running job is refused unless --cancel.");
        sub->add_option("job", *jobId, "Job id")->check(kId)->required();
        sub->add_flag("--cancel", *cancel, "Cancel the job first if it is still running");
        addConnectionOptions(sub, *connection);
        commands.push_back(
            {sub, [=] {
                 FarmClient client(*connection);
                 v1::DeleteJobRequest request;
                 request.set_job_id(*jobId);
                 request.set_cancel_running(*cancel);
                 request.set_request_id(newRequestId());
                 v1::DeleteJobResponse response;
                 callWithRequestId(
                     client, absl::StrFormat("deleting job %u", *jobId), "DeleteJob", [&] {
                         return client.stub().DeleteJob(client.context().get(), request, &response);
                     });
                 if (connection->json)
                     std::cout << toJson(response) << "\n";
                 else
                     std::cout << absl::StrFormat(
                         "deleted job %u%s; removed %u files (%.1f KiB) no other "
                         "job uses\n",
                         response.job_id(), response.cancelled() ? " (cancelled it first)" : "",
                         response.blobs_removed(), response.blob_bytes_removed() / 1024.0);
                 return kExitOk;
             }});
    }

    {
        auto connection = std::make_shared<FarmConnectionOptions>();
        auto jobId = std::make_shared<uint64_t>(0);
        auto follow = std::make_shared<bool>(false);
        CLI::App* sub = app.add_subcommand("logs", "Print a farm job's event log.");
        sub->footer(
            "Events: submitted, leased, merged, failed (with the worker's error), poisoned, "
            "handed-back, checkpointed, paused, resumed, priority-changed, retried, cancelled, "
            "finished, resumed-after-restart. The coordinator keeps the first 50 and the most "
            "recent events of each job, 1000 in all, and says how many it left out. --json "
            "prints the log as one document, or with --follow one event per line.");
        sub->add_option("job", *jobId, "Job id")->check(kId)->required();
        sub->add_flag("-f,--follow", *follow,
                      "Keep printing new events until the job ends (asks once a second)");
        addConnectionOptions(sub, *connection);
        commands.push_back(
            {sub, [=] {
                 FarmClient client(*connection);
                 uint64_t last = 0;
                 bool headerShown = false;
                 for (;;) {
                     v1::GetJobLogRequest request;
                     request.set_job_id(*jobId);
                     request.set_after_sequence(last);
                     v1::GetJobLogResponse response;
                     client.callChecked(absl::StrFormat("reading job %u's log", *jobId),
                                        "GetJobLog", [&] {
                                            response.Clear();
                                            return client.stub().GetJobLog(client.context().get(),
                                                                           request, &response);
                                        });
                     if (connection->json && !*follow) {
                         std::cout << toJson(response) << "\n";
                         return kExitOk;
                     }
                     if (!connection->json && !headerShown) {
                         std::cout << absl::StrFormat("%-19s  %6s  %-16s %-20s %s\n", "TIME", "SEQ",
                                                      "EVENT", "WORKER/UNIT", "DETAILS");
                         headerShown = true;
                     }
                     for (const v1::JobEvent& event : response.events()) {
                         if (connection->json) {
                             std::cout << toJson(event) << "\n";  // one JSON document per line
                         } else {
                             if (event.sequence() > last + 1)
                                 std::cout << absl::StrFormat(
                                     "...  %u events not kept (the log keeps the first and the "
                                     "most "
                                     "recent)\n",
                                     event.sequence() - last - 1);
                             printEvent(event);
                         }
                         last = event.sequence();
                     }
                     std::cout.flush();
                     if (!*follow || response.state() != v1::JOB_STATE_RUNNING) return kExitOk;
                     std::this_thread::sleep_for(std::chrono::seconds(1));
                 }
             }});
    }

    for (const bool drain : {true, false}) {
        auto connection = std::make_shared<FarmConnectionOptions>();
        auto workerId = std::make_shared<uint64_t>(0);
        CLI::App* sub = app.add_subcommand(
            drain ? "drain" : "undrain",
            drain ? "Drain a farm worker (it finishes its units and gets no new one)."
                  : "Undrain a farm worker (it gets units again).");
        if (drain)
            sub->footer(
                "The worker stays connected and idle until `alphorn undrain`; `alphorn workers` "
                "shows it draining. To stop a worker for good, send it SIGTERM: it finishes its "
                "unit and exits.");
        sub->add_option("worker", *workerId, "Worker id (from `alphorn workers`)")
            ->check(kId)
            ->required();
        addConnectionOptions(sub, *connection);
        commands.push_back(
            {sub, [=] {
                 FarmClient client(*connection);
                 v1::SetWorkerDrainingRequest request;
                 request.set_worker_id(*workerId);
                 request.set_draining(drain);
                 v1::SetWorkerDrainingResponse response;
                 client.callChecked(
                     absl::StrFormat("%s worker %u", drain ? "draining" : "undraining", *workerId),
                     "SetWorkerDraining", [&] {
                         return client.stub().SetWorkerDraining(client.context().get(), request,
                                                                &response);
                     });
                 if (connection->json)
                     std::cout << toJson(response.worker()) << "\n";
                 else
                     printWorkerTable({response.worker()});
                 return kExitOk;
             }});
    }
    return commands;
}

}  // namespace alphorn::cli
