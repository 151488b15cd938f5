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
                            bool running) {
    Job& added = m_jobs[jobId];
    added = Job();
    added.priority = priority;
    added.running = running;
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
    for (UnitSlot& slot : ended.units)
        if (slot.state == UnitState::Leased) release(ended, slot);
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

void LeaseScheduler::addWorker(uint64_t workerId, bool seen) {
    Worker& worker = m_workers[workerId];
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
        if (held.running) held.pending.insert(ref.unitIndex);
    }
    m_workers.erase(it);
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
    if (worker == m_workers.end()) return std::nullopt;
    // Highest priority first, then the oldest job (FIFO).
    uint64_t bestId = 0;
    Job* best = nullptr;
    for (auto& [id, candidate] : m_jobs) {
        if (!candidate.running || candidate.paused || candidate.pending.empty() ||
            *candidate.pending.begin() >= candidate.leaseLimit)
            continue;
        if (!best || candidate.priority > best->priority) {
            best = &candidate;
            bestId = id;
        }
    }
    if (!best) return std::nullopt;
    const uint32_t index = pickUnit(bestId, *best, workerId);
    worker->second.lastChunk[bestId] = best->grid.chunkOf(index);
    const uint64_t leaseId = m_nextLeaseId++;
    farm::CoordinatorMetrics::unitLeased(best->units[index].leaseId != 0);  // 0: never leased
    grant(bestId, *best, index, workerId, leaseId);
    ++best->counts.leasedThisRun;
    return Lease{leaseId, bestId, index, m_tokens.token(leaseId, workerId, bestId, index)};
}

// Locality: a worker keeps the per-pass data (photon maps) of the passes it rendered last, so
// it gets another tile of the same pass chunk when one is pending; otherwise the first unit
// of a chunk no other live worker is on, so each chunk's photons are traced by one worker;
// only when every pending unit's chunk is taken does it share one (the end of a job).
uint32_t LeaseScheduler::pickUnit(uint64_t jobId, const Job& job, uint64_t workerId) const {
    const farm::JobGrid& grid = job.grid;
    const auto firstOfChunk = [&](uint32_t chunk) {
        auto it = job.pending.lower_bound(chunk * grid.tileCount());
        return it != job.pending.end() && grid.chunkOf(*it) == chunk && *it < job.leaseLimit
                   ? it
                   : job.pending.end();
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
        if (!taken.count(chunk)) return *it;
        it = job.pending.lower_bound((chunk + 1) * grid.tileCount());
    }
    return *job.pending.begin();
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
    slot.state = UnitState::Merged;
    return true;
}

void LeaseScheduler::skipUnits(uint64_t jobId, const std::vector<uint32_t>& unitIndices) {
    Job& target = job(jobId);
    for (uint32_t unitIndex : unitIndices) {
        UnitSlot& slot = target.units.at(unitIndex);
        if (slot.state == UnitState::Leased) release(target, slot);
        target.pending.erase(unitIndex);
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
    target.pending.insert(unitIndex);
    farm::CoordinatorMetrics::unitHandedBack();
    return true;
}

LeaseScheduler::Failure LeaseScheduler::countFailure(uint64_t jobId, Job& target,
                                                     uint32_t unitIndex) {
    UnitSlot& slot = target.units[unitIndex];
    ++slot.attempts;
    ++target.counts.attemptsFailed;
    Failure failure{jobId, unitIndex, slot.attempts, slot.attempts >= m_options.maxAttempts};
    // A poison unit fails its job, never the farm: the job's scheduling ends here.
    if (failure.poisoned)
        endJob(jobId);
    else
        target.pending.insert(unitIndex);
    return failure;
}

std::optional<LeaseScheduler::Failure> LeaseScheduler::failAttempt(uint64_t jobId,
                                                                   uint32_t unitIndex,
                                                                   uint64_t leaseId) {
    if (!holds(jobId, unitIndex, leaseId)) return std::nullopt;
    Job& target = job(jobId);
    release(target, target.units[unitIndex]);
    farm::CoordinatorMetrics::unitFailed(farm::CoordinatorMetrics::FailureCause::WorkerError);
    return countFailure(jobId, target, unitIndex);
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
        farm::CoordinatorMetrics::unitFailed(farm::CoordinatorMetrics::FailureCause::LeaseExpired);
        result.emplace_back(lost, countFailure(ref.jobId, target, ref.unitIndex));
    }
    return result;
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
            if (job.pending.count(i) != (job.running && slot.state == UnitState::Pending))
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
