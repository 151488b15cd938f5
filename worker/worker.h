// The worker's life: register, lease a unit, make sure its job's scene is loaded, render the
// unit with renderUnit() on all cores while a second thread heartbeats, deliver the result in
// chunks (retrying through coordinator outages), repeat. SIGTERM drains: no new work, the
// current unit is finished and delivered, the coordinator is told the worker leaves, then exit
// 0; a second SIGTERM or SIGINT abandons the unit, hands it back (one call of at most a second)
// and exits. A worker drained by a client (`alphorn drain`) stays up and idle until undrained.
// A library (alphorn_worker) so that worker_test.cpp can run it against a scripted coordinator;
// main.cpp only parses flags and forwards signals.
#pragma once

#include "alphorn/v1/worker_service.grpc.pb.h"
#include "common/farm/bundle.h"
#include "common/farm/directory_lock.h"
#include "common/farm/retry_policy.h"
#include "common/render/unit.h"
#include "worker/blob_cache.h"

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>

namespace alphorn {
class Scene;
}

namespace alphorn::worker {

struct WorkerOptions {
    std::string coordinator;
    std::string token;
    std::string cacheDirectory;
    std::string tlsCaPath;
    std::string name;
    int threads = 0;  // 0: all cores
    uint64_t cacheBytes = uint64_t(4) << 30;
    double drainSeconds = 60.0;  // how long a draining worker keeps trying to deliver

    // Waits between attempts at a call that failed for a transient reason. The seed makes the
    // jitter reproducible; 0 draws one at random, so the workers of a farm spread apart.
    farm::RetryTimings retry;
    uint64_t retrySeed = 0;
    // How long each call may wait for an unreachable coordinator before it counts as a failed
    // attempt (calls wait for the coordinator to come back, see farm::makeContext).
    std::chrono::milliseconds registerTimeout{5000};
    std::chrono::milliseconds acquireTimeout{10000};
    std::chrono::milliseconds deliverTimeout{120000};
    // How long an idle worker keeps the last job's scene and pass data loaded. More units of
    // that job reuse them, but a render node without work should give its memory back: a large
    // scene or photon map can hold gigabytes.
    std::chrono::milliseconds unloadAfter{30000};
    // Called with each backoff delay before the worker waits it out (tests watch the policy).
    std::function<void(std::chrono::milliseconds)> onBackoff;
    // Called on the rendering thread after a unit is leased and before it is rendered (tests
    // hold a unit there while they look at heartbeats).
    std::function<void(const v1::AcquireWorkResponse&)> beforeRender;
};

class Worker {
  public:
    explicit Worker(WorkerOptions options);
    ~Worker();

    // Runs until drained; returns the process exit code.
    int run();
    // First call: stop taking work and finish the current unit. Second: abandon and hand back.
    void requestStop();

  private:
    struct JobContext {
        uint64_t jobId = 0;
        std::string identity;  // jobIdentity() of the description the scene was loaded for
        std::shared_ptr<Scene> scene;
        uint64_t seed = 0;
        std::set<std::string> blobs;
        // Pass data of recently rendered pass ranges, built once per range, not per unit.
        std::map<std::pair<uint32_t, uint32_t>, std::vector<std::shared_ptr<const PassData>>>
            passes;
    };
    struct Result {
        v1::ResultChunk header;
        std::string compressed;
    };

    void registerWithCoordinator();
    // The last call before exiting: a heartbeat saying the worker leaves (best effort).
    void sayGoodbye();
    void heartbeatLoop();
    JobContext& prepareJob(const v1::JobDescription& job);
    // Releases the loaded scene and pass data after `idleSeconds` without a unit.
    void unloadIdleJob(double idleSeconds);
    // The per-pass data of passes [begin, end), built or reused; `built` says which.
    const std::vector<std::shared_ptr<const PassData>>& passDataFor(JobContext& context,
                                                                    uint32_t begin, uint32_t end,
                                                                    bool& built);
    std::optional<Result> renderLease(const v1::AcquireWorkResponse& lease);
    // The bundle's files in `directory`, fetched into the cache as needed; returns the scene's
    // path.
    std::string materializeJobBundle(const farm::Bundle& bundle, const std::string& directory);
    // Delivers until the coordinator answers (merged, discarded or refused) or the lease is
    // fenced; keeps the result through outages. Returns false when it had to give up (draining).
    bool deliver(Result& result);
    // Waits the policy's next delay; returns early when the unit is being abandoned.
    void sleepBackoff(farm::RetryPolicy& policy);
    farm::RetryPolicy makeRetryPolicy();
    std::unique_ptr<grpc::ClientContext> context(std::chrono::milliseconds timeout) const;

    WorkerOptions m_options;
    // Taken before the cache is touched: a second worker on the same cache directory is refused.
    farm::DirectoryLock m_cacheLock;
    // RegisterRequest.host_id: kept in the cache directory, so a restarted worker is known as
    // the same host.
    std::string m_hostId;
    std::shared_ptr<grpc::Channel> m_channel;
    std::unique_ptr<v1::WorkerService::Stub> m_stub;
    BlobCache m_cache;
    std::unique_ptr<JobContext> m_job;

    std::atomic<uint64_t> m_workerId{0};
    std::atomic<int> m_stopRequests{0};
    std::atomic<bool> m_mustRegister{true};
    std::atomic<double> m_heartbeatSeconds{2.0};
    uint64_t m_retrySeed = 0;
    std::atomic<uint64_t> m_retryPolicies{0};  // policies made so far: each gets its own stream

    // Leases being worked on (rendering or delivering), shared with the heartbeat thread.
    std::mutex m_leaseMutex;
    std::condition_variable m_leaseWake;
    std::map<uint64_t, v1::HeldUnit> m_activeLeases;  // lease id -> unit
    std::set<uint64_t> m_fencedLeases;                // the coordinator told us to drop these
    std::atomic<bool> m_cancelRender{false};
    uint64_t m_renderingLease = 0;
    grpc::ClientContext* m_acquireContext = nullptr;  // cancelled by requestStop()
    bool m_finished = false;
    std::thread m_heartbeat;
    // Set when this machine's cache could not be written (read-only, full): the unit is handed
    // back, not failed, and the worker stops rather than fail every job it is given.
    std::string m_cacheFailure;
};

}  // namespace alphorn::worker
