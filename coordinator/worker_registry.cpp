#include "coordinator/worker_registry.h"

#include "coordinator/log.h"

namespace alphorn::coordinator {

void WorkerRegistry::restore(const WorkerRow& row) {
    Worker worker;
    worker.info.set_worker_id(row.id);
    worker.info.set_name(row.name);
    worker.info.set_cores(row.cores);
    worker.info.set_memory_bytes(row.memoryBytes);
    worker.info.set_version(row.version);
    worker.info.set_engine_fingerprint(row.engineFingerprint);
    worker.quarantined = row.quarantined;
    worker.lastContactWall = m_clock.wallSeconds();
    worker.draining = row.draining;
    m_scheduler.addWorker(row.id, false, row.engineFingerprint, !row.quarantined.empty());
    m_workers[row.id] = std::move(worker);
}

void WorkerRegistry::add(uint64_t workerId, const v1::RegisterRequest& request) {
    Worker& worker = m_workers[workerId];
    worker.info.set_worker_id(workerId);
    worker.info.set_name(request.name());
    worker.info.set_cores(request.cores());
    worker.info.set_memory_bytes(request.memory_bytes());
    worker.info.set_version(request.version());
    worker.info.set_engine_fingerprint(request.engine_fingerprint());
    worker.lastContactWall = m_clock.wallSeconds();
    m_scheduler.addWorker(workerId, true, request.engine_fingerprint(), false, request.host_id());
}

WorkerRegistry::Worker* WorkerRegistry::touch(uint64_t workerId) {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return nullptr;
    m_scheduler.touchWorker(workerId);
    it->second.lastContactWall = m_clock.wallSeconds();
    it->second.left = false;
    return &it->second;
}

WorkerRegistry::Worker* WorkerRegistry::heartbeat(const v1::HeartbeatRequest& request) {
    // A heartbeat of the stopping process that arrives after its goodbye leaves it gone.
    const auto known = m_workers.find(request.worker_id());
    const bool leftBefore = known != m_workers.end() && known->second.left;
    Worker* worker = touch(request.worker_id());
    if (!worker) return nullptr;
    if (request.draining() && !worker->exiting) {
        worker->exiting = true;
        logInfo("worker.draining", {field("worker", request.worker_id()), field("by", "SIGTERM")});
    }
    if (leftBefore && request.draining() && request.lease_ids_size() == 0) worker->left = true;
    if (request.exiting() && request.lease_ids_size() == 0) {
        worker->left = true;
        logInfo("worker.left", {field("worker", request.worker_id())});
    }
    return worker;
}

bool WorkerRegistry::setDraining(Worker& worker, bool draining) {
    if (worker.draining == draining) return false;
    worker.draining = draining;
    return true;
}

void WorkerRegistry::recordMerge(uint64_t workerId, uint64_t samples, uint64_t rays,
                                 double renderSeconds) {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return;
    Worker& worker = it->second;
    worker.info.set_units_merged(worker.info.units_merged() + 1);
    worker.samples += samples;
    worker.rays += rays;
    worker.renderSeconds += std::max(0.0, renderSeconds);
}

WorkerRegistry::Worker* WorkerRegistry::find(uint64_t workerId) {
    auto it = m_workers.find(workerId);
    return it == m_workers.end() ? nullptr : &it->second;
}

std::string WorkerRegistry::name(uint64_t workerId) const {
    auto it = m_workers.find(workerId);
    return it == m_workers.end() ? std::string() : it->second.info.name();
}

v1::WorkerInfo WorkerRegistry::info(uint64_t workerId, const Worker& worker) const {
    v1::WorkerInfo info = worker.info;
    const double since = m_scheduler.secondsSinceSeen(workerId);
    info.set_seconds_since_seen(since);
    info.set_leases(m_scheduler.leaseCount(workerId));
    info.set_alive(!worker.left && since < 3 * m_leaseSeconds);
    // A worker calls every heartbeat interval while it runs (also when idle), so a silence of
    // two intervals says it is probably gone, long before its leases expire.
    if (worker.left)
        info.set_state(v1::WORKER_STATE_LEFT);
    else if (!info.alive())
        info.set_state(v1::WORKER_STATE_DEAD);
    else if (since > silentAfterSeconds())
        info.set_state(v1::WORKER_STATE_SILENT);
    else
        info.set_state(v1::WORKER_STATE_ALIVE);
    info.set_draining(worker.draining || worker.exiting);
    info.set_exiting(worker.exiting);
    info.set_quarantined(worker.quarantined);
    if (worker.renderSeconds > 0) {
        info.set_samples_per_second(double(worker.samples) / worker.renderSeconds);
        info.set_rays_per_second(double(worker.rays) / worker.renderSeconds);
    }
    return info;
}

std::vector<v1::WorkerInfo> WorkerRegistry::list(bool includeDead) const {
    std::vector<v1::WorkerInfo> result;
    for (const auto& [id, worker] : m_workers) {
        v1::WorkerInfo workerInfo = info(id, worker);
        if (workerInfo.alive() || includeDead) result.push_back(std::move(workerInfo));
    }
    return result;
}

std::map<uint64_t, std::vector<WorkerRegistry::HeldUnit>> WorkerRegistry::heldUnits() const {
    std::map<uint64_t, std::vector<HeldUnit>> held;
    for (const auto& [id, worker] : m_workers)
        for (const auto& [jobId, unitIndex] : m_scheduler.unitsLeasedTo(id))
            held[id].push_back({jobId, unitIndex});
    return held;
}

std::vector<uint64_t> WorkerRegistry::forgetSilent(const Retention& retention, double wallNow) {
    std::vector<uint64_t> forgotten;
    for (auto it = m_workers.begin(); it != m_workers.end();) {
        if (m_scheduler.leaseCount(it->first) == 0 &&
            retention.expired(it->second.lastContactWall, wallNow)) {
            forgotten.push_back(it->first);
            m_scheduler.forgetWorker(it->first);
            it = m_workers.erase(it);
        } else {
            ++it;
        }
    }
    return forgotten;
}

}  // namespace alphorn::coordinator
