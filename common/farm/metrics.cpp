#include "common/farm/metrics.h"

#include "common/farm/http_server.h"

#include <prometheus/counter.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>

#include <sstream>

namespace alphorn::farm {

namespace {

using prometheus::BuildCounter;
using prometheus::BuildGauge;
using prometheus::BuildHistogram;
using prometheus::Counter;
using prometheus::Histogram;
using prometheus::Registry;

// Bucket bounds from `lowest` up, each `factor` times the last, `count` of them.
Histogram::BucketBoundaries exponentialBuckets(double lowest, double factor, int count) {
    Histogram::BucketBoundaries bounds;
    for (double bound = lowest; int(bounds.size()) < count; bound *= factor)
        bounds.push_back(bound);
    return bounds;
}

Counter& counter(Registry& registry, const std::string& name, const std::string& help,
                 const prometheus::Labels& labels = {}) {
    return BuildCounter().Name(name).Help(help).Register(registry).Add(labels);
}

Histogram& histogram(Registry& registry, const std::string& name, const std::string& help,
                     Histogram::BucketBoundaries buckets) {
    return BuildHistogram().Name(name).Help(help).Register(registry).Add({}, std::move(buckets));
}

// 1 ms to about 6 minutes in factors of 2.5 (latencies of calls and renders).
Histogram::BucketBoundaries secondsBuckets() {
    return exponentialBuckets(0.001, 2.5, 15);
}

void addBuildInfo(Registry& registry) {
    BuildGauge()
        .Name("alphorn_build_info")
        .Help("Always 1; the label names the Alphorn version of this daemon")
        .Register(registry)
        .Add({{"version", ALPHORN_VERSION}})
        .Set(1);
}

struct CoordinatorFamilies {
    std::shared_ptr<Registry> registry = std::make_shared<Registry>();
    Counter& leased = counter(*registry, "alphorn_units_leased_total",
                              "Units leased to workers (each lease once, first leases and "
                              "leases again alike)");
    Counter& leasedAgain = counter(*registry, "alphorn_units_leased_again_total",
                                   "Leases of units that had been leased before by this process "
                                   "(re-leased after a failure, an expired lease or a hand-back)");
    Counter& merged = counter(*registry, "alphorn_units_merged_total",
                              "Unit results merged into their job's film");
    Counter& samples = counter(*registry, "alphorn_samples_merged_total",
                               "Camera samples merged (tile pixels x passes of each merged unit)");
    prometheus::Family<Counter>& failedFamily =
        BuildCounter()
            .Name("alphorn_units_failed_total")
            .Help(
                "Failed unit attempts: reported by the worker (worker_error) or its lease "
                "expired without a heartbeat (lease_expired)")
            .Register(*registry);
    Counter& failedWorkerError = failedFamily.Add({{"cause", "worker_error"}});
    Counter& failedLeaseExpired = failedFamily.Add({{"cause", "lease_expired"}});
    Counter& handedBack = counter(*registry, "alphorn_units_handed_back_total",
                                  "Units a stopping worker gave back unrendered");
    Histogram& leaseWait =
        histogram(*registry, "alphorn_lease_wait_seconds",
                  "Time from an AcquireWork call to the unit it leased", secondsBuckets());
    Histogram& result = histogram(*registry, "alphorn_result_seconds",
                                  "Time a ReportResult call that merged its unit took "
                                  "(receiving, checking, decompressing, merging)",
                                  secondsBuckets());
    Histogram& checkpointSeconds =
        histogram(*registry, "alphorn_checkpoint_write_seconds",
                  "Time to write one film checkpoint (compressing, writing, fsync, rename)",
                  secondsBuckets());
    Counter& checkpointBytes = counter(*registry, "alphorn_checkpoint_written_bytes_total",
                                       "Bytes of film checkpoints written");
    Counter& checkpointFailures = counter(*registry, "alphorn_checkpoint_failures_total",
                                          "Checkpoint writes that failed (e.g. a full disk)");
    Counter& blobBytes = counter(*registry, "alphorn_blob_uploaded_bytes_total",
                                 "Bytes of blobs uploaded and stored (a blob already stored "
                                 "is not counted again)");
    Counter& blobCount =
        counter(*registry, "alphorn_blobs_uploaded_total", "Blobs uploaded and stored");
    prometheus::Family<Counter>& auditFamily =
        BuildCounter()
            .Name("alphorn_units_audited_total")
            .Help(
                "Units rendered by a second worker to compare results: agreed, disagreed (a "
                "third worker decides) or unaudited (no other worker could render it; merged "
                "as delivered)")
            .Register(*registry);
    Counter& auditAgreed = auditFamily.Add({{"outcome", "agreed"}});
    Counter& auditDisagreed = auditFamily.Add({{"outcome", "disagreed"}});
    Counter& auditUnaudited = auditFamily.Add({{"outcome", "unaudited"}});
    Counter& quarantined = counter(*registry, "alphorn_workers_quarantined_total",
                                   "Workers an audit found rendering wrong results");
    Counter& restarted = counter(*registry, "alphorn_jobs_restarted_total",
                                 "Running jobs rendered again from nothing because a "
                                 "quarantined worker had merged into them");

    CoordinatorFamilies() { addBuildInfo(*registry); }
};

CoordinatorFamilies& coordinatorFamilies() {
    static CoordinatorFamilies families;
    return families;
}

struct WorkerFamilies {
    std::shared_ptr<Registry> registry = std::make_shared<Registry>();
    Histogram& leaseWait = histogram(*registry, "alphorn_worker_lease_wait_seconds",
                                     "Time from asking the coordinator for work until a unit "
                                     "was leased (empty long polls and retries included)",
                                     secondsBuckets());
    Histogram& render = histogram(*registry, "alphorn_worker_render_seconds",
                                  "Time to render one unit (renderUnit)", secondsBuckets());
    Counter& rendered =
        counter(*registry, "alphorn_worker_units_rendered_total", "Units rendered completely");
    Counter& failed = counter(*registry, "alphorn_worker_units_failed_total",
                              "Units that failed on this worker (their error went to the "
                              "coordinator)");
    Counter& samples = counter(*registry, "alphorn_worker_samples_total",
                               "Camera samples rendered in completed units");
    Counter& rays = counter(*registry, "alphorn_worker_rays_total",
                            "Rays traced (closest-hit and shadow) in completed units");
    Counter& photons = counter(*registry, "alphorn_worker_photons_traced_total",
                               "Photon paths traced while building per-pass data (photon maps)");
    Counter& passData = counter(*registry, "alphorn_worker_pass_data_builds_total",
                                "Passes whose per-pass data this worker built");
    prometheus::Family<Counter>& deliveredFamily =
        BuildCounter()
            .Name("alphorn_worker_results_total")
            .Help(
                "Results that left this worker, by the coordinator's answer: merged, "
                "discarded (merged already or reassigned), recorded (a failure or hand-back), "
                "held (kept for an audit), refused, or abandoned (stopping, or the worker could "
                "not register again)")
            .Register(*registry);
    Counter& deliveredMerged = deliveredFamily.Add({{"outcome", "merged"}});
    Counter& deliveredDiscarded = deliveredFamily.Add({{"outcome", "discarded"}});
    Counter& deliveredRecorded = deliveredFamily.Add({{"outcome", "recorded"}});
    Counter& deliveredHeld = deliveredFamily.Add({{"outcome", "held"}});
    Counter& deliveredRefused = deliveredFamily.Add({{"outcome", "refused"}});
    Counter& deliveredAbandoned = deliveredFamily.Add({{"outcome", "abandoned"}});
    Histogram& delivery = histogram(*registry, "alphorn_worker_delivery_seconds",
                                    "Time from a result's first delivery attempt until the "
                                    "coordinator answered (retries through outages included)",
                                    secondsBuckets());
    Counter& blobsCorrupt = counter(*registry, "alphorn_worker_blobs_corrupt_total",
                                    "Cached blobs whose content no longer matched their hash "
                                    "(damaged on this worker's disk; discarded and fetched again)");

    WorkerFamilies() { addBuildInfo(*registry); }
};

WorkerFamilies& workerFamilies() {
    static WorkerFamilies families;
    return families;
}

}  // namespace

// ---- coordinator -------------------------------------------------------------------------------

std::shared_ptr<prometheus::Collectable> CoordinatorMetrics::registry() {
    return coordinatorFamilies().registry;
}

void CoordinatorMetrics::unitLeased(bool again) {
    CoordinatorFamilies& f = coordinatorFamilies();
    f.leased.Increment();
    if (again) f.leasedAgain.Increment();
}

void CoordinatorMetrics::unitMerged(uint64_t samples) {
    CoordinatorFamilies& f = coordinatorFamilies();
    f.merged.Increment();
    f.samples.Increment(double(samples));
}

void CoordinatorMetrics::unitFailed(FailureCause cause) {
    CoordinatorFamilies& f = coordinatorFamilies();
    (cause == FailureCause::WorkerError ? f.failedWorkerError : f.failedLeaseExpired).Increment();
}

void CoordinatorMetrics::unitHandedBack() {
    coordinatorFamilies().handedBack.Increment();
}

void CoordinatorMetrics::unitAudited(AuditOutcome outcome) {
    auto& families = coordinatorFamilies();
    (outcome == AuditOutcome::Agreed      ? families.auditAgreed
     : outcome == AuditOutcome::Disagreed ? families.auditDisagreed
                                          : families.auditUnaudited)
        .Increment();
}

void CoordinatorMetrics::workerQuarantined() {
    coordinatorFamilies().quarantined.Increment();
}

void CoordinatorMetrics::jobRestarted() {
    coordinatorFamilies().restarted.Increment();
}

void CoordinatorMetrics::leaseWaited(double seconds) {
    coordinatorFamilies().leaseWait.Observe(seconds);
}

void CoordinatorMetrics::resultMerged(double seconds) {
    coordinatorFamilies().result.Observe(seconds);
}

void CoordinatorMetrics::checkpointWritten(double seconds, uint64_t bytes) {
    CoordinatorFamilies& f = coordinatorFamilies();
    f.checkpointSeconds.Observe(seconds);
    f.checkpointBytes.Increment(double(bytes));
}

void CoordinatorMetrics::checkpointFailed() {
    coordinatorFamilies().checkpointFailures.Increment();
}

void CoordinatorMetrics::blobStored(uint64_t bytes) {
    CoordinatorFamilies& f = coordinatorFamilies();
    f.blobCount.Increment();
    f.blobBytes.Increment(double(bytes));
}

// ---- worker ------------------------------------------------------------------------------------

std::shared_ptr<prometheus::Collectable> WorkerMetrics::registry() {
    return workerFamilies().registry;
}

void WorkerMetrics::leaseWaited(double seconds) {
    workerFamilies().leaseWait.Observe(seconds);
}

void WorkerMetrics::unitRendered(double seconds, uint64_t samples, uint64_t rays) {
    WorkerFamilies& f = workerFamilies();
    f.render.Observe(seconds);
    f.rendered.Increment();
    f.samples.Increment(double(samples));
    f.rays.Increment(double(rays));
}

void WorkerMetrics::unitFailed() {
    workerFamilies().failed.Increment();
}

void WorkerMetrics::passDataBuilt(uint64_t photons) {
    WorkerFamilies& f = workerFamilies();
    f.passData.Increment();
    f.photons.Increment(double(photons));
}

void WorkerMetrics::resultDelivered(Delivery outcome, double seconds) {
    WorkerFamilies& f = workerFamilies();
    switch (outcome) {
        case Delivery::Merged:
            f.deliveredMerged.Increment();
            break;
        case Delivery::Discarded:
            f.deliveredDiscarded.Increment();
            break;
        case Delivery::Recorded:
            f.deliveredRecorded.Increment();
            break;
        case Delivery::Held:
            f.deliveredHeld.Increment();
            break;
        case Delivery::Refused:
            f.deliveredRefused.Increment();
            break;
        case Delivery::Abandoned:
            f.deliveredAbandoned.Increment();
            return;  // never answered: no delivery time
    }
    f.delivery.Observe(seconds);
}

void WorkerMetrics::blobCorrupt() {
    workerFamilies().blobsCorrupt.Increment();
}

// ---- serving -----------------------------------------------------------------------------------

std::string metricsText(const std::vector<std::shared_ptr<prometheus::Collectable>>& collectables) {
    std::vector<prometheus::MetricFamily> families;
    for (const auto& collectable : collectables) {
        std::vector<prometheus::MetricFamily> collected = collectable->Collect();
        families.insert(families.end(), std::make_move_iterator(collected.begin()),
                        std::make_move_iterator(collected.end()));
    }
    std::ostringstream out;
    prometheus::TextSerializer().Serialize(out, families);
    return out.str();
}

void serveMetrics(HttpServer& server,
                  std::vector<std::shared_ptr<prometheus::Collectable>> collectables,
                  const RouteAccess& access) {
    server.get(
        "/metrics", access,
        [collectables = std::move(collectables)](const HttpRequest&, HttpResponse& response) {
            response.setContent(metricsText(collectables),
                                "text/plain; version=0.0.4; charset=utf-8");
        });
}

}  // namespace alphorn::farm
