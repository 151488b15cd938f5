// The workers the coordinator knows: what each registered with, when it last called, whether a
// client drained it and whether it said it is stopping (SIGTERM) or leaving, what it merged in
// this process, and the rules by which `alphorn workers` lists it alive, silent, dead or left.
// Pure logic like the lease scheduler it keeps informed (addWorker, touchWorker, forgetWorker):
// it stores nothing (the caller writes a registration or a drain to the job store first), takes
// no lock (the caller serializes calls), and reads the time only from the Clock it is given.
#pragma once

#include "alphorn/v1/worker_service.pb.h"
#include "coordinator/clock.h"
#include "coordinator/job_store.h"
#include "coordinator/lease_scheduler.h"
#include "coordinator/retention.h"

#include <cstdint>
#include <map>
#include <vector>

namespace alphorn::coordinator {

class WorkerRegistry {
  public:
    struct Worker {
        v1::WorkerInfo info;         // as registered, and its count of merged units
        double lastContactWall = 0;  // wall clock of the last call, or of this process's start
        bool draining = false;       // drained by a client (stored)
        bool exiting = false;        // said it is stopping (SIGTERM)
        bool left = false;           // said it exits now
        // Its merged units in this process: samples, rays and its own render seconds.
        uint64_t samples = 0, rays = 0;
        double renderSeconds = 0;
        std::string quarantined;  // why an audit quarantined it (stored); empty when it is not
    };
    // A unit a worker holds a lease on.
    struct HeldUnit {
        uint64_t jobId = 0;
        uint32_t unitIndex = 0;
    };

    WorkerRegistry(const Clock& clock, LeaseScheduler& scheduler, double leaseSeconds)
        : m_clock(clock), m_scheduler(scheduler), m_leaseSeconds(leaseSeconds) {}

    // Seconds between a worker's heartbeats (told at registration).
    double heartbeatIntervalSeconds() const { return std::max(0.1, m_leaseSeconds / 4); }
    // Silence after which a worker is listed SILENT: two heartbeat intervals, at least 3 s (an
    // idle worker's long poll lasts 2 s).
    double silentAfterSeconds() const { return std::max(3.0, 2 * heartbeatIntervalSeconds()); }

    // A worker found in the store when the coordinator starts: listed dead until it calls, and
    // forgotten after the keep time unless it calls (its last contact counts from now).
    void restore(const WorkerRow& row);
    // A worker that has just registered under `workerId` (stored already).
    void add(uint64_t workerId, const v1::RegisterRequest& request);
    // Notes a call from the worker (so it has not left); nullptr for an unknown worker.
    Worker* touch(uint64_t workerId);
    // Notes a heartbeat and what it says of the worker stopping; nullptr for an unknown worker.
    Worker* heartbeat(const v1::HeartbeatRequest& request);
    // Records a client's drain (stored by the caller first); false when it did not change.
    bool setDraining(Worker& worker, bool draining);
    // Counts a unit the worker rendered and the coordinator merged.
    void recordMerge(uint64_t workerId, uint64_t samples, uint64_t rays, double renderSeconds);

    Worker* find(uint64_t workerId);
    // The worker's name, or "" for an unknown one (for log messages).
    std::string name(uint64_t workerId) const;
    // What `alphorn workers` shows of one worker: its state by the liveness rules, leases,
    // draining, and its rates.
    v1::WorkerInfo info(uint64_t workerId, const Worker& worker) const;
    // Every worker, or only those alive.
    std::vector<v1::WorkerInfo> list(bool includeDead) const;
    // The units each worker holds a lease on right now, by worker id.
    std::map<uint64_t, std::vector<HeldUnit>> heldUnits() const;
    // Forgets the workers that hold no lease and have not called within the keep time (each
    // restart of a worker registers a new id, so the table would grow without bound); returns
    // their ids, for the caller to remove from the store.
    std::vector<uint64_t> forgetSilent(const Retention& retention, double wallNow);

  private:
    const Clock& m_clock;
    LeaseScheduler& m_scheduler;
    double m_leaseSeconds;
    std::map<uint64_t, Worker> m_workers;
};

}  // namespace alphorn::coordinator
