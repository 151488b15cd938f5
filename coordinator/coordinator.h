// The coordinator's core, independent of gRPC: jobs and their unit grids, the scheduler
// (priority, then FIFO), leases with deadlines, fencing, poison-unit detection, the exact merge
// and checkpoints. The gRPC services (services.h) translate calls into these methods.
#pragma once

#include "alphorn/v1/client_service.pb.h"
#include "alphorn/v1/worker_service.pb.h"
#include "common/core/error.h"
#include "common/farm/job_grid.h"
#include "common/render/film.h"
#include "coordinator/blob_store.h"
#include "coordinator/state_db.h"
#include "coordinator/state_lock.h"

#include <chrono>
#include <condition_variable>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <unordered_map>

namespace alphorn::coordinator {

struct CoordinatorOptions {
    std::string stateDirectory;
    double leaseSeconds = 15.0;
    double checkpointIntervalSeconds = 10.0;
    uint32_t maxAttempts = 3;
    uint64_t maxBlobBytes = uint64_t(512) << 20;
    uint64_t maxBundleBytes = uint64_t(2) << 30;
    uint64_t maxImagePixels = uint64_t(8192) * 8192;
    uint32_t maxPasses = 1u << 20;
    int defaultTileSize = 64;
    uint32_t defaultPassesPerUnit = 1;
    // How long an ended job (done, failed, cancelled) stays fetchable before its record, films
    // and bundle are removed, together with blobs no remaining job uses; 0 keeps everything.
    double keepFinishedSeconds = 7 * 24 * 3600.0;
    // Memory the running jobs' films and unit tables may take together; a job that would exceed
    // it is refused at submit. 0: half of the machine's physical memory.
    uint64_t maxMemoryBytes = 0;
};

// An error with the kind of status the client should see.
class FarmError : public Error {
  public:
    enum class Kind { InvalidArgument, NotFound, FailedPrecondition, ResourceExhausted };
    FarmError(Kind kind, const std::string& message) : Error(message), kind(kind) {}
    Kind kind;
};

class Coordinator {
  public:
    // Locks and opens the state directory and resumes every job found in it. Throws Error when
    // another coordinator holds the directory or its database was lost while jobs remain.
    explicit Coordinator(CoordinatorOptions options);
    ~Coordinator();

    // Starts the background thread that expires leases and writes checkpoints.
    void start();
    // Makes waiting AcquireWork calls return, so the server can shut down quickly.
    void beginStop();
    // Stops the background thread and checkpoints every running job (clean shutdown loses nothing).
    void stop();

    BlobStore& blobs() { return m_blobs; }
    void recordBlob(const std::string& sha256, uint64_t size);
    // A client asked for or sent these blobs: they are about to be used, keep them.
    void touchBlobs(const std::vector<std::string>& sha256s);
    const CoordinatorOptions& options() const { return m_options; }

    // Client side.
    v1::JobStatus submit(const v1::SubmitJobRequest& request);
    std::vector<v1::JobStatus> listJobs(uint64_t jobId);  // throws NotFound for an unknown id
    v1::JobStatus cancel(uint64_t jobId);
    std::vector<v1::WorkerInfo> listWorkers(bool includeDead);
    struct ImageSnapshot {
        FilmBlock film;
        v1::JobStatus status;
    };
    // The merged film: a finished job's final film, or (preview) whatever is merged so far.
    ImageSnapshot snapshot(uint64_t jobId, bool preview);
    std::string jobDirectory(uint64_t jobId) const;

    // Worker side.
    uint64_t registerWorker(const v1::RegisterRequest& request);
    // Leases the next unit, waiting until `until` for one. Throws NotFound for an unknown worker.
    v1::AcquireWorkResponse acquire(uint64_t workerId, std::chrono::steady_clock::time_point until);
    v1::HeartbeatResponse heartbeat(const v1::HeartbeatRequest& request);
    // `header` is the first chunk of the stream, `compressedFilm` all data concatenated.
    v1::ResultDisposition report(const v1::ResultChunk& header, const std::string& compressedFilm);
    // Removes the jobs that ended more than keepFinishedSeconds before `wallNow` (seconds since
    // the epoch) and the blobs that no remaining job references and nobody stored or asked for
    // within that time. The background thread calls it every minute; public for tests.
    void pruneFinishedJobs(double wallNow);

    // Coordinator memory a running job takes: its whole-image film plus per-unit bookkeeping.
    static uint64_t jobMemoryBytes(int width, int height, uint64_t unitCount);

    // Upper bound on a unit result's compressed size (for refusing oversized streams early).
    uint64_t maxResultBytes(uint64_t jobId) const;

  private:
    enum class UnitState { Pending, Leased, Merged };
    struct UnitSlot {
        UnitState state = UnitState::Pending;
        uint64_t leaseId = 0, workerId = 0;
        std::chrono::steady_clock::time_point deadline;
        uint32_t attempts = 0;
        std::string lastError;
    };
    struct Job {
        uint64_t id = 0;
        v1::JobDescription description;
        v1::JobState state = v1::JOB_STATE_RUNNING;
        std::string error;
        farm::JobGrid grid;
        int filterBorder = 0;
        FilmBlock film;  // whole image while running; released when the job ends
        std::vector<bool> merged;
        uint32_t mergedCount = 0, restored = 0, mergedThisRun = 0, discarded = 0,
                 attemptsFailed = 0;
        uint32_t checkpointsWritten = 0, checkpointedCount = 0, leasedThisRun = 0;
        bool completing = false;  // every unit merged, final checkpoint being written
        std::vector<UnitSlot> units;
        std::set<uint32_t> pending;
        double createdAt = 0;
        double finishedAt = 0;  // wall clock when the job ended; 0 while running
        std::optional<std::chrono::steady_clock::time_point> firstMergeAt;
        uint64_t samplesMergedThisRun = 0;
        uint64_t passDataBuilds = 0;  // see JobStatus.pass_data_builds
        uint64_t memoryBytes = 0;     // jobMemoryBytes() while running, 0 once ended
        // The last failed checkpoint write (e.g. a full disk); cleared by the next success. A
        // job whose every unit is merged stays running until its final checkpoint is written.
        std::string checkpointError;
        std::mutex checkpointMutex;  // serializes this job's checkpoint writes
    };
    struct WorkerRecord {
        v1::WorkerInfo info;
        std::chrono::steady_clock::time_point lastSeen;
        double lastContactWall = 0;  // wall clock of the last call, or of this process's start
        std::set<uint64_t> leases;
        // The pass chunk of each job this worker last leased: it holds that chunk's pass data.
        std::map<uint64_t, uint32_t> lastChunk;
    };
    struct LeaseRef {
        uint64_t jobId;
        uint32_t unitIndex;
    };

    // The pending unit of `job` to lease to `workerId` next (job.pending must not be empty).
    uint32_t pickUnitLocked(const Job& job, uint64_t workerId) const;
    void resume();
    // Rebuilds one job from its database row and checkpoint; throws Error on a damaged record.
    void resumeJob(Job& job, const std::string& description, int width, int height,
                   int filterBorder);
    void backgroundLoop();
    void expireLeases();
    void checkpointDirtyJobs();
    // Writes `film`/`merged` unless a newer checkpoint of the job exists already.
    void writeJobCheckpoint(Job& job, const FilmBlock& film, const std::vector<bool>& merged,
                            uint32_t count);
    // Called without m_mutex held once every unit is merged: writes the final checkpoint, then
    // ends the job DONE. When the write fails the job stays running with the error shown, and
    // the background thread (or stop()) tries again.
    void finishJob(Job& job);
    // The token a worker shows to have its lease re-adopted by a later coordinator process.
    std::string leaseToken(uint64_t epoch, uint64_t leaseId, uint64_t workerId, uint64_t jobId,
                           uint32_t unitIndex) const;
    bool leaseTokenValid(const std::string& token, uint64_t leaseId, uint64_t workerId,
                         uint64_t jobId, uint32_t unitIndex) const;

    // The following require m_mutex.
    Job& jobLocked(uint64_t jobId);
    v1::JobStatus statusLocked(const Job& job) const;
    void releaseLeaseLocked(uint64_t leaseId);
    void recordFailureLocked(Job& job, uint32_t unitIndex, const std::string& message);
    void endJobLocked(Job& job, v1::JobState state, const std::string& error);
    WorkerRecord* touchWorkerLocked(uint64_t workerId);

    CoordinatorOptions m_options;
    StateDirectoryLock m_lock;
    StateDatabase m_db;
    BlobStore m_blobs;
    mutable std::mutex m_mutex;
    std::condition_variable m_workAvailable;
    std::map<uint64_t, std::unique_ptr<Job>> m_jobs;
    std::map<uint64_t, WorkerRecord> m_workers;
    std::unordered_map<uint64_t, LeaseRef> m_leases;
    std::unordered_map<std::string, double> m_blobsTouchedAt;  // sha256 -> wall clock
    uint64_t m_nextLeaseId;
    uint64_t m_epoch = 0;        // this process's start number on the state directory
    std::string m_leaseKey;      // HMAC key of lease tokens, kept in the database
    uint64_t m_memoryInUse = 0;  // sum of running jobs' memoryBytes
    bool m_stopping = false, m_stopped = false;
    std::thread m_background;
    std::condition_variable m_backgroundWake;
};

}  // namespace alphorn::coordinator
