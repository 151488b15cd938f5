// The coordinator: a thin façade over its parts, independent of gRPC. It holds them together
// under one lock and runs the background work (lease expiry, checkpoints, retention). Where each
// step of a job happens:
//   admission.h        admitted: a submitted job is checked and completed with defaults
//   job_store.h        stored: jobs, failed attempts, workers and the lease key (SQLite)
//   lease_scheduler.h  leased: units are queued, leased, renewed, fenced, failed and re-adopted
//   job_film.h         merged and checkpointed: results go into the job's film, which is
//                      written to its checkpoint file (checkpoint.h) and read back
//   worker_registry.h  the workers: registration, liveness, drains, what each merged
//   retention.h        ended jobs, unused blobs and silent workers are forgotten
//   event_log.h        each job's bounded log of what happened to it
//   change_signal.h    each job's change signal, which WatchJob waits on
// The façade's own code is in three files: coordinator.cpp (the lock, the background work, and
// the calls of submission, leasing, merging and checkpointing), recovery.cpp (taking up the
// state directory at start) and job_control.cpp (cancel, retry, pause, priority, delete, drain,
// and removing what the keep time lets go). The gRPC services (services.h) translate calls into
// these methods.
#pragma once

#include "alphorn/v1/client_service.pb.h"
#include "alphorn/v1/worker_service.pb.h"
#include "common/core/error.h"
#include "common/farm/directory_lock.h"
#include "common/farm/job_grid.h"
#include "common/render/film.h"
#include "coordinator/blob_store.h"
#include "coordinator/change_signal.h"
#include "coordinator/clock.h"
#include "coordinator/event_log.h"
#include "coordinator/farm_error.h"
#include "coordinator/job_film.h"
#include "coordinator/job_store.h"
#include "coordinator/lease_scheduler.h"
#include "coordinator/worker_registry.h"

#include <chrono>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <unordered_map>

namespace alphorn::coordinator {

// The exposures, in stops, of the PNG images the coordinator makes (GetImage, the dashboard's
// preview); beyond them a PNG is all black or all white, and NaN or infinity mean nothing.
inline constexpr float kMaxPngExposureStops = 20;

// How long a retry or delete sent with a request id is remembered (ControlRequestRow): longer
// than any client goes on asking again (its --reconnect-seconds is at most a day, after the
// call broke), so that every repeated request is recognised, and bounded, since a delete's
// record outlives its job.
inline constexpr double kControlRequestKeepSeconds = 2 * 24 * 3600.0;

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
    // How long an ended job (done, failed, cancelled) stays listed, a done job's image
    // fetchable, before its record, films and bundle are removed, together with blobs no
    // remaining job uses; 0 keeps everything.
    double keepFinishedSeconds = 7 * 24 * 3600.0;
    // Memory the running jobs' films and unit tables may take together; a job that would exceed
    // it is refused at submit. 0: half of the machine's physical memory.
    uint64_t maxMemoryBytes = 0;
    // Share of units rendered by a second worker and compared before merging, besides each
    // worker's first unit of each job, which is always audited (LeaseScheduler).
    double auditFraction = 0.01;
    // A gap this long between two ticks of the background thread means the process did not run
    // (SIGSTOP, a paused machine): leases and workers' silence are forgiven that long.
    double stallSeconds = 2.0;
};

class Coordinator {
  public:
    // Locks and opens the state directory and resumes every job found in it. Throws Error when
    // another coordinator holds the directory or its database was lost while jobs remain. Every
    // reading of the time comes from `clock`.
    explicit Coordinator(CoordinatorOptions options,
                         std::shared_ptr<const Clock> clock = std::make_shared<SystemClock>());
    ~Coordinator();

    // Starts the background thread that calls tick() every 200 ms.
    void start();
    // Makes waiting AcquireWork calls return and closes every job's change signal (WatchJob
    // streams end), so the server can shut down quickly.
    void beginStop();
    // Stops the background thread and checkpoints every running job with unwritten merges (clean
    // shutdown loses nothing).
    void stop();
    // After stop(): how many running jobs' last checkpoint could not be written (a full or
    // read-only state directory), whose merged units a restart renders again.
    int jobsUnsavedAtStop() const { return m_jobsUnsavedAtStop; }
    // After stop(): the units those jobs merged since their last written checkpoints.
    uint64_t unitsUnsavedAtStop() const { return m_unitsUnsavedAtStop; }
    // The background work, once: expires leases that are past their deadline, and when due
    // (by the clock) removes what the keep time lets go (every minute) and checkpoints the jobs
    // with new merges (every checkpoint interval). The background thread calls it; without
    // start(), whoever drives the coordinator (the simulation) calls it, from one thread.
    void tick();

    BlobStore& blobs() { return m_blobs; }
    // A blob was uploaded or a client asked for or sent these blobs: they are about to be used,
    // keep them.
    void touchBlobs(const std::vector<std::string>& sha256s);
    const CoordinatorOptions& options() const { return m_options; }

    // Client side.
    // Admits and queues a job. A request whose submission_id and owner are those of a listed
    // job returns that job's status and creates nothing (a client asking again after losing the
    // answer); one whose id an earlier call is still admitting waits for that call and returns
    // its job, or admits the job itself should that call refuse it. `callerGone`, asked while
    // such a call waits and once the scene has loaded (before anything is stored), refuses the
    // job with CallerGone when it says nobody waits for the answer any more, unless another
    // call with the same id waits for the job: that one gets it.
    v1::JobStatus submit(const v1::SubmitJobRequest& request,
                         const std::function<bool()>& callerGone = {});
    std::vector<v1::JobStatus> listJobs(uint64_t jobId);  // throws NotFound for an unknown id
    v1::JobStatus cancel(uint64_t jobId);
    std::vector<v1::WorkerInfo> listWorkers(bool includeDead);

    // Job and worker control (job_control.cpp). Each throws FarmError (NotFound for an unknown job,
    // FailedPrecondition for a change the job's state does not allow, with the reason) and
    // records the change durably and in the job's event log.
    // Runs a failed or cancelled job again under its id: units in its checkpoint stay merged,
    // the others are queued with their attempts forgotten (same bytes as a fresh job).
    // A nonempty `requestId` (RetryJobRequest.request_id) is recorded with the change: the same
    // id sent again answers with the first call's answer and changes nothing.
    v1::JobStatus retry(uint64_t jobId, const std::string& requestId = "");
    // A paused job gets no new leases; its leases out may finish and merge.
    v1::JobStatus setPaused(uint64_t jobId, bool paused);
    v1::JobStatus setPriority(uint64_t jobId, int32_t priority);
    // Deletes the job's record, log, films and bundle and the blobs only it used. A running job
    // is cancelled first when `cancelRunning`, refused otherwise. A nonempty `requestId`
    // (DeleteJobRequest.request_id) is recorded with the deletion, as for retry().
    v1::DeleteJobResponse deleteJob(uint64_t jobId, bool cancelRunning,
                                    const std::string& requestId = "");
    v1::GetJobLogResponse jobLog(uint64_t jobId, uint64_t afterSequence);
    // A draining worker is given no new unit (it finishes those it holds). Throws UnknownWorker.
    v1::WorkerInfo setWorkerDraining(uint64_t workerId, bool draining);
    // The units workers hold right now, by worker id (the dashboard's "current unit").
    using HeldUnit = WorkerRegistry::HeldUnit;
    std::map<uint64_t, std::vector<HeldUnit>> heldUnits() const;
    // Seconds between a worker's heartbeats (told at registration).
    double heartbeatIntervalSeconds() const { return m_workers->heartbeatIntervalSeconds(); }
    // Silence after which a worker is listed SILENT (WorkerRegistry::silentAfterSeconds).
    double silentAfterSeconds() const { return m_workers->silentAfterSeconds(); }
    struct ImageSnapshot {
        FilmBlock film;
        v1::JobStatus status;
    };
    // The merged film: a finished job's final film, or (preview) whatever is merged so far.
    // The film is copied in bands of rows, each under the lock: a running job's preview may
    // hold a unit merged while it was copied in some rows and not in others.
    ImageSnapshot snapshot(uint64_t jobId, bool preview);
    std::string jobDirectory(uint64_t jobId) const;
    // Who a job's checkpoints belong to: the job's id and this state directory's key (a digest
    // of it), so that no checkpoint copied or restored into another job's directory, or into
    // another state directory, is taken for that job's.
    std::string checkpointOwner(uint64_t jobId) const;
    // The job's change signal (WatchJob waits on it); throws NotFound for an unknown job. It is
    // closed when the job is deleted or removed and when the coordinator begins to stop.
    std::shared_ptr<const ChangeSignal> changeSignal(uint64_t jobId);

    // Worker side.
    uint64_t registerWorker(const v1::RegisterRequest& request);
    // Leases the next unit, waiting until `until` for one. Throws UnknownWorker for an unknown
    // worker.
    v1::AcquireWorkResponse acquire(uint64_t workerId, std::chrono::steady_clock::time_point until);
    v1::HeartbeatResponse heartbeat(const v1::HeartbeatRequest& request);
    // `header` is the first chunk of the stream, `compressedFilm` all data concatenated.
    v1::ResultDisposition report(const v1::ResultChunk& header, const std::string& compressedFilm);
    // Removes the jobs that ended more than keepFinishedSeconds before `wallNow` (seconds since
    // the epoch), the blobs that no remaining job references and nobody stored or asked for
    // within that time, and the workers without a lease that have not called within it; and
    // the retries and deletes recorded more than kControlRequestKeepSeconds before (also with
    // keepFinishedSeconds 0). tick() calls it every minute; public for tests.
    void pruneFinishedJobs(double wallNow);

    // Coordinator memory a running job takes: its whole-image film plus per-unit bookkeeping.
    static uint64_t jobMemoryBytes(int width, int height, uint64_t unitCount,
                                   SmallerRadius smallerRadius = SmallerRadius::None);

    // Runs `look` on the scheduler under the lock: for tests and the simulation, which check
    // the lease tables after each step.
    void inspect(const std::function<void(const LeaseScheduler&)>& look) const {
        std::lock_guard lock(m_mutex);
        look(*m_scheduler);
    }

    // Hooks around each durable write that storage could refuse or a crash could follow: a
    // checkpoint file, a job's end, a failed attempt, a submitted job's record (and, `after`
    // only, its directory), a worker's registration. The simulation uses them to stand for a
    // full disk (`before` throws StorageError) and to copy the state directory as a crash at
    // that moment leaves it (`after`). Set them from the thread that drives the coordinator.
    struct DurableWriteHooks {
        std::function<void()> before, after;
    };
    void setDurableWriteHooks(DurableWriteHooks hooks) { m_durableWriteHooks = std::move(hooks); }

    // Upper bound on a unit result's compressed size (for refusing oversized streams early).
    uint64_t maxResultBytes(uint64_t jobId) const;

  private:
    struct Job {
        uint64_t id = 0;
        v1::JobDescription description;
        v1::JobState state = v1::JOB_STATE_RUNNING;
        std::string error;
        farm::JobGrid grid;
        int filterBorder = 0;
        std::unique_ptr<JobFilm> film;
        uint32_t restored = 0, mergedThisRun = 0, discarded = 0;
        bool completing = false;  // every unit merged, final checkpoint being written
        double createdAt = 0;
        double finishedAt = 0;               // wall clock when the job ended; 0 while running
        std::string submissionId;            // SubmitJobRequest.submission_id; may be empty
        std::optional<double> firstMergeAt;  // monotonic
        uint64_t samplesMergedThisRun = 0;
        uint64_t passDataBuilds = 0;  // see JobStatus.pass_data_builds
        uint64_t memoryBytes = 0;     // jobMemoryBytes() while running, 0 once ended
        uint64_t raysMergedThisRun = 0;
        EventLog events;
        bool deleted = false;  // removed by a client; no checkpoint may be written any more
        // Checkpoint writes failed in a row, and when the last checkpoint.failed line was
        // logged (monotonic): a disk that stays broken is said once a minute, not every retry.
        uint32_t checkpointFailures = 0;
        double checkpointFailureLoggedAt = 0;
        // Bumped on every change its status shows (changedLocked); WatchJob waits on it.
        std::shared_ptr<ChangeSignal> changes = std::make_shared<ChangeSignal>();
        // Workers whose results were merged without an audit's agreement, in this process:
        // should one be quarantined, the running job is rendered again, the done one suspect.
        std::set<uint64_t> unverifiedContributors;
        std::string suspect;  // JobStatus.suspect
        uint32_t unitsAudited = 0;
    };
    // A unit's result kept until another worker's render of the unit agrees with it.
    struct HeldResult {
        uint64_t workerId = 0;
        std::string digest;  // ResultChunk.compressed_sha256, checked against `compressed`
        uint64_t invalidSamples = 0;
        std::string compressed;
        bool builtPassData = false;
        uint64_t rays = 0;
        double renderSeconds = 0;
        uint64_t bytes = 0;  // the compressed film's size, for the log
    };
    enum class MergeOutcome { Discarded, Merged, Completed };
    // Restores the workers and jobs of the state directory (recovery.cpp).
    void resume();
    // Rebuilds one job from its stored row and checkpoint; throws Error on a damaged record.
    void resumeJob(Job& job, const JobRow& row);
    // Why the row no longer holds its job as submitted (its fixed fields differ from their
    // digest, JobStore::recordDigest), naming the job and `database`; empty when they agree or
    // the row has no digest.
    static std::string recordDamage(const JobRow& row, const std::string& database);
    // Copies `source`, the film of job `jobId`, into `target` (its shape) one band of rows
    // per lock hold; false when the job released that film meanwhile, NotFound when it was
    // deleted.
    bool copyFilmInBands(uint64_t jobId, const JobFilm* source, FilmBlock& target);
    void backgroundLoop();
    void expireLeases();
    // A gap in the background thread's ticks longer than stallSeconds: forgives it (tick()).
    void forgiveStall(double now);
    // Returns how many running jobs' checkpoints could not be written.
    int checkpointDirtyJobs();
    // Writes `copy` unless a newer checkpoint of the job exists already (`final`: the job's last,
    // after every unit merged). Logs a failure (rate-limited) and throws it.
    void writeJobCheckpoint(Job& job, const JobFilm::Copy& copy, bool final);
    // Called without m_mutex held once every unit is merged: writes the final checkpoint, then
    // ends the job DONE. When the write fails the job stays running with the error shown, and
    // the background thread (or stop()) tries again.
    void finishJob(Job& job);

    // A submission as its client names it: the owner and the submission id.
    using SubmissionKey = std::pair<std::string, std::string>;

    // The following require m_mutex.
    Job& jobLocked(uint64_t jobId);
    // The listed job the submission created, if any.
    const Job* submittedJobLocked(const SubmissionKey& submission) const;
    v1::JobStatus statusLocked(const Job& job) const;
    // Merges a unit's result into the job's film (the caller checked mayMerge). `verified`: an
    // audit's agreement stands behind it; otherwise its worker is a contributor to be undone
    // should it be quarantined.
    MergeOutcome mergeLocked(Job& job, uint32_t unitIndex, uint64_t leaseId, const FilmBlock& block,
                             const HeldResult& credit, bool verified);
    // Decides what to do with a result that may be merged: hold it for an audit (true), or
    // merge it (false) after comparing it with the results held for the unit, passing the
    // workers that agree and quarantining those that do not.
    bool holdOrJudgeLocked(Job& job, uint32_t unitIndex, uint64_t leaseId, HeldResult result);
    // Audits no live worker can do any more: a single held result is merged unaudited; results
    // that disagree wait, said once. Returns the jobs that completed.
    std::vector<Job*> settleStrandedAuditsLocked();
    // The worker renders wrong results: no more units, its held results dropped, the running
    // jobs it merged unverified results into rendered again, the done ones marked suspect.
    void quarantineLocked(uint64_t workerId, const std::string& reason);
    void restartJobLocked(Job& job, const std::string& reason);
    // Stores a failed attempt counted by the scheduler; fails the job of a poison unit.
    void recordFailureLocked(Job& job, const LeaseScheduler::Failure& failure,
                             const std::string& message, uint64_t workerId);
    void endJobLocked(Job& job, v1::JobState state, const std::string& error);
    // Something the job's status shows changed: bumps its change signal. Every event is such a
    // change, so eventLocked() calls it; the other changes (a discarded result, a failed
    // checkpoint, a re-adopted lease) call it themselves.
    void changedLocked(Job& job);
    // Appends to the job's event log (at the clock's wall time) and signals the change.
    void eventLocked(Job& job, v1::JobEventKind kind, std::string message, uint64_t workerId = 0,
                     std::optional<uint32_t> unitIndex = std::nullopt);
    // Stores the event logs that changed (every job, or one); a failure is logged, not thrown:
    // a log is worth less than the work it records. Under m_mutex, for a job's end.
    void saveEventLogsLocked(std::optional<uint64_t> jobId = std::nullopt);
    // The same, writing without m_mutex (submissions, controls, checkpoint rounds, stop()).
    void saveChangedEventLogs(std::optional<uint64_t> jobId = std::nullopt);
    // The job, refusing with FailedPrecondition unless it is running (for pause and priority).
    Job& runningJobLocked(uint64_t jobId, const char* action, const char* done);

    // Under m_controlMutex (not m_mutex): the recorded request with this id when it is a
    // `action` ("retry", "delete") of job `jobId`; nullopt for an empty id or one not recorded;
    // throws InvalidArgument for an id recorded for another action or job.
    std::optional<ControlRequestRow> earlierControlRequest(const char* action, uint64_t jobId,
                                                           const std::string& requestId);
    // Records the first answer of a request recorded with its change; a failure is logged, not
    // thrown (the change is made: a repeated request then gets an answer made anew).
    void recordControlAnswer(const std::string& requestId, const std::string& answer);

    CoordinatorOptions m_options;
    std::shared_ptr<const Clock> m_clock;
    farm::DirectoryLock m_lock;
    JobStore m_store;
    BlobStore m_blobs;
    int m_jobsUnsavedAtStop = 0;
    uint64_t m_unitsUnsavedAtStop = 0;
    std::string m_stateIdentity;  // a digest of the store's key, for checkpointOwner()
    mutable std::mutex m_mutex;
    // Taken before m_mutex by the job controls (pause, priority, retry, delete), which write the
    // store or files without m_mutex, and by pruneFinishedJobs(), which must not free a job a
    // control holds.
    std::mutex m_controlMutex;
    std::condition_variable m_workAvailable;
    std::unique_ptr<LeaseScheduler> m_scheduler;
    std::map<uint64_t, std::unique_ptr<Job>> m_jobs;
    // Jobs deleted by a client, freed by the next tick(): the background thread may still hold
    // a pointer to one from the tick in progress (checkpointDirtyJobs).
    std::vector<std::unique_ptr<Job>> m_deletedJobs;
    std::unique_ptr<WorkerRegistry> m_workers;  // made after m_scheduler, which it informs
    std::unordered_map<std::string, double> m_blobsTouchedAt;  // sha256 -> wall clock
    // Results held for audits, by (job, unit); the scheduler knows which units wait.
    std::map<std::pair<uint64_t, uint32_t>, std::vector<HeldResult>> m_heldResults;
    // Audits whose results disagree and that no live worker can decide, said once each.
    std::set<std::pair<uint64_t, uint32_t>> m_undecidedAudits;
    double m_lastTick = 0;       // monotonic, for forgiveStall
    uint64_t m_memoryInUse = 0;  // sum of running jobs' memoryBytes
    // Submissions with an id being admitted right now (loading their scene), with how many
    // later calls with the same id wait for that admission: a second call must not admit the
    // job again, and a first call whose caller is gone still creates the job for a waiting one.
    struct SubmissionInProgress {
        int waitingCalls = 0;
    };
    std::map<SubmissionKey, std::shared_ptr<SubmissionInProgress>> m_submissionsInProgress;
    std::condition_variable m_submissionAdmitted;  // an entry left m_submissionsInProgress
    double m_nextCheckpoint = 0, m_nextPrune = 0;  // monotonic
    bool m_stopping = false, m_stopped = false;
    std::thread m_background;
    std::condition_variable m_backgroundWake;
    DurableWriteHooks m_durableWriteHooks;
};

}  // namespace alphorn::coordinator
