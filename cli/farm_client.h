// The CLI's side of the farm protocol: where the coordinator is, the client token, and the
// calls the farm subcommands share (uploading a bundle, submitting, watching, fetching images).
#pragma once

#include "alphorn/v1/client_service.grpc.pb.h"
#include "cli/commands.h"
#include "common/farm/bundle.h"
#include "common/farm/convert.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace alphorn::cli {

// Exit codes scripts can rely on.
inline constexpr int kExitOk = 0;         // the job finished and its image was written
inline constexpr int kExitError = 1;      // bad input, unreachable coordinator, refused call
inline constexpr int kExitJobFailed = 3;  // the job failed or was cancelled
// `alphorn render` stopped by Ctrl-C (SIGINT): the image of the passes done was written. The
// shell's code for a process ended by SIGINT (128 + 2), so scripts see the interruption.
inline constexpr int kExitInterrupted = 130;

struct FarmConnectionOptions {
    std::string coordinator;  // default: $ALPHORN_COORDINATOR
    std::string tokenFile;    // default: $ALPHORN_TOKEN_FILE
    std::string tlsCa;        // default: $ALPHORN_TLS_CA; nonempty means TLS
    bool json = false;
    // How long a client waits for an unreachable coordinator (at the start, or after losing it
    // in a call it asks again, or while watching a job) before it gives up. 0: no waiting and
    // no second attempt after a failure; a reachable coordinator is still connected to.
    double reconnectSeconds = 60.0;
};

// The client config file: $XDG_CONFIG_HOME/alphorn/config, else ~/.config/alphorn/config.
// Lines "coordinator = HOST:PORT", "token-file = PATH", "tls-ca = PATH" (paths relative to the
// file, or ~/...), "#" comments. Flags and environment variables take precedence.
struct ClientConfig {
    std::string coordinator, tokenFile, tlsCa;
};
std::string clientConfigPath();
// Empty when the file does not exist; throws Error naming file and line for a bad line.
ClientConfig readClientConfig(const std::string& path);

// Adds --coordinator, --token-file, --tls-ca, --reconnect-seconds and --json to a subcommand.
void addConnectionOptions(CLI::App* sub, FarmConnectionOptions& options);

class FarmClient {
  public:
    // Connects to the coordinator, waiting for it up to options.reconnectSeconds; throws Error
    // when it does not answer by then, or at once when it speaks the other protocol (TLS or
    // plaintext) than this client.
    explicit FarmClient(const FarmConnectionOptions& options);

    v1::ClientService::Stub& stub() { return *m_stub; }
    std::unique_ptr<grpc::ClientContext> context(
        std::chrono::milliseconds timeout = std::chrono::milliseconds(60000)) const;
    // Throws Error with the status message (and the RPC's name) unless `status` is OK.
    static void check(const grpc::Status& status, const char* what);

    // Runs `attempt` (one try of a call that may be repeated without harm: it reads, or sets
    // what a second try sets alike) until it returns a status other than one of a coordinator
    // that went away or cannot answer for the moment (UNAVAILABLE, CANCELLED, ABORTED), which
    // it returns; after such a status it says once on stderr, naming `what`, that it waits, and
    // waits as watch() does. Gives up, returning the last status or throwing Error,
    // --reconnect-seconds after the first failure. With a nonempty `deadlineRetryNote`,
    // DEADLINE_EXCEEDED is retried too (a call the coordinator may still be working on), and
    // the note, said on stderr each time, tells why asking again is safe.
    grpc::Status callRetrying(const std::string& what, const std::function<grpc::Status()>& attempt,
                              const std::string& deadlineRetryNote = "");
    // callRetrying(), then check() with the RPC's name `rpc`: the way the farm commands whose
    // call may be repeated make it, so that they outlast a coordinator restart.
    void callChecked(const std::string& what, const char* rpc,
                     const std::function<grpc::Status()>& attempt);

    // Gathers the scene's bundle, uploads the blobs the coordinator lacks, submits the job.
    v1::JobStatus submit(const std::string& scenePath, const v1::JobSettings& settings, bool quiet);
    // Follows the job until it ends; shows a progress bar unless quiet. Returns the last status.
    v1::JobStatus watch(uint64_t jobId, bool quiet);
    // The whole image file (EXR, PNG or film).
    std::string getImage(uint64_t jobId, v1::ImageFormat format, bool preview,
                         v1::ImageChunk* header = nullptr);
    // Writes OUT.exr and the PNG beside it.
    void fetchImages(uint64_t jobId, const std::string& exrPath, bool preview);

  private:
    // Blocks until the channel is connected; throws Error as the constructor says. With
    // `announce`, says on stderr that it waits when that takes more than two seconds. The
    // `firstConnection` (the constructor's) has its first attempt's time even past `deadline`.
    void waitForCoordinator(std::chrono::steady_clock::time_point deadline, bool announce,
                            bool firstConnection);
    // When a client that lost the coordinator at `lostAt` gives up: --reconnect-seconds later.
    std::chrono::steady_clock::time_point reconnectDeadline(
        std::chrono::steady_clock::time_point lostAt) const;
    // After a call broke because the coordinator went away at `lostAt`: waits for it to accept
    // connections again (after a short pause, with `pause`), until reconnectDeadline(lostAt);
    // throws Error then. What watch() and callRetrying() share.
    void awaitCoordinatorBack(std::chrono::steady_clock::time_point lostAt, bool pause);
    // Asks which of the bundle's blobs the coordinator lacks and uploads those; on failure
    // returns the status and sets `failedCall` to the call's name.
    grpc::Status uploadMissingBlobs(const farm::Bundle& bundle, bool quiet,
                                    std::string& failedCall);

    std::string m_address;
    bool m_tls = false;
    double m_reconnectSeconds = 60.0;
    std::string m_token;
    std::shared_ptr<grpc::Channel> m_channel;
    std::unique_ptr<v1::ClientService::Stub> m_stub;
};

using farm::toJson;
// "user@host": who submits, as `alphorn status` shows it ($USER, else the password database).
std::string submitterName();

}  // namespace alphorn::cli

namespace alphorn::cli {

struct SubmitOptions {
    std::string scene;
    std::string output;   // nonempty: wait for the job and write OUT.exr and OUT.png
    uint32_t passes = 0;  // 0: the scene's sampleCount
    uint64_t seed = 0;
    uint32_t tile = 0;
    uint32_t passesPerUnit = 0;
    int32_t priority = 0;
    std::string name;
    std::string integrator;
    std::string engineFingerprint;  // --engine: workers of this build only (default: the farm's)
    bool watch = false;
    // --target-error and its cap --max-passes (which then replaces `passes`).
    std::optional<double> targetError;
    std::optional<uint32_t> maxPasses;
    bool adaptive = false;  // --adaptive: tile-adaptive passes (with a target)
};

// The job's error estimate for progress and status lines: "err 3.1% -> 2% (~64 passes)".
std::string statusErrorText(const v1::JobStatus& status);

// `alphorn submit` after option parsing; also what `alphorn cluster --render` runs.
int runSubmit(FarmClient& client, const SubmitOptions& options, bool json);

// Job and worker control (cli/farm_commands.cpp): retry, pause, resume, priority, delete, logs,
// drain, undrain.
std::vector<Command> addControlCommands(CLI::App& app);

}  // namespace alphorn::cli
