#include "cli/farm_client.h"

#include "cli/progress.h"
#include "common/core/error.h"
#include "common/core/image.h"
#include "common/core/properties.h"
#include "common/farm/bundle.h"
#include "common/farm/chunks.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/farm/rpc.h"

#include <absl/strings/ascii.h>
#include <absl/strings/match.h>
#include <absl/strings/str_format.h>

#include <pwd.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

namespace alphorn::cli {

namespace fs = std::filesystem;

static std::string fromEnvironment(const char* name) {
    const char* value = std::getenv(name);
    return value ? value : "";
}

std::string statusErrorText(const v1::JobStatus& status) {
    std::optional<ErrorEstimate> estimate;
    if (status.has_error_estimate()) {
        estimate = ErrorEstimate();
        estimate->relativeRmse = status.error_estimate();
        estimate->passes = status.error_estimate_passes();
        if (status.has_error_bias()) estimate->relativeBias = status.error_bias();
    }
    const v1::JobSettings& settings = status.settings();
    // The coordinator's projection uses the slope it measured over the decision points.
    std::string text = errorText(
        estimate,
        settings.has_target_error() ? std::optional<double>(settings.target_error()) : std::nullopt,
        status.has_projected_passes() ? std::optional<double>(status.projected_passes())
                                      : std::nullopt);
    if (status.adaptive_tiles() > 0)
        text += absl::StrFormat(" [%u/%u tiles done]", status.adaptive_tiles_finished(),
                                status.adaptive_tiles());
    return text;
}

void addConnectionOptions(CLI::App* sub, FarmConnectionOptions& options) {
    sub->add_option("--coordinator", options.coordinator,
                    "Coordinator address host:port (or $ALPHORN_COORDINATOR, or the config file)");
    sub->add_option("--token-file", options.tokenFile,
                    "Client token file (or $ALPHORN_TOKEN_FILE, or the config file)");
    sub->add_option(
        "--tls-ca", options.tlsCa,
        "CA certificate to verify a TLS coordinator (or $ALPHORN_TLS_CA, or the config file)");
    sub->add_option("--reconnect-seconds", options.reconnectSeconds,
                    "How long to wait for an unreachable or restarting coordinator before giving "
                    "up: at the start, and after a call the coordinator broke by going away, "
                    "which is then asked again (submit with its submission id, also when a "
                    "call outlasts its time limit, and never creates a second job; retry and "
                    "delete with their request id, and never act twice). 0: give up at the first "
                    "failure (a reachable coordinator is still connected to)")
        ->capture_default_str()
        ->check(kFinite & CLI::Range(0.0, 86400.0));
    sub->add_flag("--json", options.json, "Machine-readable JSON on stdout");
}

namespace {

using Clock = std::chrono::steady_clock;

// How long a client's first connection attempt may take, whatever --reconnect-seconds says
// (gRPC abandons an attempt after 20 s; a healthy coordinator answers in milliseconds, a busy
// one in a few seconds).
constexpr double kFirstConnectionSeconds = 10.0;

std::chrono::system_clock::time_point toSystemClock(Clock::time_point when) {
    return std::chrono::system_clock::now() +
           std::chrono::duration_cast<std::chrono::system_clock::duration>(when - Clock::now());
}

double secondsSince(Clock::time_point start) {
    return std::chrono::duration<double>(Clock::now() - start).count();
}

// A line of its own on stderr, also when a progress bar occupies the current one.
void note(const std::string& line) {
    if (isatty(STDERR_FILENO)) std::cerr << "\r\033[K";
    std::cerr << line << std::endl;
}

// A status by which a call failed because the coordinator went away (stopped, restarted,
// unreachable, the connection broke: "Socket closed", "Connection reset by peer"), or could not
// serve it for the moment, not because the request was wrong: asking again may succeed.
bool callBrokenByCoordinator(const grpc::Status& status) {
    switch (status.error_code()) {
        case grpc::StatusCode::UNAVAILABLE:
        case grpc::StatusCode::CANCELLED:  // the server cancels open calls when it stops
        case grpc::StatusCode::ABORTED:
            return true;
        default:
            return false;
    }
}

// A status by which a WatchJob stream ended because the coordinator went away, which includes
// a stream it closed while the job was still running.
bool coordinatorWentAway(const grpc::Status& status) {
    return status.ok() || callBrokenByCoordinator(status);
}

// The time limit of SubmitJob's first attempt: a minute, as every unary call has. Test hook
// (documented in docs/operations.md): ALPHORN_TEST_SUBMIT_TIME_LIMIT_MS=N sets it to N ms, so
// integration tests can let it pass while the coordinator works on the submission.
std::chrono::milliseconds submitTimeLimit() {
    const std::string limit = fromEnvironment("ALPHORN_TEST_SUBMIT_TIME_LIMIT_MS");
    return std::chrono::milliseconds(limit.empty() ? 60000 : std::max(1, std::atoi(limit.c_str())));
}

}  // namespace

std::string clientConfigPath() {
    const std::string configHome = fromEnvironment("XDG_CONFIG_HOME");
    if (!configHome.empty()) return configHome + "/alphorn/config";
    const std::string home = fromEnvironment("HOME");
    return home.empty() ? "" : home + "/.config/alphorn/config";
}

ClientConfig readClientConfig(const std::string& path) {
    ClientConfig config;
    std::ifstream file(path);
    if (!file) return config;
    const fs::path directory = fs::path(path).parent_path();
    int lineNumber = 0;
    for (std::string line; std::getline(file, line);) {
        ++lineNumber;
        const std::string text(absl::StripAsciiWhitespace(line.substr(0, line.find('#'))));
        if (text.empty()) continue;
        const size_t equals = text.find('=');
        if (equals == std::string::npos)
            fail("%s:%d: expected KEY = VALUE (coordinator, token-file, tls-ca), got \"%s\"", path,
                 lineNumber, text);
        const std::string key(absl::StripAsciiWhitespace(text.substr(0, equals)));
        const std::string value(absl::StripAsciiWhitespace(text.substr(equals + 1)));
        // Files named relative to the config file, and ~/ for the home directory.
        auto pathValue = [&] {
            if (absl::StartsWith(value, "~/")) return fromEnvironment("HOME") + value.substr(1);
            return fs::path(value).is_absolute() ? value : (directory / value).string();
        };
        if (key == "coordinator") {
            config.coordinator = value;
        } else if (key == "token-file") {
            config.tokenFile = pathValue();
        } else if (key == "tls-ca") {
            config.tlsCa = pathValue();
        } else {
            const std::string intended = closestName(key, {"coordinator", "token-file", "tls-ca"});
            fail("%s:%d: unknown key \"%s\"%s (known: coordinator, token-file, tls-ca)", path,
                 lineNumber, key,
                 intended.empty() ? "" : absl::StrFormat("; did you mean \"%s\"?", intended));
        }
        if (value.empty()) fail("%s:%d: \"%s\" has no value", path, lineNumber, key);
    }
    return config;
}

FarmClient::FarmClient(const FarmConnectionOptions& options) {
    // The command line first, then the environment, then the config file.
    const ClientConfig config = readClientConfig(clientConfigPath());
    auto pick = [](const std::string& flag, const char* variable, const std::string& configured) {
        if (!flag.empty()) return flag;
        const std::string environment = fromEnvironment(variable);
        return environment.empty() ? configured : environment;
    };
    std::string address = pick(options.coordinator, "ALPHORN_COORDINATOR", config.coordinator);
    std::string tokenFile = pick(options.tokenFile, "ALPHORN_TOKEN_FILE", config.tokenFile);
    std::string tlsCa = pick(options.tlsCa, "ALPHORN_TLS_CA", config.tlsCa);
    if (address.empty())
        fail(
            "no coordinator: pass --coordinator HOST:PORT, set ALPHORN_COORDINATOR or write "
            "\"coordinator = HOST:PORT\" in %s",
            clientConfigPath());
    if (tokenFile.empty())
        fail(
            "no token: pass --token-file F, set ALPHORN_TOKEN_FILE or write \"token-file = F\" "
            "in %s",
            clientConfigPath());
    m_token = farm::readTokenFile(tokenFile);
    m_address = address;
    m_tls = !tlsCa.empty();
    m_reconnectSeconds = options.reconnectSeconds;
    m_channel = farm::makeChannel(address, tlsCa);
    m_stub = v1::ClientService::NewStub(m_channel);
    waitForCoordinator(Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                          std::chrono::duration<double>(m_reconnectSeconds)),
                       true, true);
}

void FarmClient::waitForCoordinator(Clock::time_point deadline, bool announce,
                                    bool firstConnection) {
    const auto start = Clock::now();
    // --reconnect-seconds bounds the wait for a coordinator that cannot be reached, not the
    // connecting to one that can: a client's first connection may take kFirstConnectionSeconds
    // until an attempt has failed, however little the option allows, so that 0 (no waiting
    // after a failure) still reaches a healthy coordinator.
    const Clock::time_point firstAttemptDeadline =
        start + std::chrono::duration_cast<Clock::duration>(
                    std::chrono::duration<double>(kFirstConnectionSeconds));
    bool attemptFailed = !firstConnection;
    bool probed = false, announced = !announce;
    grpc_connectivity_state state = m_channel->GetState(true);
    while (state != GRPC_CHANNEL_READY) {
        if (state == GRPC_CHANNEL_TRANSIENT_FAILURE) attemptFailed = true;
        if (state == GRPC_CHANNEL_TRANSIENT_FAILURE && !probed) {
            // A coordinator speaking the other protocol closes every attempt; waiting for it
            // would never help, so say so at once.
            probed = true;
            const std::string hint =
                farm::protocolMismatchHint(m_address, m_tls, "--tls-ca (or ALPHORN_TLS_CA)");
            if (!hint.empty()) fail("%s", hint);
        }
        const Clock::time_point giveUpAt =
            attemptFailed ? deadline : std::max(deadline, firstAttemptDeadline);
        if (!announced && secondsSince(start) >= 2.0) {
            announced = true;
            note(absl::StrFormat("waiting for the coordinator at %s (giving up after %.0f s)",
                                 m_address, std::max(0.0, m_reconnectSeconds)));
        }
        // Waiting here is also what moves the connection attempt forward (see makeContext).
        const auto step = std::min(giveUpAt, Clock::now() + std::chrono::seconds(1));
        if (!m_channel->WaitForStateChange(state, toSystemClock(step)) &&
            Clock::now() >= giveUpAt) {
            const double waited = secondsSince(start);
            const bool refused =
                farm::probeWireProtocol(m_address, std::chrono::milliseconds(1000)) ==
                farm::WireProtocol::Unreachable;
            fail(
                "cannot reach the coordinator at %s: no connection within %.0f s (%s; "
                "--reconnect-seconds sets how long to wait)",
                m_address, waited,
                refused ? "nothing accepts connections there"
                        : "it accepts connections but does not complete a gRPC connection");
        }
        state = m_channel->GetState(true);
    }
}

Clock::time_point FarmClient::reconnectDeadline(Clock::time_point lostAt) const {
    return lostAt + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double>(m_reconnectSeconds));
}

void FarmClient::awaitCoordinatorBack(Clock::time_point lostAt, bool pause) {
    // A coordinator that is stopping may still look connected for a moment; do not spin.
    if (pause) std::this_thread::sleep_for(std::chrono::milliseconds(200));
    waitForCoordinator(reconnectDeadline(lostAt), false, false);
}

grpc::Status FarmClient::callRetrying(const std::string& what,
                                      const std::function<grpc::Status()>& attempt,
                                      const std::string& deadlineRetryNote) {
    std::optional<Clock::time_point> lostAt;
    bool wentAway = false;  // some attempt broke because of the coordinator (not a time limit)
    for (;;) {
        const grpc::Status status = attempt();
        const bool deadlinePassed = status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED &&
                                    !deadlineRetryNote.empty();
        if (!callBrokenByCoordinator(status) && !deadlinePassed) {
            if (lostAt)
                note(wentAway ? absl::StrFormat("%s: reconnected to the coordinator after %.1f s",
                                                what, secondsSince(*lostAt))
                              : absl::StrFormat("%s: answered when asked again, %.1f s after "
                                                "the time limit passed",
                                                what, secondsSince(*lostAt)));
            return status;
        }
        // --reconnect-seconds 0: no second attempt, and no note promising one.
        if (m_reconnectSeconds <= 0) return status;
        const bool first = !wentAway && !deadlinePassed;
        if (!deadlinePassed) wentAway = true;
        if (!lostAt) lostAt = Clock::now();
        if (deadlinePassed) {
            // Said each time: every such attempt waited out a whole time limit.
            note(absl::StrFormat(
                "%s: no answer within the call's time limit (%s); %s (giving up "
                "after %.0f s)",
                what, status.error_message(), deadlineRetryNote, m_reconnectSeconds));
        } else if (first) {
            note(absl::StrFormat(
                "%s: the coordinator went away or cannot answer (%s); waiting for it (giving up "
                "after %.0f s)",
                what, status.error_message(), m_reconnectSeconds));
        }
        // A coordinator that answers but cannot serve (it cannot write its state) keeps the
        // channel connected: the time limit must hold without waitForCoordinator() too.
        if (Clock::now() >= reconnectDeadline(*lostAt)) return status;
        awaitCoordinatorBack(*lostAt, true);
    }
}

void FarmClient::callChecked(const std::string& what, const char* rpc,
                             const std::function<grpc::Status()>& attempt) {
    check(callRetrying(what, attempt), rpc);
}

std::unique_ptr<grpc::ClientContext> FarmClient::context(std::chrono::milliseconds timeout) const {
    return farm::makeContext(m_token, timeout);
}

void FarmClient::check(const grpc::Status& status, const char* what) {
    if (!status.ok()) fail("%s: %s", what, status.error_message());
}

std::string submitterName() {
    std::string user;
    if (const char* name = std::getenv("USER"); name && *name) user = name;
    if (user.empty())
        if (const passwd* entry = ::getpwuid(::getuid()); entry && entry->pw_name)
            user = entry->pw_name;
    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    return (user.empty() ? "uid" + std::to_string(::getuid()) : user) + "@" + host;
}

grpc::Status FarmClient::uploadMissingBlobs(const farm::Bundle& bundle, bool quiet,
                                            std::string& failedCall) {
    failedCall = "HasBlobs";
    v1::HasBlobsRequest has;
    for (const auto& file : bundle.files) has.add_sha256(file.sha256);
    v1::HasBlobsResponse missing;
    if (grpc::Status status = m_stub->HasBlobs(context().get(), has, &missing); !status.ok())
        return status;
    std::set<std::string> toUpload(missing.missing().begin(), missing.missing().end());
    if (toUpload.empty()) return grpc::Status::OK;

    failedCall = "PutBlobs";
    auto ctx = context(std::chrono::milliseconds(3600 * 1000));
    v1::PutBlobsResponse response;
    auto writer = m_stub->PutBlobs(ctx.get(), &response);
    uint64_t bytes = 0;
    for (const auto& file : bundle.files) {
        if (!toUpload.erase(file.sha256)) continue;  // two paths with the same content go once
        std::ifstream in(file.sourcePath, std::ios::binary);
        if (!in) fail("%s: cannot open", file.sourcePath);
        const bool sent = farm::sendChunks(
            in,
            [&](std::string_view data, bool, bool last) {
                v1::BlobChunk chunk;
                chunk.set_sha256(file.sha256);
                chunk.set_data(std::string(data));
                chunk.set_last(last);
                bytes += data.size();
                return writer->Write(chunk);
            },
            farm::kChunkBytes);
        if (!sent) break;  // the coordinator ended the stream: Finish() says why
    }
    writer->WritesDone();
    grpc::Status status = writer->Finish();
    if (status.ok() && !quiet)
        std::cerr << absl::StrFormat("uploaded %u blobs (%.1f KiB)\n", response.stored(),
                                     bytes / 1024.0);
    return status;
}

v1::JobStatus FarmClient::submit(const std::string& scenePath, const v1::JobSettings& settings,
                                 bool quiet) {
    const farm::Bundle bundle = farm::gatherBundle(scenePath);

    // Uploads are idempotent (blobs are named by their content): after a broken call the
    // client asks again which blobs are missing and sends those.
    std::string failedCall;
    check(callRetrying("uploading the scene",
                       [&] { return uploadMissingBlobs(bundle, quiet, failedCall); }),
          failedCall.c_str());

    v1::SubmitJobRequest request;
    *request.mutable_bundle() = farm::toProto(bundle);
    *request.mutable_settings() = settings;
    if (request.settings().owner().empty()) request.mutable_settings()->set_owner(submitterName());
    // The same id on every attempt: a SubmitJob whose answer was lost (the coordinator
    // restarted after creating the job) gives that job when asked again, not a second one.
    request.set_submission_id(farm::generateToken().substr(0, 32));
    v1::SubmitJobResponse response;
    // Loading a large scene can outlast the call's time limit while the coordinator goes on.
    // Asking again with the same submission id is safe: the coordinator gives the job the
    // first call created, or hands the job of a first call still loading to this one, and
    // never creates a second. Each such attempt may wait twice as long as the one before.
    std::chrono::milliseconds timeLimit = submitTimeLimit();
    const auto submitOnce = [&] {
        response.Clear();
        const grpc::Status status = m_stub->SubmitJob(context(timeLimit).get(), request, &response);
        if (status.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED) timeLimit *= 2;
        return status;
    };
    // Given up on a coordinator that went away or did not answer: it may have created the job.
    const char* unknownOutcome =
        "; the job may have been created before the coordinator went away: `alphorn status` "
        "lists the jobs";
    grpc::Status submitted;
    try {
        submitted = callRetrying(
            "submitting the job", submitOnce,
            "the coordinator may still be loading the scene: asking again with the same "
            "submission id, which gives the job the first call creates and never a second one");
    } catch (const Error& e) {
        fail("%s%s", e.what(), unknownOutcome);
    }
    if (callBrokenByCoordinator(submitted) ||
        submitted.error_code() == grpc::StatusCode::DEADLINE_EXCEEDED)
        fail("SubmitJob: %s%s", submitted.error_message(), unknownOutcome);
    check(submitted, "SubmitJob");
    return response.status();
}

v1::JobStatus FarmClient::watch(uint64_t jobId, bool quiet) {
    v1::WatchJobRequest request;
    request.set_job_id(jobId);
    std::unique_ptr<ProgressLine> progress;
    v1::JobStatus last;
    bool lost = false;         // the coordinator went away and has not sent a status since
    Clock::time_point lostAt;  // when it went away
    for (;;) {
        // Not waiting for ready: the channel was just found connected, and should the
        // coordinator go away again this very moment, the failure leads back to
        // waitForCoordinator() and its time limit rather than into an unbounded wait.
        auto ctx = farm::makeContext(
            m_token, std::chrono::milliseconds(int64_t(30) * 24 * 3600 * 1000), false);
        auto reader = m_stub->WatchJob(ctx.get(), request);
        v1::JobStatus status;
        bool received = false;
        while (reader->Read(&status)) {
            received = true;
            if (lost) {
                note(absl::StrFormat("job %u: reconnected to the coordinator after %.1f s", jobId,
                                     secondsSince(lostAt)));
                lost = false;
            }
            last = status;
            if (quiet) continue;
            // Counted in merged units, which move between passes (a pass is done only when its
            // every tile is merged, so a count of passes would sit still for a long time).
            if (!progress)
                progress = std::make_unique<ProgressLine>(absl::StrFormat("job %u", jobId),
                                                          status.units_total(), "units");
            progress->update(
                status.units_done(),
                absl::StrFormat("%s%u/%u passes  %s  %s  %u workers%s",
                                status.paused() ? "paused  " : "", status.passes_done(),
                                status.settings().passes(), statusErrorText(status),
                                speedText(status.samples_per_second(), status.rays_per_second()),
                                status.active_workers(),
                                status.has_photon_radius()
                                    ? absl::StrFormat("  radius %.4g", status.photon_radius())
                                    : ""),
                status.elapsed_seconds(), status.eta_seconds());
        }
        grpc::Status finished = reader->Finish();
        if (finished.ok() && last.state() != v1::JOB_STATE_RUNNING &&
            last.state() != v1::JOB_STATE_UNSPECIFIED)
            break;
        if (!coordinatorWentAway(finished)) check(finished, "WatchJob");
        if (!lost) {
            lost = true;
            lostAt = Clock::now();
            note(absl::StrFormat(
                "job %u: coordinator restarted, reconnecting (the connection ended: %s; giving up "
                "after %.0f s)",
                jobId, finished.ok() ? "closed by the coordinator" : finished.error_message(),
                m_reconnectSeconds));
        }
        try {
            awaitCoordinatorBack(lostAt, !received);
        } catch (const Error& e) {
            fail("job %u: %s; the job itself goes on: `alphorn watch %u` follows it again", jobId,
                 e.what(), jobId);
        }
    }
    if (progress) progress->finish(farm::jobStateName(last.state()));
    return last;
}

std::string FarmClient::getImage(uint64_t jobId, v1::ImageFormat format, bool preview,
                                 v1::ImageChunk* header) {
    v1::GetImageRequest request;
    request.set_job_id(jobId);
    request.set_format(format);
    request.set_preview(preview);
    std::string bytes;
    // A download broken by a coordinator restart starts again from its first byte.
    callChecked(absl::StrFormat("fetching job %u's image", jobId), "GetImage", [&] {
        auto ctx = context(std::chrono::milliseconds(600 * 1000));
        auto reader = m_stub->GetImage(ctx.get(), request);
        bytes.clear();
        bool first = true;
        farm::receiveChunks<grpc::ClientReader<v1::ImageChunk>, v1::ImageChunk>(
            *reader, bytes, [&](const v1::ImageChunk& chunk) {
                if (first && header) {
                    *header = chunk;
                    header->clear_data();
                }
                first = false;
                return true;
            });
        return reader->Finish();
    });
    return bytes;
}

static void writeBytes(const std::string& path, const std::string& bytes) {
    if (auto parent = fs::path(path).parent_path(); !parent.empty()) fs::create_directories(parent);
    farm::writeFileAtomically(path, bytes);
}

void FarmClient::fetchImages(uint64_t jobId, const std::string& exrPath, bool preview) {
    writeBytes(exrPath, getImage(jobId, v1::IMAGE_FORMAT_EXR, preview));
    writeBytes(pngPathFor(exrPath), getImage(jobId, v1::IMAGE_FORMAT_PNG, preview));
}

}  // namespace alphorn::cli
