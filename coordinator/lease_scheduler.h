// Which worker renders which unit, and until when: the queue of pending units of the running
// jobs (highest priority first, then the oldest job), leases with deadlines renewed by heartbeats,
// fencing of stale leases and results, re-adoption of leases granted by an earlier process, failed
// attempts and poison units (a unit that failed on a worker goes to another one first), pass-chunk
// locality, which workers may render a job (the same engine fingerprint, not quarantined), and
// audits: a unit rendered again by another worker so the coordinator can compare the two results
// before merging either. Pure logic: no storage, no threads, no locks (the caller serializes
// calls), and the time comes only from the Clock it is given.
#pragma once

#include "common/farm/job_grid.h"
#include "coordinator/clock.h"
#include "coordinator/lease_tokens.h"

#include <cstdint>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace alphorn::coordinator {

struct SchedulerOptions {
    double leaseSeconds = 15.0;
    uint32_t maxAttempts = 3;  // failed attempts after which a unit fails its job
    // Share of units audited besides each worker's first unit of each job (auditDraw()).
    double auditFraction = 0.01;
};

class LeaseScheduler {
  public:
    enum class UnitState : uint8_t { Pending, Leased, Merged };
    struct UnitSlot {
        uint64_t leaseId = 0, workerId = 0;
        double deadline = 0;  // monotonic seconds
        uint32_t attempts = 0;
        UnitState state = UnitState::Pending;
    };
    // Memory the scheduler takes per unit: its slot and a node of the pending set (40 bytes in
    // libstdc++, 48 with the allocator's rounding).
    static constexpr uint64_t kBytesPerUnit = sizeof(UnitSlot) + 48;

    struct Lease {
        uint64_t leaseId = 0, jobId = 0;
        uint32_t unitIndex = 0;
        std::string token;  // see LeaseTokens
    };
    struct Failure {
        uint64_t jobId = 0;
        uint32_t unitIndex = 0;
        uint32_t attempts = 0;  // failed attempts of the unit so far
        // Attempts reached maxAttempts: the scheduler ended the job (endJob), and the caller
        // records it as failed.
        bool poisoned = false;
        // A render for an audit failed: not an attempt of the unit (its result is held), and
        // the unit is not given to a worker of that host for its audit again.
        bool audit = false;
    };
    struct ExpiredLease {
        uint64_t jobId = 0, workerId = 0;
        uint32_t unitIndex = 0;
    };
    // Lease counts of one job, kept up to date as leases come and go.
    struct JobLeases {
        uint32_t leased = 0, activeWorkers = 0, leasedThisRun = 0, attemptsFailed = 0;
    };

    LeaseScheduler(const Clock& clock, SchedulerOptions options, LeaseTokens tokens,
                   uint64_t firstLeaseId);

    const SchedulerOptions& options() const { return m_options; }
    const LeaseTokens& tokens() const { return m_tokens; }

    // A job to schedule: its units not in `merged` are pending (running) or idle (ended). Only
    // workers of `engineFingerprint` render them (empty matches empty: the scheduler's own tests).
    void addJob(uint64_t jobId, int priority, const farm::JobGrid& grid,
                const std::vector<bool>& merged, const std::vector<uint32_t>& attempts,
                bool running, const std::string& engineFingerprint = "");
    // Everything merged is forgotten (a quarantined worker's results were in the job's film):
    // every unit is pending again, leases out are dropped and results held for audits are
    // forgotten (the caller drops them); attempts are kept.
    void restartJob(uint64_t jobId);
    // The job ended: no more leases, and its current leases are dropped (fenced).
    void endJob(uint64_t jobId);
    // Forgets an ended job.
    void removeJob(uint64_t jobId);
    bool running(uint64_t jobId) const;
    // The decision barrier of a job with a target error (JobFilm::leaseLimit): units from
    // `unitLimit` on are neither leased, re-adopted nor merged until it is raised. Every unit
    // of a job may be, until this is called.
    void setLeaseLimit(uint64_t jobId, uint32_t unitLimit);
    // Units an adaptive job no longer needs (their tile met the target, JobFilm): they count as
    // merged and are never leased. A lease on one (none is expected: they lie past the decision
    // barrier) is dropped.
    void skipUnits(uint64_t jobId, const std::vector<uint32_t>& unitIndices);
    // A paused job gets no new leases; its leases out may still be renewed, merged and failed.
    void setPaused(uint64_t jobId, bool paused);
    bool paused(uint64_t jobId) const;
    void setPriority(uint64_t jobId, int priority);
    JobLeases jobLeases(uint64_t jobId) const;
    const UnitSlot& unit(uint64_t jobId, uint32_t unitIndex) const;

    // `seen`: false for a worker restored from storage (not seen by this process yet). It
    // renders units of the jobs of its engine fingerprint.
    // `hostId` (RegisterRequest.host_id) is the same for every registration of a worker that
    // restarted on the same cache; empty: the worker id stands for it.
    void addWorker(uint64_t workerId, bool seen, const std::string& engineFingerprint = "",
                   bool quarantined = false, const std::string& hostId = "");
    // An audit found the worker's results wrong: it is leased nothing any more, its leases go
    // back to the queue and the results it has waiting for audits are forgotten (the caller
    // drops them). Returns the units whose audit has no result left, which are pending again.
    std::vector<std::pair<uint64_t, uint32_t>> quarantineWorker(uint64_t workerId);
    bool quarantined(uint64_t workerId) const;
    // Why the worker is given nothing: quarantined, or units wait only for workers of another
    // engine fingerprint; "" otherwise.
    std::string idleReason(uint64_t workerId) const;
    // Notes a call from the worker; false when it is unknown.
    bool touchWorker(uint64_t workerId);
    void forgetWorker(uint64_t workerId);
    bool knowsWorker(uint64_t workerId) const { return m_workers.count(workerId) > 0; }
    uint32_t leaseCount(uint64_t workerId) const;
    double secondsSinceSeen(uint64_t workerId) const;
    // The units the worker holds a lease on, as (job id, unit index), in ascending order.
    std::vector<std::pair<uint64_t, uint32_t>> unitsLeasedTo(uint64_t workerId) const;

    // Leases the next unit to a known worker, or nothing when no unit is pending.
    std::optional<Lease> lease(uint64_t workerId);
    // Whether lease(workerId) could give the worker a unit of this job now (not paused, its
    // build, a unit open to it: not on probation there, not its own held result, not one that
    // failed on its host while another host could take it). The simulation checks priorities
    // with it.
    bool couldLease(uint64_t workerId, uint64_t jobId) const;
    // A heartbeat for one held lease: renews it and returns true, or returns false when the
    // worker must drop it (expired, merged, reassigned, job ended). A lease unknown to this
    // process is re-adopted when `held` proves an earlier process granted it and the unit still
    // waits.
    struct HeldUnit {
        uint64_t jobId = 0;
        uint32_t unitIndex = 0;
        std::string token;
    };
    bool renew(uint64_t workerId, uint64_t leaseId, const HeldUnit* held);

    // May a result of this unit under this lease be merged? No when the job ended, the unit is
    // merged, or another lease holds it. (A result of an expired lease for a unit that waits
    // again is taken: the work is done and every unit is a pure function of the job.)
    bool mayMerge(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) const;
    // Marks the unit merged (releasing its lease); false when mayMerge() no longer holds.
    bool markMerged(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId);
    // Is `leaseId` the unit's current lease? Only its holder may report failure or hand back.
    bool holds(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId) const;
    // The holder gives the unit back untried (not an attempt); false when it is not the holder.
    bool handBack(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId);
    // The holder failed: releases the lease and counts an attempt (nullopt: not the holder).
    std::optional<Failure> failAttempt(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId);
    // Releases every lease past its deadline and counts an attempt for each (in lease order).
    std::vector<std::pair<ExpiredLease, Failure>> expireLeases();
    // The process did not run for `seconds` (stopped, a paused machine): every lease deadline and
    // every worker's last call move that much later, so nobody is charged for the pause.
    void forgiveStall(double seconds);

    // Audits. A result is audited when it is the worker's first of the job or the unit's
    // auditDraw() falls below the audit fraction, and a live worker of the job's fingerprint
    // could render it again (wantsAudit). The caller then keeps the result and calls holdForAudit:
    // the unit waits for a worker that has not rendered it (such units are leased before any
    // other of their job). Until a worker's first result of a job passes its audit, it is given
    // no other unit of that job, so a worker that is wrong from the start merges nothing. When
    // the results agree the caller merges one (markMerged) and passes the workers
    // (passProbation); when they differ it holds the new one too, and a third worker decides.
    bool wantsAudit(uint64_t jobId, uint32_t unitIndex, uint64_t workerId) const;
    // Releases the lease (not an attempt) and queues the unit for a render by a worker that is
    // not among those whose results are held; false when mayMerge() does not hold.
    bool holdForAudit(uint64_t jobId, uint32_t unitIndex, uint64_t leaseId, uint64_t workerId);
    // The workers whose results of the unit are held for an audit (empty: none).
    std::vector<uint64_t> heldResults(uint64_t jobId, uint32_t unitIndex) const;
    // The worker's results of the job are trusted: it may be leased its other units.
    void passProbation(uint64_t workerId, uint64_t jobId);
    // Units waiting for an audit that no live worker outside their renderers may take any more
    // (the others left or were quarantined): the caller merges the held result unaudited (one
    // result) or waits (results that disagree).
    std::vector<std::pair<uint64_t, uint32_t>> auditsWithoutAuditor() const;

    // Walks every table and returns what disagrees (empty when consistent): each lease in the
    // lease table names a leased unit that names it back and its worker holds it, no unit is
    // leased twice, pending units are exactly the waiting units of running jobs, and the
    // counters equal a recount. For tests and the simulation; it takes time per unit.
    std::string checkConsistency() const;

  private:
    struct Job {
        int priority = 0;
        bool running = true;
        std::string engineFingerprint;
        uint32_t leaseLimit = UINT32_MAX;
        bool paused = false;
        farm::JobGrid grid;
        std::vector<UnitSlot> units;
        std::set<uint32_t> pending;
        std::map<uint64_t, uint32_t> leasesByWorker;  // worker -> leases held on this job
        JobLeases counts;
        // Units whose results wait for an audit, with the workers that rendered them: not in
        // `pending`, leased only to other workers.
        std::map<uint32_t, std::vector<uint64_t>> audits;
        // Hosts each unit failed on (an error or an expired lease): it goes to another first.
        std::map<uint32_t, std::set<std::string>> failedOn;
    };
    struct Worker {
        double lastSeen = 0;
        std::set<uint64_t> leases;
        // The pass chunk of each job this worker last leased: it holds that chunk's pass data.
        std::map<uint64_t, uint32_t> lastChunk;
        std::string engineFingerprint;
        std::string host;  // RegisterRequest.host_id, or the worker id
        bool quarantined = false;
        // Jobs whose first result from this worker is being audited (no other unit of the job
        // until it passes), and jobs where it passed.
        std::set<uint64_t> auditing, trusted;
    };
    struct LeaseRef {
        uint64_t jobId;
        uint32_t unitIndex;
    };

    Job& job(uint64_t jobId);
    const Job& job(uint64_t jobId) const;
    // The unit to lease the worker from the job, if it may take one: an audit first, then by
    // pass-chunk locality, avoiding units that failed on it while another worker could take them.
    std::optional<uint32_t> pickUnit(uint64_t jobId, const Job& job, uint64_t workerId) const;
    // Whether a worker other than `workerId` and those in `besides`, of the job's fingerprint
    // and not quarantined, called within the lease time.
    // With `unitIndex`, also not on a host the unit failed on.
    bool anotherLiveWorker(const Job& job, uint64_t workerId,
                           const std::vector<uint64_t>& besides = {},
                           std::optional<uint32_t> unitIndex = std::nullopt) const;
    // A failed lease of an audit render: releases it and notes the host.
    Failure failAudit(uint64_t jobId, Job& job, uint32_t unitIndex, uint64_t workerId);
    const std::string& hostOf(uint64_t workerId) const;
    // Whether a worker that called within the lease time, of the job's fingerprint and not
    // quarantined, is not `excluded(id, worker)`.
    template <typename Excluded>
    bool anyLiveWorker(const Job& job, Excluded excluded) const;
    static bool failedOnHost(const Job& job, uint32_t unitIndex, const std::string& host);
    // The unit waits for a lease again, unless its job ended or its result is held for an
    // audit (then only an auditor may take it).
    void requeue(Job& job, uint32_t unitIndex);
    bool mayRender(const Worker& worker, const Job& job) const;
    void grant(uint64_t jobId, Job& job, uint32_t unitIndex, uint64_t workerId, uint64_t leaseId);
    void release(Job& job, UnitSlot& slot);
    // Counts a failed attempt of the unit on `workerId` (already released).
    Failure countFailure(uint64_t jobId, Job& job, uint32_t unitIndex, uint64_t workerId);

    const Clock& m_clock;
    SchedulerOptions m_options;
    LeaseTokens m_tokens;
    uint64_t m_nextLeaseId;
    std::map<uint64_t, Job> m_jobs;  // by id: ascending ids are submission order (FIFO)
    std::map<uint64_t, Worker> m_workers;
    std::unordered_map<uint64_t, LeaseRef> m_leases;
};

}  // namespace alphorn::coordinator
