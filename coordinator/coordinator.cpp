// Coordinator: construction and the background work, and the calls by which a job is submitted,
// reported on, leased, merged and checkpointed. Taking up the state directory at start is in
// recovery.cpp; the controls of jobs and workers, and retention, in job_control.cpp.
#include "coordinator/coordinator.h"

#include "common/core/system_memory.h"
#include "common/farm/build_identity.h"
#include "common/farm/convert.h"
#include "common/farm/engine_fingerprint.h"
#include "common/farm/film_codec.h"
#include "common/farm/sha256.h"
#include "common/farm/text_field.h"
#include "common/photon/radius_schedule.h"
#include "common/scene/accel.h"
#include "coordinator/admission.h"
#include "coordinator/log.h"
#include "coordinator/services.h"

#include <absl/strings/str_replace.h>
#include <openssl/rand.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;
using Kind = FarmError::Kind;

namespace {

// While a job's checkpoints keep failing with the same error, checkpoint.failed is logged this
// often (and on the first failure and every new error).
constexpr double kCheckpointFailureLogSeconds = 60.0;

uint64_t randomLeaseBase() {
    // Lease ids start at a random point so that ids from a previous coordinator process never
    // match a lease of this one.
    uint64_t base = 0;
    RAND_bytes(reinterpret_cast<unsigned char*>(&base), sizeof base);
    return (base >> 2) + 1;
}

// The database's path, after checking that it was not lost: an empty or missing database next
// to job directories would start with no jobs and hand out their ids again, deleting films.
std::string checkedDatabasePath(const std::string& stateDirectory) {
    const fs::path database = fs::path(stateDirectory) / "state.sqlite";
    std::error_code error;
    const uint64_t size = fs::exists(database) ? fs::file_size(database, error) : 0;
    if (size == 0 && !error && fs::is_directory(fs::path(stateDirectory) / "jobs")) {
        const auto jobs = std::distance(fs::directory_iterator(fs::path(stateDirectory) / "jobs"),
                                        fs::directory_iterator());
        if (jobs > 0)
            fail(
                "%s is %s but %s/jobs holds %u job directories: the database was lost or "
                "truncated. Restore it from a backup, or move the state directory away to start "
                "afresh",
                database.string(), fs::exists(database) ? "empty" : "missing", stateDirectory,
                jobs);
    }
    return database.string();
}

constexpr double kPruneIntervalSeconds = 60;
// A round of checkpoints may take at most this share of the coordinator's time: a large film (a
// photon-mapped 960x540 job keeps 133 MB of sums) stretches the interval instead of keeping a
// core busy copying and compressing it (on a one-machine cluster, the workers' core).
constexpr double kCheckpointTimeShare = 0.05;

}  // namespace

uint64_t Coordinator::jobMemoryBytes(int width, int height, uint64_t unitCount,
                                     SmallerRadius smallerRadius) {
    return JobFilm::memoryBytes(width, height, unitCount, smallerRadius) +
           unitCount * LeaseScheduler::kBytesPerUnit;
}

Coordinator::Coordinator(CoordinatorOptions options, std::shared_ptr<const Clock> clock)
    : m_options(std::move(options)),
      m_clock(std::move(clock)),
      m_lock(m_options.stateDirectory, {"state directory", "coordinator", "--state-dir"}),
      m_store(checkedDatabasePath(m_options.stateDirectory)),
      m_blobs(m_options.stateDirectory + "/blobs", m_options.maxBlobBytes) {
    if (m_options.maxMemoryBytes == 0) m_options.maxMemoryBytes = physicalMemoryBytes() / 2;
    fs::create_directories(fs::path(m_options.stateDirectory) / "jobs");
    fs::create_directories(fs::path(m_options.stateDirectory) / "tmp");
    for (const auto& entry : fs::directory_iterator(fs::path(m_options.stateDirectory) / "tmp"))
        fs::remove_all(entry.path());
    // Lease tokens are signed with a key kept in the store and name this process's epoch, so a
    // later process can tell which leases it may re-adopt (those of earlier processes).
    const uint64_t epoch = m_store.beginEpoch();
    m_scheduler = std::make_unique<LeaseScheduler>(
        *m_clock,
        SchedulerOptions{m_options.leaseSeconds, m_options.maxAttempts, m_options.auditFraction},
        LeaseTokens(m_store.leaseKey(), epoch), randomLeaseBase());
    m_stateIdentity = farm::sha256Hex("checkpoint owner:" + m_store.leaseKey()).substr(0, 16);
    m_workers = std::make_unique<WorkerRegistry>(*m_clock, *m_scheduler, m_options.leaseSeconds);
    m_nextCheckpoint = m_clock->monotonicSeconds() + m_options.checkpointIntervalSeconds;
    m_nextPrune = m_clock->monotonicSeconds() + 1;
    m_lastTick = m_clock->monotonicSeconds();
    resume();
}

Coordinator::~Coordinator() {
    stop();
}

std::string Coordinator::jobDirectory(uint64_t jobId) const {
    return (fs::path(m_options.stateDirectory) / "jobs" / std::to_string(jobId)).string();
}

std::string Coordinator::checkpointOwner(uint64_t jobId) const {
    return absl::StrFormat("job %u of state %s", jobId, m_stateIdentity);
}

void Coordinator::start() {
    m_background = std::thread([this] { backgroundLoop(); });
}

void Coordinator::beginStop() {
    {
        std::lock_guard lock(m_mutex);
        m_stopping = true;
        // Watching clients are told to go (and come back to the next process) at once.
        for (auto& [id, job] : m_jobs) job->changes->close();
    }
    m_workAvailable.notify_all();  // long-polling AcquireWork calls return at once
}

void Coordinator::stop() {
    {
        std::lock_guard lock(m_mutex);
        if (m_stopped) return;
        m_stopped = true;
        m_stopping = true;
        for (auto& [id, job] : m_jobs) job->changes->close();
    }
    m_backgroundWake.notify_all();
    m_workAvailable.notify_all();
    if (m_background.joinable()) m_background.join();
    m_jobsUnsavedAtStop = checkpointDirtyJobs();
    saveChangedEventLogs();
    if (m_jobsUnsavedAtStop == 0) {
        logInfo("coordinator.stopped");
        return;
    }
    std::lock_guard lock(m_mutex);
    for (auto& [id, job] : m_jobs) {
        if (job->state != v1::JOB_STATE_RUNNING || !job->film->dirty()) continue;
        m_unitsUnsavedAtStop += job->film->unsavedCount();
        logError("checkpoint.lost",
                 {field("job", id), field("units_unsaved", job->film->unsavedCount()),
                  field("units_saved", job->film->mergedCount() - job->film->unsavedCount()),
                  field("error", job->film->checkpointError())});
    }
    logError("coordinator.stopped", {field("jobs_unsaved", m_jobsUnsavedAtStop),
                                     field("units_unsaved", m_unitsUnsavedAtStop),
                                     field("consequence",
                                           "their units merged since the last checkpoint are "
                                           "rendered again after a restart")});
}

void Coordinator::backgroundLoop() {
    std::unique_lock lock(m_mutex);
    while (!m_stopping) {
        m_backgroundWake.wait_for(lock, std::chrono::milliseconds(200));
        if (m_stopping) break;
        lock.unlock();
        tick();
        lock.lock();
    }
}

void Coordinator::tick() {
    {
        std::vector<std::unique_ptr<Job>> deleted;
        {
            std::lock_guard lock(m_mutex);
            deleted.swap(m_deletedJobs);
        }
    }
    forgiveStall(m_clock->monotonicSeconds());
    try {
        expireLeases();
    } catch (const std::exception& e) {
        logWarning("leases.expiry_failed", {field("error", e.what())});
    }
    if (m_clock->monotonicSeconds() >= m_nextPrune) {
        try {
            pruneFinishedJobs(m_clock->wallSeconds());
        } catch (const std::exception& e) {
            logWarning("prune.failed", {field("error", e.what())});
        }
        m_nextPrune = m_clock->monotonicSeconds() + kPruneIntervalSeconds;
    }
    if (const double start = m_clock->monotonicSeconds(); start >= m_nextCheckpoint) {
        checkpointDirtyJobs();
        // The event logs are stored with each round of checkpoints: a crash loses at most the
        // events since, as it loses the merges since.
        saveChangedEventLogs();
        const double end = m_clock->monotonicSeconds();
        m_nextCheckpoint = end + std::max(m_options.checkpointIntervalSeconds,
                                          (end - start) / kCheckpointTimeShare);
    }
    // The next stall is measured from here: a long checkpoint round is work, not a stall.
    std::lock_guard lock(m_mutex);
    m_lastTick = m_clock->monotonicSeconds();
}

void Coordinator::forgiveStall(double now) {
    std::lock_guard lock(m_mutex);
    // m_lastTick is the end of the previous tick (tick()).
    const double gap = now - m_lastTick;
    if (!(gap > m_options.stallSeconds)) return;
    // The background thread ticks every 200 ms; a gap this long means the whole process stood
    // still, heartbeats unread: the workers did nothing wrong, so nobody's lease is charged.
    m_scheduler->forgiveStall(gap);
    logWarning("coordinator.stalled",
               {field("seconds", absl::StrFormat("%.1f", gap)),
                field("action", "lease deadlines and worker silences moved later by as much")});
}

void Coordinator::touchBlobs(const std::vector<std::string>& sha256s) {
    const double now = m_clock->wallSeconds();
    std::lock_guard lock(m_mutex);
    for (const std::string& sha : sha256s) m_blobsTouchedAt[sha] = now;
}

// ---- jobs ------------------------------------------------------------------------------------

v1::JobStatus Coordinator::submit(const v1::SubmitJobRequest& request,
                                  const std::function<bool()>& callerGone) {
    checkSubmissionId(request.submission_id());
    const SubmissionKey submission{request.settings().owner(), request.submission_id()};
    if (!request.submission_id().empty()) {
        std::unique_lock lock(m_mutex);
        for (;;) {
            if (const Job* earlier = submittedJobLocked(submission)) {
                logInfo("job.submitted_again",
                        {field("job", earlier->id), field("submission", request.submission_id())});
                return statusLocked(*earlier);
            }
            auto [entry, first] = m_submissionsInProgress.try_emplace(submission);
            if (first) {
                entry->second = std::make_shared<SubmissionInProgress>();
                break;
            }
            // A client that gave up on a slow scene load asks again: it waits for the first
            // call (which creates the job for it) instead of loading the scene a second time.
            // The entry is held, not looked up again: it may be gone, and another in its place.
            const std::shared_ptr<SubmissionInProgress> inProgress = entry->second;
            ++inProgress->waitingCalls;
            m_submissionAdmitted.wait_for(lock, std::chrono::milliseconds(50));
            --inProgress->waitingCalls;
            if (callerGone && callerGone())
                throw FarmError(Kind::CallerGone,
                                absl::StrFormat("the client went away while submission %s was "
                                                "being admitted by an earlier call",
                                                request.submission_id()));
        }
    }
    // Whatever the outcome, the submission is no longer in progress once this call returns:
    // by then its job is listed, or it was refused and may be sent again (by a call waiting).
    struct InProgress {
        Coordinator& coordinator;
        const SubmissionKey& submission;
        ~InProgress() {
            if (submission.second.empty()) return;
            std::lock_guard lock(coordinator.m_mutex);
            coordinator.m_submissionsInProgress.erase(submission);
            coordinator.m_submissionAdmitted.notify_all();
        }
    } inProgress{*this, submission};
    // Another call with this submission's id waits for its job.
    auto awaited = [&] {
        if (submission.second.empty()) return false;
        std::lock_guard lock(m_mutex);
        auto entry = m_submissionsInProgress.find(submission);
        return entry != m_submissionsInProgress.end() && entry->second->waitingCalls > 0;
    };

    // Loading the scene to check it allocates and frees much (meshes, textures), and the C
    // library keeps what was freed in its per-thread arenas: without giving it back, the
    // coordinator's resident memory grew with every submission (400 small jobs: 324 MB; 68 MB
    // once given back). Given back when this call ends, whatever its outcome, outside the lock.
    struct FreedMemoryGivenBack {
        ~FreedMemoryGivenBack() { returnFreeMemoryToSystem(); }
    } freedMemoryGivenBack;
    const AdmissionLimits limits{
        m_options.maxBundleBytes,  m_options.maxImagePixels,       m_options.maxPasses,
        m_options.defaultTileSize, m_options.defaultPassesPerUnit, m_options.maxMemoryBytes};
    AdmittedJob admitted =
        admitJob(request, m_blobs, limits, (fs::path(m_options.stateDirectory) / "tmp").string());
    const std::string& staging = admitted.stagingDirectory;
    const farm::JobGrid& grid = admitted.grid;
    auto refuse = [&](Kind kind, const std::string& message) {
        // On a failing disk the removal may fail too; the next start empties the staging area.
        std::error_code ignored;
        fs::remove_all(staging, ignored);
        throw FarmError(kind, message);
    };
    // Loading a large scene can outlast the client's deadline. A job created for a caller that
    // is gone would run with nobody told its id, while the caller reports a failure and is
    // likely to submit again; a client that is still there asks again with the same submission
    // id and gets the job created then, or, asking while this call loads, the job this call
    // creates for it.
    if (callerGone && callerGone() && !awaited())
        refuse(Kind::CallerGone,
               "the client went away (deadline passed or connection lost) while the scene "
               "loaded; no job was created");
    const uint64_t memory =
        jobMemoryBytes(grid.width(), grid.height(), grid.unitCount(), grid.tiles().smallerRadius());
    {
        std::lock_guard lock(m_mutex);
        if (m_memoryInUse + memory > m_options.maxMemoryBytes)
            refuse(Kind::ResourceExhausted,
                   absl::StrFormat(
                       "the job needs about %s of coordinator memory (a %dx%d film and %u units; "
                       "larger tiles or more passes per unit need fewer units); running jobs "
                       "hold %s of the %s allowed (--max-memory)",
                       formatBytes(memory), grid.width(), grid.height(), grid.unitCount(),
                       formatBytes(m_memoryInUse), formatBytes(m_options.maxMemoryBytes)));
        // Reserved now, so concurrent submissions cannot overshoot together.
        m_memoryInUse += memory;
    }
    auto release = [&] {
        std::lock_guard lock(m_mutex);
        m_memoryInUse -= memory;
    };

    auto job = std::make_unique<Job>();
    job->description = std::move(admitted.description);
    job->createdAt = m_clock->wallSeconds();
    job->submissionId = request.submission_id();
    try {
        if (m_durableWriteHooks.before) m_durableWriteHooks.before();
        job->id = m_store.addJob(
            job->description, grid.width(), grid.height(), admitted.filterBorder, job->createdAt,
            admitted.smallerRadius == SmallerRadius::Kept, request.submission_id());
        if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    } catch (const Error& e) {
        release();
        refuse(Kind::ResourceExhausted, absl::StrFormat("cannot record the job: %s", e.what()));
    }
    job->description.set_job_id(job->id);
    try {
        // A directory for a new id means the store lost jobs: never delete their films.
        if (fs::exists(jobDirectory(job->id)))
            fail("%s exists already although the database had no job %u", jobDirectory(job->id),
                 job->id);
        fs::rename(staging, jobDirectory(job->id));
        if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    } catch (const std::exception& e) {
        release();
        try {
            m_store.removeJob(job->id);
        } catch (const Error&) {
            // The row stays: a restart resumes that job (its directory made anew).
        }
        refuse(Kind::ResourceExhausted, absl::StrFormat("cannot store the job: %s", e.what()));
    }
    job->memoryBytes = memory;
    job->grid = grid;
    job->filterBorder = admitted.filterBorder;
    job->film = std::make_unique<JobFilm>(
        grid, jobDirectory(job->id) + "/film.ckpt", checkpointOwner(job->id),
        targetError(job->description.settings()), job->description.settings().adaptive());
    job->film->startEmpty();

    std::unique_lock lock(m_mutex);
    const uint64_t id = job->id;
    const v1::JobSettings& settings = job->description.settings();
    m_scheduler->addJob(id, settings.priority(), grid, {}, {}, true, settings.engine_fingerprint());
    m_scheduler->setLeaseLimit(id, job->film->leaseLimit());
    eventLocked(*job, v1::JOB_EVENT_SUBMITTED,
                absl::StrFormat("\"%s\" by %s: %dx%d, %u passes, seed %u, %u units of %u "
                                "passes, tile %u, priority %d",
                                settings.name(), settings.owner().empty() ? "?" : settings.owner(),
                                grid.width(), grid.height(), settings.passes(), settings.seed(),
                                grid.unitCount(), settings.passes_per_unit(), settings.tile_size(),
                                settings.priority()));
    logInfo("job.submitted",
            {field("job", id), field("name", settings.name()),
             field("size", absl::StrFormat("%dx%d", grid.width(), grid.height())),
             field("passes", settings.passes()), field("units", grid.unitCount()),
             field("priority", settings.priority()), field("submission", job->submissionId)});
    // The submission consumes the touches of its blobs (the uses that led to it): a touch
    // from now on means another submission is under way (see Retention::deletedJobBlobs).
    for (const v1::BundleFile& file : job->description.bundle().files())
        m_blobsTouchedAt.erase(file.sha256());
    m_jobs[id] = std::move(job);
    m_workAvailable.notify_all();
    const v1::JobStatus status = statusLocked(*m_jobs[id]);
    lock.unlock();
    saveChangedEventLogs(id);
    return status;
}

const Coordinator::Job* Coordinator::submittedJobLocked(const SubmissionKey& submission) const {
    // A scan, not an index: it runs once per submission, and the jobs listed are those of the
    // keep time, which another index would have to follow through deletes and retention.
    for (const auto& [id, job] : m_jobs)
        if (!job->submissionId.empty() && job->submissionId == submission.second &&
            job->description.settings().owner() == submission.first)
            return job.get();
    return nullptr;
}

Coordinator::Job& Coordinator::jobLocked(uint64_t jobId) {
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) throw FarmError(Kind::NotFound, absl::StrFormat("no job %u", jobId));
    return *it->second;
}

v1::JobStatus Coordinator::statusLocked(const Job& job) const {
    const JobFilm& film = *job.film;
    v1::JobStatus status;
    status.set_job_id(job.id);
    *status.mutable_settings() = job.description.settings();
    status.set_state(job.state);
    status.set_error(relativeToStateDirectory(job.error, m_options.stateDirectory));
    if (job.state == v1::JOB_STATE_RUNNING && !film.checkpointError().empty())
        status.set_error(absl::StrFormat(
            "cannot write the checkpoint (%s); retrying every %.3g s",
            relativeToStateDirectory(film.checkpointError(), m_options.stateDirectory),
            m_options.checkpointIntervalSeconds));
    status.set_width(job.grid.width());
    status.set_height(job.grid.height());
    status.set_units_total(job.grid.unitCount());
    status.set_units_done(film.mergedCount());
    const LeaseScheduler::JobLeases leases = m_scheduler->jobLeases(job.id);
    status.set_units_leased(leases.leased);
    status.set_active_workers(leases.activeWorkers);
    const uint32_t passesDone = film.passesComplete();
    status.set_passes_done(passesDone);
    const v1::PhotonRadiusSchedule& schedule = job.description.photon_radius_schedule();
    if (job.description.has_photon_radius_schedule() && isValidRadiusAlpha(schedule.alpha())) {
        status.set_photon_radius(
            reportedProgressiveRadius(schedule.initial_radius(), schedule.alpha(), passesDone));
    }
    describeEstimate(film, status);
    status.set_units_restored(job.restored);
    status.set_units_merged_this_run(job.mergedThisRun);
    status.set_results_discarded(job.discarded);
    status.set_attempts_failed(leases.attemptsFailed);
    status.set_checkpoints_written(film.checkpointsWritten());
    status.set_units_leased_this_run(leases.leasedThisRun);
    status.set_pass_data_builds(job.passDataBuilds);
    status.set_invalid_samples(film.invalidSamples());
    status.set_elapsed_seconds(m_clock->wallSeconds() - job.createdAt);
    double rate = 0.0, rayRate = 0.0;
    if (job.firstMergeAt) {
        const double seconds = m_clock->monotonicSeconds() - *job.firstMergeAt;
        if (seconds > 0.05) {
            rate = job.samplesMergedThisRun / seconds;
            rayRate = job.raysMergedThisRun / seconds;
        }
    }
    status.set_samples_per_second(rate);
    status.set_rays_per_second(rayRate);
    status.set_paused(job.state == v1::JOB_STATE_RUNNING && m_scheduler->paused(job.id));
    status.set_suspect(job.suspect);
    status.set_units_audited(job.unitsAudited);
    uint32_t auditsWaiting = 0;
    for (auto held = m_heldResults.lower_bound({job.id, 0});
         held != m_heldResults.end() && held->first.first == job.id; ++held)
        ++auditsWaiting;
    status.set_audits_waiting(auditsWaiting);
    status.set_submitted_at_unix_seconds(job.createdAt);
    const uint64_t totalSamples =
        uint64_t(job.grid.width()) * job.grid.height() * film.expectedPasses();
    if (job.state != v1::JOB_STATE_RUNNING)
        status.set_eta_seconds(0.0);
    else
        status.set_eta_seconds(
            rate > 0 ? double(totalSamples - std::min(totalSamples, film.samplesMerged())) / rate
                     : -1.0);
    return status;
}

std::vector<v1::JobStatus> Coordinator::listJobs(uint64_t jobId) {
    std::lock_guard lock(m_mutex);
    std::vector<v1::JobStatus> result;
    if (jobId != 0) {
        result.push_back(statusLocked(jobLocked(jobId)));
        return result;
    }
    for (auto it = m_jobs.rbegin(); it != m_jobs.rend(); ++it)
        result.push_back(statusLocked(*it->second));
    return result;
}

void Coordinator::endJobLocked(Job& job, v1::JobState state, const std::string& error) {
    job.state = state;
    job.error = error;
    if (m_scheduler->running(job.id)) m_scheduler->endJob(job.id);
    job.finishedAt = m_clock->wallSeconds();
    m_memoryInUse -= job.memoryBytes;
    job.memoryBytes = 0;
    job.film->clearCheckpointError();
    if (state != v1::JOB_STATE_DONE) job.film->release();
    // Memory first, store last: if the write fails (a full disk) the job has ended in this
    // process, and a restart finds it as the store says (a finished film is finished again).
    if (state == v1::JOB_STATE_CANCELLED)
        eventLocked(job, v1::JOB_EVENT_CANCELLED, error);
    else
        eventLocked(job, v1::JOB_EVENT_FINISHED,
                    std::string(farm::jobStateName(state)) + (error.empty() ? "" : ": " + error));
    if (m_durableWriteHooks.before) m_durableWriteHooks.before();
    m_store.setJobState(job.id, state, error, job.finishedAt);
    if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    saveEventLogsLocked(job.id);
    (state == v1::JOB_STATE_DONE ? logInfo : logWarning)(
        "job.ended",
        {field("job", job.id), field("state", farm::jobStateName(state)), field("error", error),
         field("units_merged_this_run", job.mergedThisRun), field("units_restored", job.restored),
         field("results_discarded", job.discarded)});
}

void Coordinator::changedLocked(Job& job) {
    job.changes->notify(job.state != v1::JOB_STATE_RUNNING);
}

void Coordinator::eventLocked(Job& job, v1::JobEventKind kind, std::string message,
                              uint64_t workerId, std::optional<uint32_t> unitIndex) {
    // The log is read by clients: it names files in the state directory relative to it.
    message = relativeToStateDirectory(message, m_options.stateDirectory);
    job.events.add(m_clock->wallSeconds(), kind, std::move(message), workerId, unitIndex);
    changedLocked(job);
}

std::shared_ptr<const ChangeSignal> Coordinator::changeSignal(uint64_t jobId) {
    std::lock_guard lock(m_mutex);
    Job& job = jobLocked(jobId);
    if (m_stopping) job.changes->close();
    return job.changes;
}

void Coordinator::saveEventLogsLocked(std::optional<uint64_t> jobId) {
    for (auto& [id, job] : m_jobs) {
        if ((jobId && id != *jobId) || !job->events.changed()) continue;
        try {
            m_store.saveJobLog(id, job->events.record());
            job->events.markSaved();
        } catch (const StorageError& e) {
            logWarning("job.log_not_saved", {field("job", id), field("error", e.what())});
        }
    }
}

void Coordinator::saveChangedEventLogs(std::optional<uint64_t> jobId) {
    // Copied under the lock, written without it: each save waits for the disk.
    std::vector<std::pair<uint64_t, v1::JobEventLog>> changed;
    {
        std::lock_guard lock(m_mutex);
        for (auto& [id, job] : m_jobs) {
            if ((jobId && id != *jobId) || !job->events.changed()) continue;
            changed.emplace_back(id, job->events.record());
            job->events.markSaved();
        }
    }
    for (const auto& [id, log] : changed) {
        try {
            m_store.saveJobLog(id, log);
        } catch (const StorageError& e) {
            logWarning("job.log_not_saved", {field("job", id), field("error", e.what())});
            std::lock_guard lock(m_mutex);
            if (auto it = m_jobs.find(id); it != m_jobs.end()) it->second->events.markChanged();
        }
    }
}

Coordinator::ImageSnapshot Coordinator::snapshot(uint64_t jobId, bool preview) {
    ImageSnapshot snap;
    farm::JobGrid grid;
    const JobFilm* source = nullptr;
    int x0 = 0, y0 = 0, width = 0, height = 0;
    PassHalves halves = PassHalves::Kept;
    SmallerRadius smallerRadius = SmallerRadius::None;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        snap.status = statusLocked(job);
        if (job.state == v1::JOB_STATE_RUNNING && !preview)
            throw FarmError(
                Kind::FailedPrecondition,
                absl::StrFormat("job %u is still running (%u of %u units); ask for a preview",
                                jobId, job.film->mergedCount(), job.grid.unitCount()));
        if (job.state == v1::JOB_STATE_FAILED || job.state == v1::JOB_STATE_CANCELLED)
            throw FarmError(Kind::FailedPrecondition,
                            absl::StrFormat("job %u has no image: %s", jobId, job.error));
        grid = job.grid;
        if (job.film->inMemory()) {
            const FilmBlock& film = job.film->film();
            source = job.film.get();
            x0 = film.x0(), y0 = film.y0(), width = film.width(), height = film.height();
            halves = film.keepsHalves() ? PassHalves::Kept : PassHalves::None;
            smallerRadius = film.keepsSmallerRadius() ? SmallerRadius::Kept : SmallerRadius::None;
        }
    }
    if (source) {
        // Allocated without the lock, filled band by band under it (copyFilmInBands).
        snap.film = FilmBlock(x0, y0, width, height, halves, smallerRadius);
        if (copyFilmInBands(jobId, source, snap.film)) return snap;
    }
    // A finished job whose film was released from memory: read its final checkpoint.
    snap.film = std::move(
        JobFilm(grid, jobDirectory(jobId) + "/film.ckpt", checkpointOwner(jobId)).readFile().film);
    return snap;
}

bool Coordinator::copyFilmInBands(uint64_t jobId, const JobFilm* source, FilmBlock& target) {
    // About 1 MiB per band: a fraction of a millisecond under the lock, where a 1920x1080 film
    // (265 MB with its odd half) copied at once held every lease and result behind it.
    constexpr size_t kBandBytes = size_t(1) << 20;
    const int rowsPerBand = static_cast<int>(
        std::max<size_t>(1, kBandBytes / (size_t(target.width()) * target.bytesPerPixel())));
    const int yEnd = target.y0() + target.height();
    for (int y = target.y0(); y < yEnd; y += rowsPerBand) {
        std::lock_guard lock(m_mutex);
        // The job may have been deleted, or ended and released its film, between two bands.
        const Job& job = jobLocked(jobId);
        if (job.film.get() != source || !source->inMemory()) return false;
        const FilmBlock& film = source->film();
        target.copyRows(film, y, std::min(y + rowsPerBand, yEnd));
        target.invalidSamples = film.invalidSamples;
    }
    return true;
}

// ---- workers -----------------------------------------------------------------------------------

uint64_t Coordinator::registerWorker(const v1::RegisterRequest& request) {
    // Units and results are exchangeable only between builds of one version: a change to the
    // renderer changes a unit's sums, and a job whose units came from two builds would have the
    // image of neither (the same-bytes promise). A worker that states no version is refused too.
    const std::string theirs = request.version();
    if (theirs != ALPHORN_VERSION)
        throw FarmError(
            Kind::FailedPrecondition,
            theirs.empty()
                ? std::string("a worker must state its Alphorn version to join (this "
                              "coordinator is ") +
                      ALPHORN_VERSION + ")"
                : absl::StrFormat("worker version %s cannot join a %s coordinator: every worker "
                                  "of a farm runs the coordinator's version, so that a job's "
                                  "image does not depend on which workers rendered it",
                                  theirs, ALPHORN_VERSION));
    try {
        farm::checkTextField("the worker's name", request.name());
        farm::checkEngineFingerprint(request.engine_fingerprint(), false);
        farm::checkTextField("the worker's host id", request.host_id(), 64);
    } catch (const Error& e) {
        throw FarmError(Kind::InvalidArgument, e.what());
    }
    // The same holds for one build on two kinds of CPU: Embree's kernels for another instruction
    // set (or another architecture) round hits differently.
    const std::string platform = renderPlatform();
    if (request.platform() != platform)
        throw FarmError(
            Kind::FailedPrecondition,
            request.platform().empty()
                ? absl::StrFormat("a worker must state its platform to join (this coordinator "
                                  "runs on %s)",
                                  platform)
                : absl::StrFormat("a worker on %s cannot join a coordinator on %s: its ray "
                                  "tracing kernels round hits differently, so a job's image "
                                  "would depend on which workers rendered it; run workers on "
                                  "CPUs of the coordinator's platform",
                                  request.platform(), platform));
    WorkerRow row;
    row.name = request.name();
    row.cores = request.cores();
    row.memoryBytes = request.memory_bytes();
    row.version = request.version();
    row.engineFingerprint = request.engine_fingerprint();
    if (m_durableWriteHooks.before) m_durableWriteHooks.before();
    const uint64_t id = m_store.addWorker(row, m_clock->wallSeconds());
    if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    std::lock_guard lock(m_mutex);
    m_workers->add(id, request);
    logInfo("worker.registered",
            {field("worker", id), field("name", request.name()), field("cores", request.cores()),
             field("version", request.version()), field("platform", request.platform()),
             field("engine_fingerprint", request.engine_fingerprint())});
    return id;
}

std::vector<v1::WorkerInfo> Coordinator::listWorkers(bool includeDead) {
    std::lock_guard lock(m_mutex);
    return m_workers->list(includeDead);
}

std::map<uint64_t, std::vector<Coordinator::HeldUnit>> Coordinator::heldUnits() const {
    std::lock_guard lock(m_mutex);
    return m_workers->heldUnits();
}

v1::AcquireWorkResponse Coordinator::acquire(uint64_t workerId,
                                             std::chrono::steady_clock::time_point until) {
    std::unique_lock lock(m_mutex);
    v1::AcquireWorkResponse response;
    for (;;) {
        const WorkerRegistry::Worker* worker = m_workers->touch(workerId);
        if (!worker)
            throw FarmError(Kind::UnknownWorker,
                            absl::StrFormat("unknown worker %u: register again", workerId));
        if (m_stopping) return response;
        // A drained worker waits out the long poll (undrain wakes it) rather than spinning.
        response.set_draining(worker->draining);
        const bool mayLease = !worker->draining && !worker->exiting;
        if (const auto lease = mayLease ? m_scheduler->lease(workerId) : std::nullopt) {
            Job& job = *m_jobs.at(lease->jobId);
            eventLocked(job, v1::JOB_EVENT_LEASED, absl::StrFormat("lease %u", lease->leaseId),
                        workerId, lease->unitIndex);
            response.set_has_work(true);
            response.set_lease_id(lease->leaseId);
            *response.mutable_unit() =
                farm::toProto(job.id, lease->unitIndex, job.grid.unit(lease->unitIndex));
            response.mutable_unit()->set_smaller_radius(job.grid.tiles().smallerRadius() ==
                                                        SmallerRadius::Kept);
            *response.mutable_job() = job.description;
            response.set_lease_seconds(m_options.leaseSeconds);
            response.set_lease_token(lease->token);
            return response;
        }
        // The wait is real time even with another clock: it only bounds a long poll.
        if (m_workAvailable.wait_until(lock, until) == std::cv_status::timeout) {
            m_workers->touch(workerId);
            if (mayLease) response.set_idle_reason(m_scheduler->idleReason(workerId));
            return response;
        }
    }
}

v1::HeartbeatResponse Coordinator::heartbeat(const v1::HeartbeatRequest& request) {
    std::lock_guard lock(m_mutex);
    v1::HeartbeatResponse response;
    if (!m_workers->heartbeat(request)) {
        response.set_unknown_worker(true);
        for (uint64_t lease : request.lease_ids()) response.add_drop_lease_ids(lease);
        return response;
    }
    for (int i = 0; i < request.lease_ids_size(); ++i) {
        const uint64_t leaseId = request.lease_ids(i);
        std::optional<LeaseScheduler::HeldUnit> held;
        if (i < request.held_units_size())
            held = LeaseScheduler::HeldUnit{request.held_units(i).job_id(),
                                            request.held_units(i).unit_index(),
                                            request.held_units(i).lease_token()};
        const uint32_t leasedBefore = m_scheduler->leaseCount(request.worker_id());
        // Fencing: the lease expired (and the unit may be someone else's now), or the unit is
        // merged or its job ended. The worker stops rendering it.
        if (!m_scheduler->renew(request.worker_id(), leaseId, held ? &*held : nullptr)) {
            response.add_drop_lease_ids(leaseId);
        } else if (m_scheduler->leaseCount(request.worker_id()) > leasedBefore) {
            if (auto job = m_jobs.find(held->jobId); job != m_jobs.end())
                changedLocked(*job->second);
            logInfo("unit.readopted",
                    {field("job", held->jobId), field("unit", held->unitIndex),
                     field("worker", request.worker_id()), field("lease", leaseId)});
        }
    }
    return response;
}

void Coordinator::recordFailureLocked(Job& job, const LeaseScheduler::Failure& failure,
                                      const std::string& message, uint64_t workerId) {
    if (failure.audit) {
        // The unit's result is held; only the second opinion failed, on a host not asked again.
        logWarning("audit.failed", {field("job", job.id), field("unit", failure.unitIndex),
                                    field("worker", workerId), field("error", message)});
        eventLocked(job, v1::JOB_EVENT_FAILED,
                    absl::StrFormat("rendering it again for an audit failed (not counted as an "
                                    "attempt; another host audits it): %s",
                                    message),
                    workerId, failure.unitIndex);
        m_workAvailable.notify_all();
        return;
    }
    try {
        if (m_durableWriteHooks.before) m_durableWriteHooks.before();
        m_store.setUnitAttempts(job.id, failure.unitIndex, failure.attempts, message);
        if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    } catch (const StorageError& e) {
        // The unit goes back in the queue all the same; only the count may restart from less.
        logWarning(
            "unit.attempt_not_recorded",
            {field("job", job.id), field("unit", failure.unitIndex), field("error", e.what())});
    }
    logWarning("unit.failed", {field("job", job.id), field("unit", failure.unitIndex),
                               field("attempt", failure.attempts), field("error", message)});
    eventLocked(job, v1::JOB_EVENT_FAILED,
                absl::StrFormat("attempt %u: %s", failure.attempts, message), workerId,
                failure.unitIndex);
    if (failure.poisoned) {
        eventLocked(job, v1::JOB_EVENT_POISONED,
                    absl::StrFormat("unit %u failed %u times (the limit)", failure.unitIndex,
                                    failure.attempts),
                    workerId, failure.unitIndex);
        // A poison unit: it fails its job, never the farm.
        try {
            endJobLocked(job, v1::JOB_STATE_FAILED,
                         absl::StrFormat("unit %u failed %u times (the limit); last error: %s",
                                         failure.unitIndex, failure.attempts, message));
        } catch (const StorageError& e) {
            logWarning("job.end_not_recorded", {field("job", job.id), field("error", e.what())});
        }
        return;
    }
    m_workAvailable.notify_all();
}

void Coordinator::expireLeases() {
    std::vector<Job*> completed;
    {
        std::lock_guard lock(m_mutex);
        for (const auto& [expired, failure] : m_scheduler->expireLeases()) {
            recordFailureLocked(
                *m_jobs.at(expired.jobId), failure,
                absl::StrFormat("lease expired: worker %u (%s) stopped responding while "
                                "rendering unit %u (crashed, hung or lost its network)",
                                expired.workerId, m_workers->name(expired.workerId),
                                expired.unitIndex),
                expired.workerId);
        }
        completed = settleStrandedAuditsLocked();
    }
    for (Job* job : completed) finishJob(*job);
}

uint64_t Coordinator::maxResultBytes(uint64_t jobId) const {
    std::lock_guard lock(m_mutex);
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) return 0;
    const Job& job = *it->second;
    // The largest unit block: a full tile plus the filter border on each side.
    const uint64_t side =
        uint64_t(job.description.settings().tile_size()) + 2 * uint64_t(job.filterBorder);
    return ZSTD_compressBound(side * side * FilmBlock(0, 0, 0, 0).bytesPerPixel()) + 4096;
}

v1::ResultDisposition Coordinator::report(const v1::ResultChunk& header,
                                          const std::string& compressedFilm) {
    const uint64_t jobId = header.job_id();
    const uint32_t unitIndex = header.unit_index();
    const uint64_t leaseId = header.lease_id();
    RenderUnit unit;
    int border = 0;
    SmallerRadius smallerRadius = SmallerRadius::None;
    {
        std::lock_guard lock(m_mutex);
        if (!m_workers->touch(header.worker_id()))
            throw FarmError(
                Kind::UnknownWorker,
                absl::StrFormat("unknown worker %u: register again", header.worker_id()));
        Job& job = jobLocked(jobId);
        if (unitIndex >= job.grid.unitCount())
            throw FarmError(Kind::InvalidArgument,
                            absl::StrFormat("job %u has no unit %u", jobId, unitIndex));
        if (!header.error().empty() || header.handed_back()) {
            // Failures and hand-backs only count from the current holder of the lease.
            if (header.handed_back()) {
                if (!m_scheduler->handBack(jobId, unitIndex, leaseId)) return v1::RESULT_DISCARDED;
                logInfo("unit.handed_back", {field("job", jobId), field("unit", unitIndex),
                                             field("worker", header.worker_id())});
                eventLocked(job, v1::JOB_EVENT_HANDED_BACK, "the worker is stopping",
                            header.worker_id(), unitIndex);
                m_workAvailable.notify_all();
            } else {
                const auto failure = m_scheduler->failAttempt(jobId, unitIndex, leaseId);
                if (!failure) return v1::RESULT_DISCARDED;
                recordFailureLocked(
                    job, *failure,
                    absl::StrFormat("worker %u: %s", header.worker_id(), header.error()),
                    header.worker_id());
            }
            return v1::RESULT_RECORDED;
        }
        // Fencing: a unit merged already, reassigned to another worker, or of an ended job is
        // dropped. Results are idempotent by unit id: a unit is merged at most once.
        if (!m_scheduler->mayMerge(jobId, unitIndex, leaseId)) {
            ++job.discarded;
            changedLocked(job);
            logInfo("result.discarded",
                    {field("job", jobId), field("unit", unitIndex),
                     field("worker", header.worker_id()), field("lease", leaseId)});
            return v1::RESULT_DISCARDED;
        }
        unit = job.grid.unit(unitIndex);
        border = job.filterBorder;
        smallerRadius = job.grid.tiles().smallerRadius();
    }

    // Check and decompress outside the lock: this is the expensive part.
    FilmBlock block = unitBlock(unit.tile, border, smallerRadius);
    if (header.block_x0() != block.x0() || header.block_y0() != block.y0() ||
        header.block_width() != block.width() || header.block_height() != block.height())
        throw FarmError(
            Kind::InvalidArgument,
            absl::StrFormat(
                "unit %u: the result block is %dx%d at (%d, %d), expected %dx%d at (%d, %d)",
                unitIndex, header.block_width(), header.block_height(), header.block_x0(),
                header.block_y0(), block.width(), block.height(), block.x0(), block.y0()));
    if (farm::sha256Hex(compressedFilm) != header.compressed_sha256())
        throw FarmError(Kind::InvalidArgument,
                        absl::StrFormat("unit %u: result checksum mismatch", unitIndex));
    try {
        farm::decompressFilm(compressedFilm, block);
    } catch (const Error& e) {
        throw FarmError(Kind::InvalidArgument, absl::StrFormat("unit %u: %s", unitIndex, e.what()));
    }
    block.invalidSamples = header.invalid_samples();

    Job* completed = nullptr;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        // Checked again: the job or the lease may have changed while decompressing.
        if (!m_scheduler->mayMerge(jobId, unitIndex, leaseId)) {
            ++job.discarded;
            changedLocked(job);
            return v1::RESULT_DISCARDED;
        }
        HeldResult result{header.worker_id(),       header.compressed_sha256(),
                          header.invalid_samples(), "",
                          header.built_pass_data(), header.rays(),
                          header.render_seconds(),  compressedFilm.size()};
        const bool audited = m_heldResults.count({jobId, unitIndex}) > 0;
        if (!audited && !m_scheduler->wantsAudit(jobId, unitIndex, result.workerId)) {
            switch (mergeLocked(job, unitIndex, leaseId, block, result, false)) {
                case MergeOutcome::Discarded:
                    ++job.discarded;
                    changedLocked(job);
                    return v1::RESULT_DISCARDED;
                case MergeOutcome::Completed:
                    completed = &job;
                    break;
                case MergeOutcome::Merged:
                    break;
            }
        } else {
            HeldResult held = result;
            held.compressed = compressedFilm;
            if (holdOrJudgeLocked(job, unitIndex, leaseId, std::move(held))) return v1::RESULT_HELD;
            // Agreed with a held result: the bytes are the same, this block is merged.
            if (mergeLocked(job, unitIndex, leaseId, block, result, true) ==
                MergeOutcome::Completed)
                completed = &job;
        }
    }
    if (completed) finishJob(*completed);
    return v1::RESULT_MERGED;
}

Coordinator::MergeOutcome Coordinator::mergeLocked(Job& job, uint32_t unitIndex, uint64_t leaseId,
                                                   const FilmBlock& block, const HeldResult& credit,
                                                   bool verified) {
    if (!m_scheduler->markMerged(job.id, unitIndex, leaseId)) return MergeOutcome::Discarded;
    const RenderUnit unit = job.grid.unit(unitIndex);
    const uint32_t leaseLimit = job.film->leaseLimit();
    job.film->merge(unitIndex, block);
    // An adaptive job's tiles that met the target: their later units are never leased.
    if (const std::vector<uint32_t> skipped = job.film->takeSkippedUnits(); !skipped.empty())
        m_scheduler->skipUnits(job.id, skipped);
    if (job.film->leaseLimit() != leaseLimit) {
        // A decision point passed: the units up to the next one may be leased now.
        m_scheduler->setLeaseLimit(job.id, job.film->leaseLimit());
        m_workAvailable.notify_all();
    }
    if (!verified) job.unverifiedContributors.insert(credit.workerId);
    ++job.mergedThisRun;
    if (!job.firstMergeAt) job.firstMergeAt = m_clock->monotonicSeconds();
    if (credit.builtPassData) job.passDataBuilds += unit.passEnd - unit.passBegin;
    const uint64_t samples =
        uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
    job.samplesMergedThisRun += samples;
    job.raysMergedThisRun += credit.rays;
    m_workers->recordMerge(credit.workerId, samples, credit.rays, credit.renderSeconds);
    eventLocked(job, v1::JOB_EVENT_MERGED, "", credit.workerId, unitIndex);
    // Logged here, under the lock, so that it comes before the job.ended it may lead to.
    logInfo("unit.merged", {field("job", job.id), field("unit", unitIndex),
                            field("worker", credit.workerId), field("bytes", credit.bytes)});
    if (!job.film->complete()) return MergeOutcome::Merged;
    job.completing = true;
    return MergeOutcome::Completed;
}

namespace {

std::string workerList(const std::vector<uint64_t>& workers) {
    std::string list;
    for (uint64_t worker : workers) list += (list.empty() ? "" : ", ") + std::to_string(worker);
    return list;
}

}  // namespace

bool Coordinator::holdOrJudgeLocked(Job& job, uint32_t unitIndex, uint64_t leaseId,
                                    HeldResult result) {
    const auto key = std::make_pair(job.id, unitIndex);
    std::vector<HeldResult>& held = m_heldResults[key];
    const uint64_t workerId = result.workerId;
    if (held.empty()) {
        m_scheduler->holdForAudit(job.id, unitIndex, leaseId, workerId);
        held.push_back(std::move(result));
        logInfo("unit.held_for_audit",
                {field("job", job.id), field("unit", unitIndex), field("worker", workerId)});
        changedLocked(job);
        m_workAvailable.notify_all();
        return true;
    }
    std::vector<uint64_t> agreeing{workerId}, disagreeing;
    for (const HeldResult& other : held) {
        if (other.workerId == workerId) return true;  // delivered again: held already
        const bool same =
            other.digest == result.digest && other.invalidSamples == result.invalidSamples;
        (same ? agreeing : disagreeing).push_back(other.workerId);
    }
    if (agreeing.size() == 1) {
        // Nobody agrees with it yet: a worker that rendered neither decides.
        m_scheduler->holdForAudit(job.id, unitIndex, leaseId, workerId);
        held.push_back(std::move(result));
        std::vector<uint64_t> renderers;
        for (const HeldResult& each : held) renderers.push_back(each.workerId);
        farm::CoordinatorMetrics::unitAudited(farm::CoordinatorMetrics::AuditOutcome::Disagreed);
        logWarning("audit.disagreed",
                   {field("job", job.id), field("unit", unitIndex),
                    field("workers", workerList(renderers)),
                    field("action", "another worker renders the unit to decide")});
        eventLocked(job, v1::JOB_EVENT_AUDITED,
                    absl::StrFormat("the results of workers %s differ; another worker decides",
                                    workerList(renderers)),
                    workerId, unitIndex);
        m_workAvailable.notify_all();
        return true;
    }
    m_heldResults.erase(key);
    m_undecidedAudits.erase(key);
    ++job.unitsAudited;
    farm::CoordinatorMetrics::unitAudited(farm::CoordinatorMetrics::AuditOutcome::Agreed);
    for (uint64_t worker : agreeing) m_scheduler->passProbation(worker, job.id);
    logInfo("audit.agreed",
            {field("job", job.id), field("unit", unitIndex), field("workers", workerList(agreeing)),
             field("disagreeing", workerList(disagreeing))});
    eventLocked(job, v1::JOB_EVENT_AUDITED,
                disagreeing.empty()
                    ? absl::StrFormat("workers %s rendered the same bytes", workerList(agreeing))
                    : absl::StrFormat("workers %s rendered the same bytes; worker %s did not",
                                      workerList(agreeing), workerList(disagreeing)),
                workerId, unitIndex);
    for (uint64_t worker : disagreeing)
        quarantineLocked(
            worker,
            absl::StrFormat("its render of unit %u of job %u differs from the same render by "
                            "workers %s, which agree",
                            unitIndex, job.id, workerList(agreeing)));
    return false;
}

std::vector<Coordinator::Job*> Coordinator::settleStrandedAuditsLocked() {
    std::vector<Job*> completed;
    for (const auto& [jobId, unitIndex] : m_scheduler->auditsWithoutAuditor()) {
        const auto key = std::make_pair(jobId, unitIndex);
        auto held = m_heldResults.find(key);
        auto job = m_jobs.find(jobId);
        if (held == m_heldResults.end() || job == m_jobs.end()) continue;
        if (held->second.size() > 1) {
            if (m_undecidedAudits.insert(key).second) {
                std::vector<uint64_t> renderers;
                for (const HeldResult& each : held->second) renderers.push_back(each.workerId);
                logWarning("audit.undecided", {field("job", jobId), field("unit", unitIndex),
                                               field("workers", workerList(renderers)),
                                               field("action",
                                                     "waiting for a worker of the job's build that "
                                                     "rendered neither")});
                eventLocked(*job->second, v1::JOB_EVENT_AUDITED,
                            absl::StrFormat("the results of workers %s differ and no other "
                                            "worker of the job's build is alive to decide; "
                                            "the unit waits for one",
                                            workerList(renderers)),
                            0, unitIndex);
            }
            continue;
        }
        // Nobody else can render it again (the other workers left): taken as delivered.
        HeldResult result = std::move(held->second.front());
        m_heldResults.erase(held);
        FilmBlock block =
            unitBlock(job->second->grid.unit(unitIndex).tile, job->second->filterBorder,
                      job->second->grid.tiles().smallerRadius());
        try {
            farm::decompressFilm(result.compressed, block);
        } catch (const Error& e) {
            continue;  // checked when it arrived; cannot happen
        }
        block.invalidSamples = result.invalidSamples;
        farm::CoordinatorMetrics::unitAudited(farm::CoordinatorMetrics::AuditOutcome::Unaudited);
        logInfo("audit.skipped",
                {field("job", jobId), field("unit", unitIndex), field("worker", result.workerId),
                 field("reason",
                       "no other worker of the job's build is alive "
                       "to render it again")});
        m_scheduler->passProbation(result.workerId, jobId);
        if (mergeLocked(*job->second, unitIndex, 0, block, result, false) ==
            MergeOutcome::Completed)
            completed.push_back(job->second.get());
        m_workAvailable.notify_all();
    }
    return completed;
}

void Coordinator::quarantineLocked(uint64_t workerId, const std::string& reason) {
    if (m_scheduler->quarantined(workerId)) return;
    try {
        m_store.setWorkerQuarantined(workerId, reason);
    } catch (const StorageError& e) {
        // Held in memory all the same; a restart forgets it until the next audit finds it.
        logWarning("worker.quarantine_not_recorded",
                   {field("worker", workerId), field("error", e.what())});
    }
    if (WorkerRegistry::Worker* worker = m_workers->find(workerId)) worker->quarantined = reason;
    m_scheduler->quarantineWorker(workerId);
    for (auto held = m_heldResults.begin(); held != m_heldResults.end();) {
        auto& results = held->second;
        results.erase(std::remove_if(results.begin(), results.end(),
                                     [&](const HeldResult& r) { return r.workerId == workerId; }),
                      results.end());
        held = results.empty() ? m_heldResults.erase(held) : std::next(held);
    }
    farm::CoordinatorMetrics::workerQuarantined();
    logError("worker.quarantined",
             {field("worker", workerId), field("name", m_workers->name(workerId)),
              field("reason", reason)});
    for (auto& [id, job] : m_jobs) {
        if (!job->unverifiedContributors.count(workerId)) continue;
        const std::string why =
            absl::StrFormat("worker %u (%s), which merged units into it, was quarantined: %s",
                            workerId, m_workers->name(workerId), reason);
        if (job->state == v1::JOB_STATE_RUNNING && !job->completing) {
            restartJobLocked(*job, why);
        } else if (job->state == v1::JOB_STATE_DONE || job->completing) {
            job->suspect = why;
            try {
                m_store.setJobSuspect(id, why);
            } catch (const StorageError& e) {
                logWarning("job.suspect_not_recorded",
                           {field("job", id), field("error", e.what())});
            }
            logError("job.suspect", {field("job", id), field("reason", why)});
            eventLocked(*job, v1::JOB_EVENT_SUSPECT, why, workerId);
        }
    }
    m_workAvailable.notify_all();
}

void Coordinator::restartJobLocked(Job& job, const std::string& reason) {
    // The film's sums cannot be taken apart by worker: everything is rendered again, which
    // gives the bytes of a fresh job (every unit is a pure function of the job).
    job.film->startEmpty();
    m_scheduler->restartJob(job.id);
    m_scheduler->setLeaseLimit(job.id, job.film->leaseLimit());
    for (auto held = m_heldResults.lower_bound({job.id, 0});
         held != m_heldResults.end() && held->first.first == job.id;)
        held = m_heldResults.erase(held);
    job.unverifiedContributors.clear();
    job.restored = job.mergedThisRun = 0;
    job.samplesMergedThisRun = job.raysMergedThisRun = 0;
    job.firstMergeAt.reset();
    // No restart may resume the old film: its checkpoint goes now (a write in progress notices
    // the film's new generation and removes what it wrote).
    std::error_code error;
    fs::remove(fs::path(jobDirectory(job.id)) / "film.ckpt", error);
    if (error)
        logError("checkpoint.not_removed", {field("job", job.id), field("error", error.message())});
    farm::CoordinatorMetrics::jobRestarted();
    logWarning("job.restarted", {field("job", job.id), field("reason", reason)});
    eventLocked(job, v1::JOB_EVENT_RESTARTED, reason + "; rendering it again from nothing");
}

void Coordinator::finishJob(Job& job) {
    JobFilm::Copy copy;
    {
        std::lock_guard lock(m_mutex);
        copy = job.film->copy();
    }
    // The final film is on disk before the job is reported done.
    bool written = false;
    try {
        writeJobCheckpoint(job, copy, true);
        written = true;
    } catch (const std::exception&) {
        // Logged by writeJobCheckpoint; the next checkpoint round tries again.
    }
    std::lock_guard lock(m_mutex);
    if (written && job.state == v1::JOB_STATE_RUNNING) {
        try {
            endJobLocked(job, v1::JOB_STATE_DONE, "");
        } catch (const std::exception& e) {
            logWarning("job.end_not_recorded", {field("job", job.id), field("error", e.what())});
        }
        job.film->release();  // served from the checkpoint from now on; memory stays flat
    }
    job.completing = false;
}

void Coordinator::writeJobCheckpoint(Job& job, const JobFilm::Copy& copy, bool final) {
    std::lock_guard writeLock(job.film->writeMutex());
    {
        std::lock_guard lock(m_mutex);
        if (job.deleted || copy.generation != job.film->generation() ||
            !job.film->newerThanCheckpoint(copy.count))
            return;
    }
    const double start = m_clock->monotonicSeconds();
    try {
        if (m_durableWriteHooks.before) m_durableWriteHooks.before();
        job.film->writeFile(copy);
        if (m_durableWriteHooks.after) m_durableWriteHooks.after();
    } catch (const std::exception& e) {
        std::lock_guard lock(m_mutex);
        // The first failure, a new error, and then once a minute: retries follow every
        // checkpoint interval, and a disk that stays broken would fill the log.
        const bool newError = job.film->checkpointError() != e.what();
        ++job.checkpointFailures;
        if (newError || job.checkpointFailures == 1 ||
            start - job.checkpointFailureLoggedAt >= kCheckpointFailureLogSeconds) {
            logWarning("checkpoint.failed",
                       {field("job", job.id), field("final", final ? "yes" : "no"),
                        field("attempts", job.checkpointFailures), field("error", e.what())});
            job.checkpointFailureLoggedAt = start;
        }
        job.film->checkpointFailed(e.what());
        changedLocked(job);
        throw;
    }
    std::lock_guard lock(m_mutex);
    if (copy.generation != job.film->generation()) {
        // The film was emptied while this copy was written (a quarantined worker had merged
        // into it): no restart may resume it.
        std::error_code ignored;
        fs::remove(fs::path(jobDirectory(job.id)) / "film.ckpt", ignored);
        return;
    }
    if (job.checkpointFailures > 0)
        logInfo("checkpoint.recovered",
                {field("job", job.id), field("failed_attempts", job.checkpointFailures)});
    job.checkpointFailures = 0;
    job.film->checkpointWritten(copy.count);
    eventLocked(job, v1::JOB_EVENT_CHECKPOINTED,
                absl::StrFormat("%u of %u units", copy.count, job.grid.unitCount()));
    logInfo("checkpoint.written",
            {field("job", job.id), field("units_merged", copy.count),
             field("units_total", job.grid.unitCount()),
             field("ms", absl::StrFormat("%.1f", 1000 * (m_clock->monotonicSeconds() - start)))});
}

int Coordinator::checkpointDirtyJobs() {
    std::vector<Job*> dirty, complete;
    int failed = 0;
    {
        std::lock_guard lock(m_mutex);
        for (auto& [id, job] : m_jobs) {
            if (job->state != v1::JOB_STATE_RUNNING || job->completing) continue;
            if (job->film->complete()) {
                // Its final checkpoint failed before: try again.
                job->completing = true;
                complete.push_back(job.get());
            } else if (job->film->dirty()) {
                dirty.push_back(job.get());
            }
        }
    }
    for (Job* job : complete) finishJob(*job);
    // One job at a time, so at most one extra film copy is in memory.
    for (Job* job : dirty) {
        JobFilm::Copy copy;
        {
            std::lock_guard lock(m_mutex);
            if (job->state != v1::JOB_STATE_RUNNING || job->completing) continue;
            copy = job->film->copy();
        }
        try {
            writeJobCheckpoint(*job, copy, false);
        } catch (const std::exception&) {
            ++failed;  // logged by writeJobCheckpoint
        }
    }
    return failed;
}

}  // namespace alphorn::coordinator
