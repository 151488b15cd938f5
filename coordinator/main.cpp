// alphorn-coordinator: the farm's long-running daemon. It accepts jobs from clients, leases
// units to workers, merges their results exactly and checkpoints every job, so that a restart
// on the same --state-dir resumes everything. See docs/operations.md.
#include "common/farm/engine_fingerprint.h"
#include "common/farm/files.h"
#include "common/farm/http_server.h"
#include "common/farm/metrics.h"
#include "common/farm/number_options.h"
#include "common/farm/rpc.h"
#include "coordinator/coordinator.h"
#include "coordinator/dashboard.h"
#include "coordinator/log.h"
#include "coordinator/metrics.h"
#include "coordinator/services.h"

#include <absl/strings/str_format.h>
#include <CLI/CLI.hpp>

#include <sys/resource.h>

#include <csignal>

using namespace alphorn;
using namespace alphorn::coordinator;

namespace {

// Every connection holds a file descriptor, and at the process's limit gRPC's listener stops
// accepting for good (gRPC 1.51 gives up after accept4's EMFILE). The soft limit, often 1024, is
// raised to the hard one (systemd's default is 524288) so that no burst of connections reaches
// it; silent connections are closed after the handshake timeout (farm::configureServer).
void raiseOpenFileLimit() {
    rlimit limit{};
    if (::getrlimit(RLIMIT_NOFILE, &limit) != 0 || limit.rlim_cur >= limit.rlim_max) return;
    const rlim_t before = limit.rlim_cur;
    limit.rlim_cur = limit.rlim_max;
    if (::setrlimit(RLIMIT_NOFILE, &limit) == 0)
        logInfo("limits.open_files",
                {field("before", uint64_t(before)), field("now", uint64_t(limit.rlim_cur))});
}

}  // namespace

int main(int argc, char** argv) {
    CLI::App app{
        "alphorn-coordinator: schedules render units to workers and merges their results."};
    app.set_version_flag("--version", std::string("alphorn-coordinator ") + ALPHORN_VERSION +
                                          " (engine " + farm::engineFingerprint() + ")");
    std::string listen = "127.0.0.1:7700", clientTokenFile, workerTokenFile, tlsCert, tlsKey,
                portFile;
    CoordinatorOptions options;
    app.add_option("--listen", listen, "Address to listen on (host:port; port 0 picks a free one)");
    app.add_option("--state-dir", options.stateDirectory,
                   "Directory for the database, blobs and checkpoints")
        ->required();
    app.add_option("--client-token-file", clientTokenFile, "File holding the clients' bearer token")
        ->required();
    app.add_option("--worker-token-file", workerTokenFile, "File holding the workers' bearer token")
        ->required();
    app.add_option("--tls-cert", tlsCert, "PEM certificate chain: serve TLS (with --tls-key)");
    app.add_option("--tls-key", tlsKey, "PEM private key of --tls-cert");
    app.add_option("--checkpoint-interval", options.checkpointIntervalSeconds,
                   "Seconds between film checkpoints (longer when writing a round of them "
                   "takes over 5% of the time)")
        ->check(farm::kFinite & CLI::Range(0.05, 3600.0));
    app.add_option("--lease-seconds", options.leaseSeconds,
                   "Seconds a unit lease lasts without a heartbeat")
        ->check(farm::kFinite & CLI::Range(0.2, 86400.0));
    app.add_option("--max-attempts", options.maxAttempts,
                   "Failed attempts of one unit (worker errors and expired leases, counted over "
                   "all workers) after which it fails its job; a unit that failed on a worker "
                   "goes to another one first while one is alive")
        ->check(CLI::Range(1, 1000));
    app.add_option("--audit", options.auditFraction,
                   "Share of units rendered again by a second worker and compared byte for byte "
                   "before merging (besides each worker's first unit of each job, always "
                   "audited); a worker whose result a third render contradicts is quarantined")
        ->capture_default_str()
        ->check(farm::kFinite & CLI::Range(0.0, 1.0));
    app.add_option("--max-blob-bytes", options.maxBlobBytes, "Largest blob accepted");
    app.add_option("--max-bundle-bytes", options.maxBundleBytes, "Largest scene bundle accepted");
    app.add_option("--max-image-pixels", options.maxImagePixels,
                   "Largest image (width x height) accepted");
    app.add_option("--max-passes", options.maxPasses, "Most passes a job may ask for");
    double keepFinishedHours = options.keepFinishedSeconds / 3600;
    app.add_option("--keep-finished-hours", keepFinishedHours,
                   "Hours an ended job stays listed (a done job's image fetchable) before its "
                   "record, images and bundle are removed (with blobs no remaining job uses); 0 "
                   "keeps them forever")
        ->capture_default_str()
        ->check(farm::kFinite & CLI::Range(0.0, 1e6));
    app.add_option("--max-memory", options.maxMemoryBytes,
                   "Memory the running jobs' films and unit tables may take together, e.g. 8GB "
                   "(default: half the physical memory); a job that would exceed it is refused")
        ->transform(CLI::AsSizeValue(false))
        // transform() puts a validator first: the sign is checked before the size is read.
        ->transform(farm::kDecimalSize);
    app.add_option("--port-file", portFile, "Write the bound port to this file once listening");
    std::string httpListen, httpPortFile, metricsTokenFile;
    bool anonymousMetrics = false;
    CLI::Option* http = app.add_option(
        "--http-listen", httpListen,
        "Serve HTTP on this address (host:port; port 0 picks a free one): /metrics for "
        "Prometheus and, with --dashboard, the web dashboard; with TLS when --tls-cert is "
        "given. Off by default");
    app.add_option("--http-port-file", httpPortFile,
                   "Write the bound HTTP port to this file once listening")
        ->needs(http);
    app.add_option("--metrics-token-file", metricsTokenFile,
                   "File holding a token that may read /metrics and nothing else (for "
                   "Prometheus; the client token reads it too)")
        ->needs(http);
    app.add_flag("--http-anonymous-metrics", anonymousMetrics,
                 "Serve /metrics to anyone, without a token (only on a trusted network)")
        ->needs(http);
    bool dashboard = false;
    std::string viewerTokenFile;
    CLI::Option* dashboardFlag =
        app.add_flag("--dashboard", dashboard,
                     "Serve the web dashboard on --http-listen (/dashboard/; log in with the "
                     "client token, or the viewer token to look only)")
            ->needs(http);
    app.add_option("--dashboard-viewer-token-file", viewerTokenFile,
                   "File holding a token that may look at the dashboard but not act")
        ->needs(dashboardFlag);
    farm::requireDecimalNumbers(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // CLI11's own codes (105, 106, ...) are not the documented ones: a usage error exits 1.
        return app.exit(e) == 0 ? 0 : 1;
    }
    options.keepFinishedSeconds = keepFinishedHours * 3600;
    // From here on stderr is the log: one event per line, whoever writes.
    farm::routeLibraryOutputToLog();

    // A file size limit (ulimit -f) must fail the write that exceeds it, like a full disk, not
    // kill the coordinator.
    std::signal(SIGXFSZ, SIG_IGN);
    raiseOpenFileLimit();
    // Signals are taken by sigwait() in this thread below, so every thread blocks them (those
    // started later inherit the mask).
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    try {
        const std::string clientToken = farm::readTokenFile(clientTokenFile);
        const std::string workerToken = farm::readTokenFile(workerTokenFile);
        if (clientToken == workerToken)
            fail(
                "the client and worker tokens must differ (a worker must not be able to submit "
                "jobs)");
        std::string metricsToken;
        if (!metricsTokenFile.empty()) {
            metricsToken = farm::readTokenFile(metricsTokenFile);
            if (metricsToken == workerToken)
                fail(
                    "the metrics token must differ from the worker token (whoever scrapes "
                    "metrics must not be able to pose as a worker)");
        }
        std::string viewerToken;
        if (!viewerTokenFile.empty()) {
            viewerToken = farm::readTokenFile(viewerTokenFile);
            if (viewerToken == workerToken || viewerToken == clientToken)
                fail(
                    "the dashboard viewer token must differ from the client and worker tokens "
                    "(a viewer must not be able to act or to pose as a worker)");
        }
        Coordinator coordinator(options);
        ClientServiceImpl clientService(coordinator, clientToken);
        WorkerServiceImpl workerService(coordinator, workerToken);

        grpc::ServerBuilder builder;
        int port = 0;
        builder.AddListeningPort(listen, farm::makeServerCredentials(tlsCert, tlsKey), &port);
        // Without this gRPC sets SO_REUSEPORT and a second coordinator on the same port starts
        // too, taking part of the clients' calls.
        builder.AddChannelArgument(GRPC_ARG_ALLOW_REUSEPORT, 0);
        farm::configureServer(builder);
        builder.RegisterService(&clientService);
        builder.RegisterService(&workerService);
        std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
        if (!server || port == 0) fail("cannot listen on %s", listen);
        // Declared after the coordinator, so they stop before the coordinator goes.
        std::unique_ptr<Dashboard> webDashboard;
        std::unique_ptr<farm::HttpServer> httpServer;
        if (!httpListen.empty()) {
            httpServer = std::make_unique<farm::HttpServer>(
                farm::HttpServerOptions{httpListen, tlsCert, tlsKey});
            farm::RouteAccess metricsAccess{{clientToken}, anonymousMetrics};
            if (!metricsToken.empty()) metricsAccess.tokens.push_back(metricsToken);
            farm::serveMetrics(*httpServer,
                               {farm::CoordinatorMetrics::registry(),
                                std::make_shared<CoordinatorStateMetrics>(coordinator)},
                               metricsAccess);
            if (dashboard) {
                webDashboard = std::make_unique<Dashboard>(
                    coordinator, DashboardOptions{clientToken, viewerToken, !tlsCert.empty()});
                webDashboard->install(*httpServer);
                webDashboard->start();
            }
            httpServer->start();
            logInfo("http.listening",
                    {field("address", httpListen), field("port", httpServer->port()),
                     field("tls", httpServer->tls() ? "on" : "off"),
                     field("anonymous_metrics", anonymousMetrics ? "yes" : "no"),
                     field("dashboard", dashboard ? "on" : "off")});
            if (!httpPortFile.empty()) {
                farm::writeFileAtomically(httpPortFile, std::to_string(httpServer->port()) + "\n");
            }
        }
        coordinator.start();
        logInfo("coordinator.listening", {field("address", listen), field("port", port),
                                          field("tls", tlsCert.empty() ? "off" : "on"),
                                          field("state_dir", options.stateDirectory)});
        if (!portFile.empty()) {
            farm::writeFileAtomically(portFile, std::to_string(port) + "\n");
        }

        int signal = 0;
        sigwait(&signals, &signal);
        logInfo("coordinator.stopping", {field("signal", signal)});
        coordinator.beginStop();
        if (httpServer) httpServer->stop();
        if (webDashboard) webDashboard->stop();
        server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
        coordinator.stop();
        // The merged work that could not be saved is not lost for the image (a restart renders
        // it again), but whoever stopped the coordinator must hear that the state disk failed.
        if (coordinator.jobsUnsavedAtStop() == 0) return 0;
        std::cerr << absl::StrFormat(
            "alphorn-coordinator: the state disk refused the last checkpoint of %d running "
            "job(s): %u unit(s) merged since their previous checkpoints were not saved and will "
            "be rendered again after a restart (the images stay right; only that work is lost). "
            "Free space or fix the disk before starting again.\n",
            coordinator.jobsUnsavedAtStop(), coordinator.unitsUnsavedAtStop());
        return 1;
    } catch (const std::exception& e) {
        logError("coordinator.failed", {field("error", e.what())});
        return 1;
    }
}
