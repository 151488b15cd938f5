#include "coordinator/metrics.h"

#include "coordinator/coordinator.h"
#include "coordinator/log.h"

#include <absl/strings/ascii.h>
#include <prometheus/metric_family.h>

#include <map>

namespace alphorn::coordinator {

namespace {

prometheus::MetricFamily family(const std::string& name, const std::string& help,
                                prometheus::MetricType type) {
    prometheus::MetricFamily result;
    result.name = name;
    result.help = help;
    result.type = type;
    return result;
}

void addGauge(prometheus::MetricFamily& family, double value,
              std::vector<prometheus::ClientMetric::Label> labels = {}) {
    prometheus::ClientMetric metric;
    metric.label = std::move(labels);
    metric.gauge.value = value;
    family.metric.push_back(std::move(metric));
}

// "JOB_STATE_DONE" -> "done": every state of the protocol gets a series, also states added
// later, and a state with no job reads 0 rather than being absent.
std::string stateLabel(const std::string& enumName) {
    const std::string prefix = "JOB_STATE_";
    return absl::AsciiStrToLower(
        enumName.substr(enumName.rfind(prefix, 0) == 0 ? prefix.size() : 0));
}

}  // namespace

std::vector<prometheus::MetricFamily> CoordinatorStateMetrics::Collect() const {
    std::vector<prometheus::MetricFamily> families;

    std::map<int, uint64_t> jobsByState;
    uint64_t pending = 0, leased = 0;
    for (const v1::JobStatus& job : m_coordinator.listJobs(0)) {
        ++jobsByState[job.state()];
        if (job.state() != v1::JOB_STATE_RUNNING) continue;
        leased += job.units_leased();
        pending += job.units_total() -
                   std::min<uint64_t>(job.units_total(), job.units_done() + job.units_leased());
    }
    auto jobs = family("alphorn_jobs",
                       "Jobs the coordinator knows, by state (ended jobs stay "
                       "until --keep-finished-hours)",
                       prometheus::MetricType::Gauge);
    const google::protobuf::EnumDescriptor* states = v1::JobState_descriptor();
    for (int i = 0; i < states->value_count(); ++i) {
        const auto* state = states->value(i);
        if (state->number() == v1::JOB_STATE_UNSPECIFIED) continue;
        addGauge(jobs, double(jobsByState[state->number()]),
                 {{"state", stateLabel(state->name())}});
    }
    families.push_back(std::move(jobs));
    auto pendingUnits =
        family("alphorn_pending_units", "Units of running jobs waiting for a worker",
               prometheus::MetricType::Gauge);
    addGauge(pendingUnits, double(pending));
    families.push_back(std::move(pendingUnits));
    auto leasedUnits = family("alphorn_leased_units", "Units leased to workers right now",
                              prometheus::MetricType::Gauge);
    addGauge(leasedUnits, double(leased));
    families.push_back(std::move(leasedUnits));

    auto workers =
        family("alphorn_workers",
               "Workers by state: alive (called within two heartbeat intervals, at least 3 s), "
               "silent (not since), dead (not for three lease periods; forgotten "
               "after --keep-finished-hours) or left (exited after a drain)",
               prometheus::MetricType::Gauge);
    auto draining = family("alphorn_workers_draining",
                           "Workers taking no new unit: drained by a client, or stopping",
                           prometheus::MetricType::Gauge);
    auto merged = family("alphorn_units_merged_by_worker_total",
                         "Units each worker delivered that were merged, by this coordinator "
                         "process",
                         prometheus::MetricType::Counter);
    uint64_t alive = 0, silent = 0, dead = 0, left = 0, drainingCount = 0;
    for (const v1::WorkerInfo& worker : m_coordinator.listWorkers(true)) {
        switch (worker.state()) {
            case v1::WORKER_STATE_SILENT:
                ++silent;
                break;
            case v1::WORKER_STATE_DEAD:
                ++dead;
                break;
            case v1::WORKER_STATE_LEFT:
                ++left;
                break;
            default:
                ++alive;
                break;
        }
        if (worker.draining() || worker.exiting()) ++drainingCount;
        prometheus::ClientMetric metric;
        metric.label = {{"worker", worker.name()},
                        {"worker_id", std::to_string(worker.worker_id())}};
        metric.counter.value = double(worker.units_merged());
        merged.metric.push_back(std::move(metric));
    }
    addGauge(workers, double(alive), {{"state", "alive"}});
    addGauge(workers, double(silent), {{"state", "silent"}});
    addGauge(workers, double(dead), {{"state", "dead"}});
    addGauge(workers, double(left), {{"state", "left"}});
    addGauge(draining, double(drainingCount));
    families.push_back(std::move(workers));
    families.push_back(std::move(draining));
    families.push_back(std::move(merged));

    try {
        uint64_t bytes = 0, count = 0;
        for (const BlobStore::StoredBlob& blob : m_coordinator.blobs().list()) {
            bytes += blob.size;
            ++count;
        }
        auto blobBytes = family("alphorn_blob_store_bytes",
                                "Bytes of the blobs (scene files) in the state directory",
                                prometheus::MetricType::Gauge);
        addGauge(blobBytes, double(bytes));
        families.push_back(std::move(blobBytes));
        auto blobCount = family("alphorn_blob_store_blobs", "Blobs in the state directory",
                                prometheus::MetricType::Gauge);
        addGauge(blobCount, double(count));
        families.push_back(std::move(blobCount));
    } catch (const std::exception& e) {
        // A blob removed by retention while being listed: this scrape goes without the size.
        logWarning("metrics.blob_store_unreadable", {field("error", e.what())});
    }
    return families;
}

}  // namespace alphorn::coordinator
