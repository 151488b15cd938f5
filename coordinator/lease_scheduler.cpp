#include "coordinator/lease_scheduler.h"

#include "common/core/error.h"
#include "common/farm/metrics.h"

#include <absl/strings/str_format.h>

#include <algorithm>

namespace alphorn::coordinator {

LeaseScheduler::LeaseScheduler(const Clock& clock, SchedulerOptions options, LeaseTokens tokens,
                               uint64_t firstLeaseId)
    : m_clock(clock),
      m_options(options),
      m_tokens(std::move(tokens)),
      m_nextLeaseId(firstLeaseId) {}

LeaseScheduler::Job& LeaseScheduler::job(uint64_t jobId) {
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) alphorn::fail("the scheduler has no job %u", jobId);
    return it->second;
}

const LeaseScheduler::Job& LeaseScheduler::job(uint64_t jobId) const {
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) alphorn::fail("the scheduler has no job %u", jobId);
    return it->second;
}

void LeaseScheduler::addJob(uint64_t jobId, int priority, const farm::JobGrid& grid,
                            const std::vector<bool>& merged, const std::vector<uint32_t>& attempts,
                            bool running, const std::string& engineFingerprint) {
    Job& added = m_jobs[jobId];
    added = Job();
    added.priority = priority;
    added.running = running;
    added.engineFingerprint = engineFingerprint;
    added.grid = grid;
    added.units.resize(grid.unitCount());
    for (uint32_t i = 0; i < grid.unitCount(); ++i) {
        UnitSlot& slot = added.units[i];
        if (i < attempts.size()) slot.attempts = attempts[i];
        added.counts.attemptsFailed += slot.attempts;
        if (i < merged.size() && merged[i])
            slot.state = UnitState::Merged;
        else if (running)
            added.pending.insert(i);
    }
}

void LeaseScheduler::endJob(uint64_t jobId) {
    Job& ended = job(jobId);
    ended.running = false;
    ended.pending.clear();
    ended.audits.clear();
    ended.failedOn.clear();
    for (UnitSlot& slot : ended.units)
        if (slot.state == UnitState::Leased) release(ended, slot);
    for (auto& [id, worker] : m_workers) worker.auditing.erase(jobId);
}

void LeaseScheduler::restartJob(uint64_t jobId) {
    Job& restarted = job(jobId);
    for (UnitSlot& slot : restarted.units)
        if (slot.state == UnitState::Leased) release(restarted, slot);
    restarted.audits.clear();
    for (auto& [id, worker] : m_workers) worker.auditing.erase(jobId);
    restarted.pending.clear();
    for (uint32_t i = 0; i < restarted.units.size(); ++i) {
        restarted.units[i].state = UnitState::Pending;
        if (restarted.running) restarted.pending.insert(i);
    }
}

void LeaseScheduler::removeJob(uint64_t jobId) {
    if (!m_jobs.count(jobId)) return;
    endJob(jobId);
    m_jobs.erase(jobId);
    for (auto& [id, worker] : m_workers) worker.lastChunk.erase(jobId);
}

bool LeaseScheduler::running(uint64_t jobId) const {
    return job(jobId).running;
}

void LeaseScheduler::setLeaseLimit(uint64_t jobId, uint32_t unitLimit) {
    job(jobId).leaseLimit = unitLimit;
}

void LeaseScheduler::setPaused(uint64_t jobId, bool paused) {
    job(jobId).paused = paused;
}

bool LeaseScheduler::paused(uint64_t jobId) const {
    return job(jobId).paused;
}

void LeaseScheduler::setPriority(uint64_t jobId, int priority) {
    job(jobId).priority = priority;
}

LeaseScheduler::JobLeases LeaseScheduler::jobLeases(uint64_t jobId) const {
    return job(jobId).counts;
}

const LeaseScheduler::UnitSlot& LeaseScheduler::unit(uint64_t jobId, uint32_t unitIndex) const {
    return job(jobId).units.at(unitIndex);
}

void LeaseScheduler::addWorker(uint64_t workerId, bool seen, const std::string& engineFingerprint,
                               bool quarantined, const std::string& hostId) {
    Worker& worker = m_workers[workerId];
    worker.engineFingerprint = engineFingerprint;
    worker.quarantined = quarantined;
    worker.host = hostId.empty() ? "worker " + std::to_string(workerId) : hostId;
    // Restored workers count as not seen for a year: they are listed dead until they call.
    worker.lastSeen = m_clock.monotonicSeconds() - (seen ? 0.0 : 365 * 24 * 3600.0);
}

bool LeaseScheduler::touchWorker(uint64_t workerId) {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return false;
    it->second.lastSeen = m_clock.monotonicSeconds();
    return true;
}

void LeaseScheduler::forgetWorker(uint64_t workerId) {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return;
    for (uint64_t leaseId : std::set<uint64_t>(it->second.leases)) {
        const LeaseRef ref = m_leases.at(leaseId);
        Job& held = job(ref.jobId);
        UnitSlot& slot = held.units[ref.unitIndex];
        release(held, slot);
        requeue(held, ref.unitIndex);
    }
    m_workers.erase(it);
}

void LeaseScheduler::requeue(Job& job, uint32_t unitIndex) {
    if (job.running && !job.audits.count(unitIndex)) job.pending.insert(unitIndex);
}

bool LeaseScheduler::failedOnHost(const Job& job, uint32_t unitIndex, const std::string& host) {
    auto failed = job.failedOn.find(unitIndex);
    return failed != job.failedOn.end() && failed->second.count(host);
}

template <typename Excluded>
bool LeaseScheduler::anyLiveWorker(const Job& job, Excluded excluded) const {
    const double recent = m_clock.monotonicSeconds() - m_options.leaseSeconds;
    for (const auto& [id, worker] : m_workers)
        if (worker.lastSeen >= recent && mayRender(worker, job) && !excluded(id, worker))
            return true;
    return false;
}

std::vector<std::pair<uint64_t, uint32_t>> LeaseScheduler::quarantineWorker(uint64_t workerId) {
    std::vector<std::pair<uint64_t, uint32_t>> unheld;
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return unheld;
    Worker& worker = it->second;
    worker.quarantined = true;
    worker.auditing.clear();
    worker.trusted.clear();
    for (uint64_t leaseId : std::set<uint64_t>(worker.leases)) {
        const LeaseRef ref = m_leases.at(leaseId);
        Job& held = job(ref.jobId);
        release(held, held.units[ref.unitIndex]);
        requeue(held, ref.unitIndex);
    }
    for (auto& [jobId, held] : m_jobs) {
        for (auto audit = held.audits.begin(); audit != held.audits.end();) {
            std::vector<uint64_t>& renderers = audit->second;
            renderers.erase(std::remove(renderers.begin(), renderers.end(), workerId),
                            renderers.end());
            if (!renderers.empty()) {
                ++audit;
                continue;
            }
            unheld.emplace_back(jobId, audit->first);
            if (held.running && held.units[audit->first].state == UnitState::Pending)
                held.pending.insert(audit->first);
            audit = held.audits.erase(audit);
        }
    }
    return unheld;
}

bool LeaseScheduler::quarantined(uint64_t workerId) const {
    auto it = m_workers.find(workerId);
    return it != m_workers.end() && it->second.quarantined;
}

bool LeaseScheduler::mayRender(const Worker& worker, const Job& job) const {
    return !worker.quarantined && worker.engineFingerprint == job.engineFingerprint;
}

bool LeaseScheduler::anotherLiveWorker(const Job& job, uint64_t workerId,
                                       const std::vector<uint64_t>& besides,
                                       std::optional<uint32_t> unitIndex) const {
    return anyLiveWorker(job, [&](uint64_t id, const Worker& worker) {
        return id == workerId || std::find(besides.begin(), besides.end(), id) != besides.end() ||
               (unitIndex && failedOnHost(job, *unitIndex, worker.host));
    });
}

const std::string& LeaseScheduler::hostOf(uint64_t workerId) const {
    static const std::string unknown = "unknown";
    auto worker = m_workers.find(workerId);
    return worker == m_workers.end() ? unknown : worker->second.host;
}

LeaseScheduler::Failure LeaseScheduler::failAudit(uint64_t jobId, Job& target, uint32_t unitIndex,
                                                  uint64_t workerId) {
    target.failedOn[unitIndex].insert(hostOf(workerId));
    return Failure{jobId, unitIndex, target.units[unitIndex].attempts, false, true};
}

std::string LeaseScheduler::idleReason(uint64_t workerId) const {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return "";
    const Worker& worker = it->second;
    if (worker.quarantined)
        return "quarantined: an audit found its results differ from other workers' renders of "
               "the same units";
    std::vector<uint64_t> otherBuild;
    std::string wanted;
    bool waiting = false;
    for (const auto& [id, candidate] : m_jobs) {
        if (!candidate.running || candidate.paused ||
            (candidate.pending.empty() && candidate.audits.empty()))
            continue;
        waiting = true;
        if (candidate.engineFingerprint != worker.engineFingerprint) {
            otherBuild.push_back(id);
            wanted = candidate.engineFingerprint;
        }
    }
    if (!waiting || otherBuild.empty()) return "";
    std::string jobs;
    for (size_t i = 0; i < otherBuild.size() && i < 5; ++i)
        jobs += (i ? ", " : "") + std::to_string(otherBuild[i]);
    if (otherBuild.size() > 5) jobs += absl::StrFormat(" and %u more", otherBuild.size() - 5);
    return absl::StrFormat(
        "job%s %s need%s workers of engine fingerprint %s; this worker's is %s (another "
        "build: its units would not sum to the job's bytes)",
        otherBuild.size() > 1 ? "s" : "", jobs, otherBuild.size() > 1 ? "" : "s", wanted,
        worker.engineFingerprint);
}

uint32_t LeaseScheduler::leaseCount(uint64_t workerId) const {
    auto it = m_workers.find(workerId);
    return it == m_workers.end() ? 0 : uint32_t(it->second.leases.size());
}

double LeaseScheduler::secondsSinceSeen(uint64_t workerId) const {
    return m_clock.monotonicSeconds() - m_workers.at(workerId).lastSeen;
}

std::vector<std::pair<uint64_t, uint32_t>> LeaseScheduler::unitsLeasedTo(uint64_t workerId) const {
    std::vector<std::pair<uint64_t, uint32_t>> held;
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return held;
    for (uint64_t leaseId : it->second.leases) {
        const LeaseRef& ref = m_leases.at(leaseId);
        held.emplace_back(ref.jobId, ref.unitIndex);
    }
    std::sort(held.begin(), held.end());
    return held;
}

void LeaseScheduler::grant(uint64_t jobId, Job& job, uint32_t unitIndex, uint64_t workerId,
                           uint64_t leaseId) {
    UnitSlot& slot = job.units[unitIndex];
    job.pending.erase(unitIndex);
    slot.state = UnitState::Leased;
    slot.leaseId = leaseId;
    slot.workerId = workerId;
    slot.deadline = m_clock.monotonicSeconds() + m_options.leaseSeconds;
    m_leases[leaseId] = LeaseRef{jobId, unitIndex};
    m_workers.at(workerId).leases.insert(leaseId);
    ++job.counts.leased;
    if (job.leasesByWorker[workerId]++ == 0) ++job.counts.activeWorkers;
}

void LeaseScheduler::release(Job& job, UnitSlot& slot) {
    m_leases.erase(slot.leaseId);
    if (auto worker = m_workers.find(slot.workerId); worker != m_workers.end())
        worker->second.leases.erase(slot.leaseId);
    --job.counts.leased;
    auto held = job.leasesByWorker.find(slot.workerId);
    if (--held->second == 0) {
        job.leasesByWorker.erase(held);
        --job.counts.activeWorkers;
    }
    slot.state = UnitState::Pending;
}

std::optional<LeaseScheduler::Lease> LeaseScheduler::lease(uint64_t workerId) {
    auto worker = m_workers.find(workerId);
    if (worker == m_workers.end() || worker->second.quarantined) return std::nullopt;
    // Highest priority first, then the oldest job (FIFO).
    std::vector<std::pair<int, uint64_t>> order;
    for (const auto& [id, candidate] : m_jobs) {
        if (!candidate.running || candidate.paused || !mayRender(worker->second, candidate))
            continue;
        const bool pending =
            !candidate.pending.empty() && *candidate.pending.begin() < candidate.leaseLimit;
        if (pending || !candidate.audits.empty()) order.emplace_back(-candidate.priority, id);
    }
    std::sort(order.begin(), order.end());
    for (const auto& [negativePriority, jobId] : order) {
        Job& best = m_jobs.at(jobId);
        const std::optional<uint32_t> index = pickUnit(jobId, best, workerId);
        if (!index) continue;
        worker->second.lastChunk[jobId] = best.grid.chunkOf(*index);
        const uint64_t leaseId = m_nextLeaseId++;
        farm::CoordinatorMetrics::unitLeased(best.units[*index].leaseId != 0);  // 0: never leased
        grant(jobId, best, *index, workerId, leaseId);
        ++best.counts.leasedThisRun;
        return Lease{leaseId, jobId, *index, m_tokens.token(leaseId, workerId, jobId, *index)};
    }
    return std::nullopt;
}

bool LeaseScheduler::couldLease(uint64_t workerId, uint64_t jobId) const {
    auto worker = m_workers.find(workerId);
    auto candidate = m_jobs.find(jobId);
    if (worker == m_workers.end() || candidate == m_jobs.end()) return false;
    const Job& job = candidate->second;
    return job.running && !job.paused && mayRender(worker->second, job) &&
           pickUnit(jobId, job, workerId).has_value();
}

// Audits come first: their results wait in the coordinator's memory, and a worker on probation
// waits for them. Then locality: a worker keeps the per-pass data (photon maps) of the passes it
// rendered last, so it gets another tile of the same pass chunk when one is pending; otherwise
// the first unit of a chunk no other live worker is on, so each chunk's photons are traced by one
// worker; only when every pending unit's chunk is taken does it share one (the end of a job).
std::optional<uint32_t> LeaseScheduler::pickUnit(uint64_t jobId, const Job& job,
                                                 uint64_t workerId) const {
    const Worker& me = m_workers.at(workerId);
    for (const auto& [unitIndex, renderers] : job.audits)
        if (unitIndex < job.leaseLimit && job.units[unitIndex].state == UnitState::Pending &&
            std::find(renderers.begin(), renderers.end(), workerId) == renderers.end() &&
            !failedOnHost(job, unitIndex, me.host))
            return unitIndex;
    if (me.auditing.count(jobId)) return std::nullopt;  // on probation: its first result waits
    // A unit that failed on this host goes to another one first, when one could take it.
    const bool avoidFailures =
        !job.failedOn.empty() &&
        anyLiveWorker(job, [&](uint64_t, const Worker& worker) { return worker.host == me.host; });
    const auto allowed = [&](uint32_t unitIndex) {
        return !avoidFailures || !failedOnHost(job, unitIndex, me.host);
    };
    const farm::JobGrid& grid = job.grid;
    // The first pending unit in [from, to) below the lease limit that the worker may take.
    const auto firstAllowed = [&](uint32_t from, uint32_t to) {
        to = std::min(to, job.leaseLimit);
        for (auto it = job.pending.lower_bound(from); it != job.pending.end() && *it < to; ++it)
            if (allowed(*it)) return it;
        return job.pending.end();
    };
    const auto firstOfChunk = [&](uint32_t chunk) {
        return firstAllowed(chunk * grid.tileCount(), (chunk + 1) * grid.tileCount());
    };
    std::set<uint32_t> taken;
    const double recent = m_clock.monotonicSeconds() - m_options.leaseSeconds;
    for (const auto& [id, worker] : m_workers) {
        auto chunk = worker.lastChunk.find(jobId);
        if (chunk == worker.lastChunk.end()) continue;
        if (id == workerId) {
            if (auto it = firstOfChunk(chunk->second); it != job.pending.end()) return *it;
        } else if (worker.lastSeen >= recent) {
            taken.insert(chunk->second);
        }
    }
    for (auto it = job.pending.begin(); it != job.pending.end() && *it < job.leaseLimit;) {
        const uint32_t chunk = grid.chunkOf(*it);
        if (!taken.count(chunk))
            if (auto first = firstOfChunk(chunk); first != job.pending.end()) return *first;
        it = job.pending.lower_bound((chunk + 1) * grid.tileCount());
    }
    if (auto first = firstAllowed(0, UINT32_MAX); first != job.pending.end()) return *first;
    return std::nullopt;
}

bool LeaseScheduler::renew(uint64_t workerId, uint64_t leaseId, const HeldUnit* held) {
    if (!m_workers.count(workerId)) return false;
    auto it = m_leases.find(leaseId);
    if (it == m_leases.end() && held) {
        // A lease granted to this worker by an earlier coordinator process (the token says
        // so): re-adopt the unit if it is still waiting, so the worker's render is not thrown
        // away. Invented leases and leases that expired in this process are fenced.
        auto adopted = m_jobs.find(held->jobId);
        if (adopted != m_jobs.end() && adopted->second.running &&
            held->unitIndex < adopted->second.units.size() &&
            held->unitIndex < adopted->second.leaseLimit &&
            adopted->second.units[held->unitIndex].state == UnitState::Pending &&
            m_tokens.grantedEarlier(held->token, leaseId, workerId, held->jobId, held->unitIndex)) {
            grant(held->jobId, adopted->second, held->unitIndex, workerId, leaseId);
            it = m_leases.find(leaseId);
        }
    }
    if (it == m_leases.end()) return false;
    UnitSlot& slot = job(it->second.jobId).units[it->second.unitIndex];
    if (slot.workerId != workerId || slot.state != UnitState::Leased) return false;
    slot.deadline = m_clock.monotonicSeconds() + m_options.leaseSeconds;
    return true;
}

bool LeaseScheduler::mayMerge(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) const {
    const Job& target = job(jobId);
    if (!target.running || unitIndex >= target.units.size() || unitIndex >= target.leaseLimit)
        return false;
    const UnitSlot& slot = target.units[unitIndex];
    if (slot.state == UnitState::Merged) return false;
    return slot.state == UnitState::Pending || slot.leaseId == leaseId;
}

bool LeaseScheduler::markMerged(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) {
    if (!mayMerge(jobId, unitIndex, leaseId)) return false;
    Job& target = job(jobId);
    UnitSlot& slot = target.units[unitIndex];
    if (slot.state == UnitState::Leased) release(target, slot);
    target.pending.erase(unitIndex);  // a result from an earlier lease of a requeued unit
    target.audits.erase(unitIndex);
    target.failedOn.erase(unitIndex);
    slot.state = UnitState::Merged;
    return true;
}

bool LeaseScheduler::wantsAudit(uint64_t jobId, uint32_t unitIndex, uint64_t workerId) const {
    const Job& target = job(jobId);
    auto worker = m_workers.find(workerId);
    if (worker == m_workers.end()) return false;
    const bool first = !worker->second.trusted.count(jobId);
    if (!first && m_tokens.auditDraw(jobId, unitIndex) >= m_options.auditFraction) return false;
    return anotherLiveWorker(target, workerId, {}, unitIndex);
}

bool LeaseScheduler::holdForAudit(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId,
                                  uint64_t workerId) {
    if (!mayMerge(jobId, unitIndex, leaseId)) return false;
    Job& target = job(jobId);
    UnitSlot& slot = target.units[unitIndex];
    if (slot.state == UnitState::Leased) release(target, slot);
    target.pending.erase(unitIndex);
    std::vector<uint64_t>& renderers = target.audits[unitIndex];
    if (std::find(renderers.begin(), renderers.end(), workerId) == renderers.end())
        renderers.push_back(workerId);
    if (auto worker = m_workers.find(workerId);
        worker != m_workers.end() && !worker->second.trusted.count(jobId))
        worker->second.auditing.insert(jobId);
    return true;
}

std::vector<uint64_t> LeaseScheduler::heldResults(uint64_t jobId, uint32_t unitIndex) const {
    const Job& target = job(jobId);
    auto audit = target.audits.find(unitIndex);
    return audit == target.audits.end() ? std::vector<uint64_t>() : audit->second;
}

void LeaseScheduler::passProbation(uint64_t workerId, uint64_t jobId) {
    auto worker = m_workers.find(workerId);
    if (worker == m_workers.end()) return;
    worker->second.auditing.erase(jobId);
    worker->second.trusted.insert(jobId);
}

std::vector<std::pair<uint64_t, uint32_t>> LeaseScheduler::auditsWithoutAuditor() const {
    std::vector<std::pair<uint64_t, uint32_t>> stranded;
    for (const auto& [jobId, candidate] : m_jobs) {
        if (!candidate.running) continue;
        for (const auto& [unitIndex, renderers] : candidate.audits)
            if (candidate.units[unitIndex].state == UnitState::Pending &&
                !anotherLiveWorker(candidate, renderers.front(), renderers, unitIndex))
                stranded.emplace_back(jobId, unitIndex);
    }
    return stranded;
}

void LeaseScheduler::skipUnits(uint64_t jobId, const std::vector<uint32_t>& unitIndices) {
    Job& target = job(jobId);
    for (uint32_t unitIndex : unitIndices) {
        UnitSlot& slot = target.units.at(unitIndex);
        if (slot.state == UnitState::Leased) release(target, slot);
        target.pending.erase(unitIndex);
        target.audits.erase(unitIndex);
        slot.state = UnitState::Merged;
    }
}

bool LeaseScheduler::holds(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) const {
    const Job& target = job(jobId);
    return target.running && unitIndex < target.units.size() &&
           target.units[unitIndex].state == UnitState::Leased &&
           target.units[unitIndex].leaseId == leaseId;
}

bool LeaseScheduler::handBack(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) {
    if (!holds(jobId, unitIndex, leaseId)) return false;
    Job& target = job(jobId);
    release(target, target.units[unitIndex]);
    requeue(target, unitIndex);
    farm::CoordinatorMetrics::unitHandedBack();
    return true;
}

LeaseScheduler::Failure LeaseScheduler::countFailure(uint64_t jobId, Job& target,
                                                     uint32_t unitIndex, uint64_t workerId) {
    UnitSlot& slot = target.units[unitIndex];
    ++slot.attempts;
    ++target.counts.attemptsFailed;
    Failure failure{jobId, unitIndex, slot.attempts, slot.attempts >= m_options.maxAttempts};
    // A poison unit fails its job, never the farm: the job's scheduling ends here.
    if (failure.poisoned) {
        endJob(jobId);
        return failure;
    }
    target.failedOn[unitIndex].insert(hostOf(workerId));
    requeue(target, unitIndex);
    return failure;
}

std::optional<LeaseScheduler::Failure> LeaseScheduler::failAttempt(uint64_t jobId,
                                                                   uint32_t unitIndex,
                                                                   uint64_t leaseId) {
    if (!holds(jobId, unitIndex, leaseId)) return std::nullopt;
    Job& target = job(jobId);
    const uint64_t workerId = target.units[unitIndex].workerId;
    release(target, target.units[unitIndex]);
    if (target.audits.count(unitIndex)) return failAudit(jobId, target, unitIndex, workerId);
    farm::CoordinatorMetrics::unitFailed(farm::CoordinatorMetrics::FailureCause::WorkerError);
    return countFailure(jobId, target, unitIndex, workerId);
}

std::vector<std::pair<LeaseScheduler::ExpiredLease, LeaseScheduler::Failure>>
LeaseScheduler::expireLeases() {
    const double now = m_clock.monotonicSeconds();
    std::vector<uint64_t> expired;
    for (const auto& [leaseId, ref] : m_leases)
        if (m_jobs.at(ref.jobId).units[ref.unitIndex].deadline < now) expired.push_back(leaseId);
    std::sort(expired.begin(), expired.end());  // the same order on every run
    std::vector<std::pair<ExpiredLease, Failure>> result;
    for (uint64_t leaseId : expired) {
        auto it = m_leases.find(leaseId);
        if (it == m_leases.end()) continue;  // its job was failed by an earlier poison unit
        const LeaseRef ref = it->second;
        Job& target = job(ref.jobId);
        UnitSlot& slot = target.units[ref.unitIndex];
        const ExpiredLease lost{ref.jobId, slot.workerId, ref.unitIndex};
        release(target, slot);
        if (target.audits.count(ref.unitIndex)) {
            result.emplace_back(lost, failAudit(ref.jobId, target, ref.unitIndex, lost.workerId));
            continue;
        }
        farm::CoordinatorMetrics::unitFailed(farm::CoordinatorMetrics::FailureCause::LeaseExpired);
        result.emplace_back(lost, countFailure(ref.jobId, target, ref.unitIndex, lost.workerId));
    }
    return result;
}

void LeaseScheduler::forgiveStall(double seconds) {
    for (const auto& [leaseId, ref] : m_leases)
        m_jobs.at(ref.jobId).units[ref.unitIndex].deadline += seconds;
    for (auto& [id, worker] : m_workers) worker.lastSeen += seconds;
}

std::string LeaseScheduler::checkConsistency() const {
    std::string problems;
    const auto problem = [&](const std::string& text) { problems += text + "; "; };
    for (const auto& [leaseId, ref] : m_leases) {
        auto owner = m_jobs.find(ref.jobId);
        if (owner == m_jobs.end() || ref.unitIndex >= owner->second.units.size()) {
            problem(absl::StrFormat("lease %u names no unit", leaseId));
            continue;
        }
        const UnitSlot& slot = owner->second.units[ref.unitIndex];
        if (slot.state != UnitState::Leased || slot.leaseId != leaseId)
            problem(absl::StrFormat("lease %u: job %u unit %u is held by lease %u (state %d)",
                                    leaseId, ref.jobId, ref.unitIndex, slot.leaseId,
                                    int(slot.state)));
        auto worker = m_workers.find(slot.workerId);
        if (worker == m_workers.end() || !worker->second.leases.count(leaseId))
            problem(
                absl::StrFormat("lease %u: worker %u does not hold it", leaseId, slot.workerId));
    }
    size_t workerLeases = 0;
    for (const auto& [id, worker] : m_workers) {
        workerLeases += worker.leases.size();
        for (uint64_t leaseId : worker.leases)
            if (!m_leases.count(leaseId))
                problem(absl::StrFormat("worker %u holds lease %u that is not in the table", id,
                                        leaseId));
    }
    if (workerLeases != m_leases.size())
        problem(absl::StrFormat("workers hold %u leases, the table has %u", workerLeases,
                                m_leases.size()));
    for (const auto& [jobId, job] : m_jobs) {
        JobLeases recount;
        std::map<uint64_t, uint32_t> byWorker;
        for (uint32_t i = 0; i < job.units.size(); ++i) {
            const UnitSlot& slot = job.units[i];
            if (slot.state == UnitState::Leased) {
                ++recount.leased;
                ++byWorker[slot.workerId];
                auto ref = m_leases.find(slot.leaseId);
                if (ref == m_leases.end() || ref->second.jobId != jobId ||
                    ref->second.unitIndex != i)
                    problem(
                        absl::StrFormat("job %u unit %u is leased by lease %u, which is not "
                                        "in the table for it",
                                        jobId, i, slot.leaseId));
            }
            recount.attemptsFailed += slot.attempts;
            const bool waits =
                job.running && slot.state == UnitState::Pending && !job.audits.count(i);
            if (job.pending.count(i) != waits)
                problem(absl::StrFormat("job %u unit %u: pending %d, state %d, running %d", jobId,
                                        i, int(job.pending.count(i)), int(slot.state),
                                        int(job.running)));
        }
        if (!job.running && recount.leased > 0)
            problem(absl::StrFormat("ended job %u has %u leases", jobId, recount.leased));
        recount.activeWorkers = uint32_t(byWorker.size());
        if (recount.leased != job.counts.leased ||
            recount.activeWorkers != job.counts.activeWorkers ||
            recount.attemptsFailed != job.counts.attemptsFailed || byWorker != job.leasesByWorker)
            problem(absl::StrFormat(
                "job %u counts %u leased, %u workers, %u failed; a recount "
                "gives %u, %u, %u",
                jobId, job.counts.leased, job.counts.activeWorkers, job.counts.attemptsFailed,
                recount.leased, recount.activeWorkers, recount.attemptsFailed));
    }
    return problems;
}

}  // namespace alphorn::coordinator
