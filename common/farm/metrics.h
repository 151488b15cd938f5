// The daemons' Prometheus metrics (prometheus-cpp's core library): what happens on the farm is
// counted where it happens, by one call per event, and served on /metrics (serveMetrics()).
// This header keeps prometheus-cpp out of the code that reports events: the lease scheduler, the
// job film, checkpoints, the blob store and the worker include only this.
//
// Each daemon has its own registry, made on first use, so the coordinator serves only
// coordinator metrics and a worker only worker metrics. Counters count from the start of the
// process (Prometheus handles the reset of a restart); rates are PromQL's job (rate(...[1m])).
// Metric names and their meaning are listed in docs/operations.md ("Metrics").
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace prometheus {
class Collectable;
}  // namespace prometheus

namespace alphorn::farm {

class HttpServer;
struct RouteAccess;

// Seconds since construction, on the monotonic clock (for latency histograms; the coordinator's
// own Clock is for its decisions, which a simulation may drive).
class Stopwatch {
  public:
    Stopwatch() : m_start(std::chrono::steady_clock::now()) {}
    double seconds() const {
        return std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    }

  private:
    std::chrono::steady_clock::time_point m_start;
};

// Events of the coordinator.
struct CoordinatorMetrics {
    // The registry to serve (serveMetrics).
    static std::shared_ptr<prometheus::Collectable> registry();

    // A unit was leased to a worker; `again` when it had been leased before in this process
    // (its earlier lease failed, expired or was handed back).
    static void unitLeased(bool again);
    // A unit's result was merged into its job's film; `samples` = tile pixels x passes.
    static void unitMerged(uint64_t samples);
    enum class FailureCause { WorkerError, LeaseExpired };
    // A unit's attempt failed (counted towards its job's attempt limit).
    static void unitFailed(FailureCause cause);
    static void unitHandedBack();
    // An AcquireWork call was answered with a unit after waiting `seconds`.
    static void leaseWaited(double seconds);
    // A ReportResult call that merged its unit took `seconds` (receiving the stream, checking,
    // decompressing and merging).
    static void resultMerged(double seconds);
    static void checkpointWritten(double seconds, uint64_t bytes);
    static void checkpointFailed();
    // A blob upload was stored (not counted when the blob was there already).
    static void blobStored(uint64_t bytes);
    // How an audited unit ended: two workers' results agreed, disagreed (a third decides), or
    // the held result was merged unaudited because no other worker could render it.
    enum class AuditOutcome { Agreed, Disagreed, Unaudited };
    static void unitAudited(AuditOutcome outcome);
    // An audit found a worker's results wrong.
    static void workerQuarantined();
    // A running job was rendered again from nothing because a quarantined worker had merged
    // into it.
    static void jobRestarted();
};

// Events of a worker.
struct WorkerMetrics {
    // The registry to serve (serveMetrics).
    static std::shared_ptr<prometheus::Collectable> registry();

    // An AcquireWork exchange that ended with a unit: `seconds` from asking until the unit was
    // there, across empty long polls and retries.
    static void leaseWaited(double seconds);
    // A unit rendered completely: camera samples and rays traced (closest-hit and shadow).
    static void unitRendered(double seconds, uint64_t samples, uint64_t rays);
    // A unit that failed on this worker (its error goes to the coordinator).
    static void unitFailed();
    // Per-pass data (a photon map) was built: `photons` photon paths traced.
    static void passDataBuilt(uint64_t photons);
    // Merged; discarded (merged already or reassigned); recorded (a failure or a hand-back the
    // coordinator took note of); held for an audit; refused; abandoned (stopping, or could not
    // register again).
    enum class Delivery { Merged, Discarded, Recorded, Held, Refused, Abandoned };
    // A result left the worker's hands, `seconds` after its first delivery attempt.
    static void resultDelivered(Delivery outcome, double seconds);
    // A cached blob's content no longer matched its hash; it was discarded and fetched again.
    static void blobCorrupt();
};

// Serves the exposition text of `collectables` (in order) on GET /metrics of `server`, to whom
// `access` allows.
void serveMetrics(HttpServer& server,
                  std::vector<std::shared_ptr<prometheus::Collectable>> collectables,
                  const RouteAccess& access);
// The exposition text (Prometheus text format 0.0.4) of `collectables`.
std::string metricsText(const std::vector<std::shared_ptr<prometheus::Collectable>>& collectables);

}  // namespace alphorn::farm
