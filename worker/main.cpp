// alphorn-worker: renders units leased from an alphorn-coordinator. See docs/operations.md.
#include "common/farm/engine_fingerprint.h"
#include "common/farm/files.h"
#include "common/farm/http_server.h"
#include "common/farm/log.h"
#include "common/farm/metrics.h"
#include "common/farm/number_options.h"
#include "common/farm/rpc.h"
#include "worker/worker.h"

#include <tbb/global_control.h>
#include <CLI/CLI.hpp>

#include <cmath>
#include <csignal>
#include <cstdio>

using namespace alphorn;

int main(int argc, char** argv) {
    CLI::App app{"alphorn-worker: renders units for an alphorn-coordinator."};
    app.set_version_flag("--version", std::string("alphorn-worker ") + ALPHORN_VERSION +
                                          " (engine " + farm::engineFingerprint() + ")");
    worker::WorkerOptions options;
    std::string tokenFile;
    double cacheGiB = 4.0;
    app.add_option("--coordinator", options.coordinator, "Coordinator address (host:port)")
        ->required();
    app.add_option("--token-file", tokenFile, "File holding the worker bearer token")->required();
    app.add_option("--cache-dir", options.cacheDirectory,
                   "Directory for the blob cache and job scenes")
        ->required();
    app.add_option("--threads", options.threads, "Render threads (default: all cores)")
        ->check(CLI::Range(0, 1024));
    app.add_option("--tls-ca", options.tlsCaPath,
                   "PEM CA certificate: connect with TLS, verifying the coordinator");
    app.add_option("--cache-gib", cacheGiB, "Blob cache budget in GiB")
        ->check(farm::kFinite & CLI::Range(0.0, 1e6));
    app.add_option("--name", options.name, "Name shown by `alphorn workers` (default: host:pid)");
    app.add_option("--drain-seconds", options.drainSeconds,
                   "On SIGTERM, how long to keep trying to deliver")
        ->check(farm::kFinite & CLI::Range(0.0, 1e6));
    double unloadAfterSeconds = 30.0;
    app.add_option("--unload-after", unloadAfterSeconds,
                   "How long an idle worker keeps the last job's scene and photon maps loaded, in "
                   "seconds; then it releases them and gives the memory back")
        ->check(farm::kFinite & CLI::Range(0.0, 1e6));
    std::string httpListen, httpPortFile, httpTlsCert, httpTlsKey, metricsTokenFile;
    bool anonymousMetrics = false;
    CLI::Option* http = app.add_option(
        "--http-listen", httpListen,
        "Serve HTTP on this address (host:port; port 0 picks a free one): /metrics for "
        "Prometheus. Off by default");
    app.add_option("--http-port-file", httpPortFile,
                   "Write the bound HTTP port to this file once listening")
        ->needs(http);
    CLI::Option* cert = app.add_option("--http-tls-cert", httpTlsCert,
                                       "PEM certificate chain: serve HTTPS (with --http-tls-key)")
                            ->needs(http);
    app.add_option("--http-tls-key", httpTlsKey, "PEM private key of --http-tls-cert")->needs(cert);
    cert->needs("--http-tls-key");
    app.add_option("--metrics-token-file", metricsTokenFile,
                   "File holding a token that may read /metrics and nothing else (for "
                   "Prometheus; the worker token reads it too)")
        ->needs(http);
    app.add_flag("--http-anonymous-metrics", anonymousMetrics,
                 "Serve /metrics to anyone, without a token (only on a trusted network)")
        ->needs(http);
    farm::requireDecimalNumbers(app);
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // Help and version exit 0; usage errors exit 1 like every other error (not CLI11's
        // 105-114), as documented.
        return app.exit(e) == 0 ? 0 : 1;
    }
    options.cacheBytes = static_cast<uint64_t>(cacheGiB * double(uint64_t(1) << 30));
    options.unloadAfter =
        std::chrono::milliseconds(static_cast<int64_t>(std::llround(unloadAfterSeconds * 1000.0)));
    // From here on stderr is the log: one event per line, whoever writes.
    farm::routeLibraryOutputToLog();

    // A file size limit (ulimit -f) must fail the cache write that exceeds it, like a full disk,
    // not kill the worker.
    std::signal(SIGXFSZ, SIG_IGN);
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    try {
        options.token = farm::readTokenFile(tokenFile);
        std::unique_ptr<tbb::global_control> threadLimit;
        if (options.threads > 0)
            threadLimit = std::make_unique<tbb::global_control>(
                tbb::global_control::max_allowed_parallelism, options.threads);
        worker::Worker worker(options);
        std::unique_ptr<farm::HttpServer> httpServer;
        if (!httpListen.empty()) {
            farm::RouteAccess metricsAccess{{options.token}, anonymousMetrics};
            if (!metricsTokenFile.empty())
                metricsAccess.tokens.push_back(farm::readTokenFile(metricsTokenFile));
            httpServer = std::make_unique<farm::HttpServer>(
                farm::HttpServerOptions{httpListen, httpTlsCert, httpTlsKey});
            farm::serveMetrics(*httpServer, {farm::WorkerMetrics::registry()}, metricsAccess);
            httpServer->start();
            farm::logInfo(
                "http.listening",
                {farm::field("address", httpListen), farm::field("port", httpServer->port()),
                 farm::field("tls", httpServer->tls() ? "on" : "off"),
                 farm::field("anonymous_metrics", anonymousMetrics ? "yes" : "no")});
            if (!httpPortFile.empty()) {
                farm::writeFileAtomically(httpPortFile, std::to_string(httpServer->port()) + "\n");
            }
        }
        // SIGTERM (docker stop, systemctl stop, a Kubernetes pod's end) drains: the unit in
        // hand is finished and delivered, then the worker exits 0. A second signal abandons the
        // unit, hands it back and exits at once.
        std::thread signalThread([&] {
            for (int received = 1;; ++received) {
                int signal = 0;
                sigwait(&signals, &signal);
                farm::logInfo("worker.signal",
                              {farm::field("signal", signal),
                               farm::field("action", received == 1 ? "draining"
                                                                   : "handing back and exiting")});
                worker.requestStop();
            }
        });
        signalThread.detach();
        const int code = worker.run();
        // Leave without unwinding the detached signal thread.
        std::_Exit(code);
    } catch (const std::exception& e) {
        farm::logEvent("error", "worker.failed", {farm::field("error", e.what())});
        return 1;
    }
}
