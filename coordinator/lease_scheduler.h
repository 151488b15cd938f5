// Which worker renders which unit, and until when: the queue of pending units of the running
// jobs (highest priority first, then the oldest job), leases with deadlines renewed by heartbeats,
// fencing of stale leases and results, re-adoption of leases granted by an earlier process, failed
// attempts and poison units, and pass-chunk locality. Pure logic: no storage, no threads, no
// locks (the caller serializes calls), and the time comes only from the Clock it is given.
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

    // A job to schedule: its units not in `merged` are pending (running) or idle (ended).
    void addJob(uint64_t jobId, int priority, const farm::JobGrid& grid,
                const std::vector<bool>& merged, const std::vector<uint32_t>& attempts,
                bool running);
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

    // `seen`: false for a worker restored from storage (not seen by this process yet).
    void addWorker(uint64_t workerId, bool seen);
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

    // Walks every table and returns what disagrees (empty when consistent): each lease in the
    // lease table names a leased unit that names it back and its worker holds it, no unit is
    // leased twice, pending units are exactly the waiting units of running jobs, and the
    // counters equal a recount. For tests and the simulation; it takes time per unit.
    std::string checkConsistency() const;

  private:
    struct Job {
        int priority = 0;
        bool running = true;
        uint32_t leaseLimit = UINT32_MAX;
        bool paused = false;
        farm::JobGrid grid;
        std::vector<UnitSlot> units;
        std::set<uint32_t> pending;
        std::map<uint64_t, uint32_t> leasesByWorker;  // worker -> leases held on this job
        JobLeases counts;
    };
    struct Worker {
        double lastSeen = 0;
        std::set<uint64_t> leases;
        // The pass chunk of each job this worker last leased: it holds that chunk's pass data.
        std::map<uint64_t, uint32_t> lastChunk;
    };
    struct LeaseRef {
        uint64_t jobId;
        uint32_t unitIndex;
    };

    Job& job(uint64_t jobId);
    const Job& job(uint64_t jobId) const;
    uint32_t pickUnit(uint64_t jobId, const Job& job, uint64_t workerId) const;
    void grant(uint64_t jobId, Job& job, uint32_t unitIndex, uint64_t workerId, uint64_t leaseId);
    void release(Job& job, UnitSlot& slot);
    Failure countFailure(uint64_t jobId, Job& job, uint32_t unitIndex);

    const Clock& m_clock;
    SchedulerOptions m_options;
    LeaseTokens m_tokens;
    uint64_t m_nextLeaseId;
    std::map<uint64_t, Job> m_jobs;  // by id: ascending ids are submission order (FIFO)
    std::map<uint64_t, Worker> m_workers;
    std::unordered_map<uint64_t, LeaseRef> m_leases;
};

}  // namespace alphorn::coordinator
