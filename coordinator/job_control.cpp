// Coordinator: what clients do to jobs and workers once submitted (cancel, retry, pause,
// priority, delete, a job's log, drain), and the removal of what the keep time lets go. Each
// control is recorded in the store and applied to the scheduler and the job, and a job's is
// written to its event log.
#include "coordinator/coordinator.h"

#include "common/core/system_memory.h"
#include "common/farm/convert.h"
#include "coordinator/admission.h"
#include "coordinator/checkpoint.h"
#include "coordinator/log.h"
#include "coordinator/retention.h"

#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;
using Kind = FarmError::Kind;

v1::JobStatus Coordinator::cancel(uint64_t jobId) {
    std::lock_guard lock(m_mutex);
    Job& job = jobLocked(jobId);
    if (job.state == v1::JOB_STATE_RUNNING && !job.completing)
        endJobLocked(job, v1::JOB_STATE_CANCELLED, "cancelled by a client");
    return statusLocked(job);
}

Coordinator::Job& Coordinator::runningJobLocked(uint64_t jobId, const char* action,
                                                const char* done) {
    Job& job = jobLocked(jobId);
    if (job.state != v1::JOB_STATE_RUNNING || job.completing)
        throw FarmError(
            Kind::FailedPrecondition,
            absl::StrFormat("cannot %s job %u: it is %s; only a running job can be %s", action,
                            jobId, job.completing ? "finishing" : farm::jobStateName(job.state),
                            done));
    return job;
}

// Pause and priority write the store without m_mutex: a store write waits for the disk
// (milliseconds), and every lease and merge would wait with it. m_controlMutex keeps the controls
// in the order they were stored and keeps deleteJob() and pruneFinishedJobs() from removing the
// job meanwhile. The change is stored before it is applied and acknowledged; a job that ended
// in between gets it too, stored and in memory alike (a retry keeps a new priority and clears a
// pause).
v1::JobStatus Coordinator::setPaused(uint64_t jobId, bool paused) {
    std::lock_guard control(m_controlMutex);
    {
        std::lock_guard lock(m_mutex);
        Job& job =
            runningJobLocked(jobId, paused ? "pause" : "resume", paused ? "paused" : "resumed");
        if (m_scheduler->paused(jobId) == paused) return statusLocked(job);
    }
    m_store.setJobPaused(jobId, paused);
    v1::JobStatus status;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        m_scheduler->setPaused(jobId, paused);
        const LeaseScheduler::JobLeases leases = m_scheduler->jobLeases(jobId);
        eventLocked(job, paused ? v1::JOB_EVENT_PAUSED : v1::JOB_EVENT_RESUMED,
                    paused
                        ? absl::StrFormat("no new leases; %u units out may finish", leases.leased)
                        : std::string("leasing again"));
        logInfo(paused ? "job.paused" : "job.resumed_by_client", {field("job", jobId)});
        if (!paused) m_workAvailable.notify_all();
        status = statusLocked(job);
    }
    saveChangedEventLogs(jobId);
    return status;
}

v1::JobStatus Coordinator::setPriority(uint64_t jobId, int32_t priority) {
    std::lock_guard control(m_controlMutex);
    v1::JobDescription changed;
    int32_t before = 0;
    {
        std::lock_guard lock(m_mutex);
        Job& job = runningJobLocked(jobId, "change the priority of", "given a new priority");
        before = job.description.settings().priority();
        if (before == priority) return statusLocked(job);
        changed = job.description;
    }
    changed.mutable_settings()->set_priority(priority);
    m_store.setJobDescription(jobId, changed);
    v1::JobStatus status;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        job.description = std::move(changed);
        m_scheduler->setPriority(jobId, priority);
        eventLocked(job, v1::JOB_EVENT_PRIORITY_CHANGED,
                    absl::StrFormat("priority %d -> %d", before, priority));
        logInfo("job.priority",
                {field("job", jobId), field("from", before), field("to", priority)});
        m_workAvailable.notify_all();
        status = statusLocked(job);
    }
    saveChangedEventLogs(jobId);
    return status;
}

std::optional<ControlRequestRow> Coordinator::earlierControlRequest(const char* action,
                                                                    uint64_t jobId,
                                                                    const std::string& requestId) {
    if (requestId.empty()) return std::nullopt;
    std::optional<ControlRequestRow> earlier = m_store.controlRequest(requestId);
    if (earlier && (earlier->action != action || earlier->jobId != jobId))
        throw FarmError(Kind::InvalidArgument,
                        absl::StrFormat("request id %s was sent with a %s of job %u, not a %s of "
                                        "job %u: each call draws its own id",
                                        requestId, earlier->action, earlier->jobId, action, jobId));
    if (earlier)
        logInfo(absl::StrFormat("job.%s_sent_again", action),
                {field("job", jobId), field("request", requestId)});
    return earlier;
}

void Coordinator::recordControlAnswer(const std::string& requestId, const std::string& answer) {
    try {
        m_store.setControlRequestAnswer(requestId, answer);
    } catch (const StorageError& e) {
        logWarning("request.answer_unrecorded",
                   {field("request", requestId), field("error", e.what())});
    }
}

// A retry or delete may be sent again by a client that lost the answer (the coordinator
// restarted after making the change): asked again, the change would be refused (the job runs
// already, or is gone), although the client's request succeeded. With a request id, the
// request is recorded in the transaction that stores its change, so that the same id sent
// again is recognised, under m_controlMutex (a first call still at work finishes first), and
// answered with the first call's answer.
v1::JobStatus Coordinator::retry(uint64_t jobId, const std::string& requestId) {
    checkRequestId(requestId);
    std::lock_guard control(m_controlMutex);
    if (const std::optional<ControlRequestRow> earlier =
            earlierControlRequest("retry", jobId, requestId)) {
        v1::JobControlResponse answer;
        if (!earlier->answer.empty() && answer.ParseFromString(earlier->answer))
            return answer.status();
        // Stopped between the change and recording its answer: the job's status now.
        std::lock_guard lock(m_mutex);
        return statusLocked(jobLocked(jobId));
    }
    Job* job = nullptr;
    uint64_t memory = 0;
    {
        std::lock_guard lock(m_mutex);
        job = &jobLocked(jobId);
        if (job->state == v1::JOB_STATE_RUNNING || job->state == v1::JOB_STATE_DONE)
            throw FarmError(
                Kind::FailedPrecondition,
                absl::StrFormat("cannot retry job %u: it is %s; only a failed or cancelled job "
                                "can run again",
                                jobId, farm::jobStateName(job->state)));
        if (job->grid.unitCount() == 0)
            throw FarmError(Kind::FailedPrecondition,
                            absl::StrFormat("cannot retry job %u: its record could not be "
                                            "resumed (%s); submit the scene again",
                                            jobId, job->error));
        memory = jobMemoryBytes(job->grid.width(), job->grid.height(), job->grid.unitCount(),
                                job->grid.tiles().smallerRadius());
        if (m_memoryInUse + memory > m_options.maxMemoryBytes)
            throw FarmError(Kind::ResourceExhausted,
                            absl::StrFormat("cannot retry job %u now: it needs about %s of "
                                            "coordinator memory; running jobs hold %s of the %s "
                                            "allowed (--max-memory)",
                                            jobId, formatBytes(memory), formatBytes(m_memoryInUse),
                                            formatBytes(m_options.maxMemoryBytes)));
    }
    // The units in the job's checkpoint stay merged: their sums are exact, so finishing the
    // others gives the bytes of a fresh job. A missing or unreadable checkpoint starts afresh.
    // Read without the lock (a film may be large); the write mutex keeps checkpoint writes
    // out, and m_controlMutex keeps deleteJob() away.
    std::lock_guard writeLock(job->film->writeMutex());
    std::optional<Checkpoint> checkpoint;
    const std::string checkpointPath = jobDirectory(jobId) + "/film.ckpt";
    if (fs::exists(checkpointPath)) {
        try {
            checkpoint = job->film->readFile();
        } catch (const Error& e) {
            logWarning("checkpoint.unreadable", {field("job", jobId), field("error", e.what()),
                                                 field("action", "rendering it again")});
        }
    }
    std::unique_lock lock(m_mutex);
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end() || it->second.get() != job)
        throw FarmError(Kind::NotFound, absl::StrFormat("no job %u (deleted)", jobId));
    if (job->state == v1::JOB_STATE_RUNNING || job->state == v1::JOB_STATE_DONE)
        throw FarmError(Kind::FailedPrecondition,
                        absl::StrFormat("cannot retry job %u: it is %s already", jobId,
                                        farm::jobStateName(job->state)));
    if (m_memoryInUse + memory > m_options.maxMemoryBytes)
        throw FarmError(Kind::ResourceExhausted,
                        absl::StrFormat("cannot retry job %u now: not enough coordinator memory "
                                        "(--max-memory)",
                                        jobId));
    // Stored first, in one transaction with the request: should that fail, nothing has changed.
    const ControlRequestRow request{requestId, "retry", jobId, "", m_clock->wallSeconds()};
    m_store.markJobRetried(jobId, requestId.empty() ? nullptr : &request);
    const v1::JobState before = job->state;
    if (checkpoint)
        job->film->restore(std::move(*checkpoint), true);
    else
        job->film->startEmpty();
    job->state = v1::JOB_STATE_RUNNING;
    job->error.clear();
    job->finishedAt = 0;
    job->memoryBytes = memory;
    m_memoryInUse += memory;
    job->restored = job->film->mergedCount();
    job->mergedThisRun = 0;
    job->firstMergeAt.reset();
    job->samplesMergedThisRun = job->raysMergedThisRun = 0;
    m_scheduler->removeJob(jobId);
    m_scheduler->addJob(jobId, job->description.settings().priority(), job->grid,
                        job->film->merged(), {}, true,
                        job->description.settings().engine_fingerprint());
    m_scheduler->setLeaseLimit(jobId, job->film->leaseLimit());
    eventLocked(*job, v1::JOB_EVENT_RETRIED,
                absl::StrFormat("was %s; %u of %u units kept from its checkpoint, the rest "
                                "queued with their attempts forgotten",
                                farm::jobStateName(before), job->restored, job->grid.unitCount()));
    logInfo("job.retried", {field("job", jobId), field("units_kept", job->restored),
                            field("units_total", job->grid.unitCount())});
    // Should every unit be in the checkpoint already, the next checkpoint round ends the job.
    m_workAvailable.notify_all();
    const v1::JobStatus status = statusLocked(*job);
    lock.unlock();
    if (!requestId.empty()) {
        v1::JobControlResponse answer;
        *answer.mutable_status() = status;
        recordControlAnswer(requestId, answer.SerializeAsString());
    }
    saveChangedEventLogs(jobId);
    return status;
}

v1::DeleteJobResponse Coordinator::deleteJob(uint64_t jobId, bool cancelRunning,
                                             const std::string& requestId) {
    checkRequestId(requestId);
    std::lock_guard control(m_controlMutex);
    if (const std::optional<ControlRequestRow> earlier =
            earlierControlRequest("delete", jobId, requestId)) {
        v1::DeleteJobResponse answer;
        if (earlier->answer.empty() || !answer.ParseFromString(earlier->answer)) answer.Clear();
        answer.set_job_id(jobId);
        return answer;
    }
    v1::DeleteJobResponse response;
    response.set_job_id(jobId);
    std::unique_ptr<Job> deleted;
    std::set<std::string> jobBlobs, referenced;
    std::unordered_map<std::string, double> touchedAt;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        if (job.state == v1::JOB_STATE_RUNNING) {
            if (job.completing)
                throw FarmError(Kind::FailedPrecondition,
                                absl::StrFormat("job %u is finishing (its final checkpoint is "
                                                "being written); try again in a moment",
                                                jobId));
            if (!cancelRunning)
                throw FarmError(
                    Kind::FailedPrecondition,
                    absl::StrFormat("job %u is running: cancel it first (alphorn cancel %u), "
                                    "or delete it with --cancel",
                                    jobId, jobId));
        }
        if (job.state == v1::JOB_STATE_RUNNING) {
            endJobLocked(job, v1::JOB_STATE_CANCELLED, "cancelled by a client to delete it");
            response.set_cancelled(true);
        }
        // Should this fail, the job is still there (cancelled), as the store says. The request
        // is recorded with the removal, its answer as far as it is known: the blobs follow.
        const ControlRequestRow request{requestId, "delete", jobId, response.SerializeAsString(),
                                        m_clock->wallSeconds()};
        m_store.removeJob(jobId, requestId.empty() ? nullptr : &request);
        job.deleted = true;
        job.changes->close();
        for (const v1::BundleFile& file : job.description.bundle().files())
            jobBlobs.insert(file.sha256());
        m_scheduler->removeJob(jobId);
        auto it = m_jobs.find(jobId);
        deleted = std::move(it->second);
        m_jobs.erase(it);
        for (const auto& [id, other] : m_jobs)
            for (const v1::BundleFile& file : other->description.bundle().files())
                referenced.insert(file.sha256());
        touchedAt = m_blobsTouchedAt;
    }
    {
        // A checkpoint write of the job in progress finishes before its directory goes.
        std::lock_guard writeLock(deleted->film->writeMutex());
        std::error_code ignored;
        fs::remove_all(jobDirectory(jobId), ignored);
    }
    for (const std::string& sha : Retention::deletedJobBlobs(jobBlobs, referenced, touchedAt)) {
        if (!m_blobs.has(sha)) continue;
        response.set_blob_bytes_removed(response.blob_bytes_removed() + m_blobs.size(sha));
        response.set_blobs_removed(response.blobs_removed() + 1);
        m_blobs.remove(sha);
    }
    if (!requestId.empty()) recordControlAnswer(requestId, response.SerializeAsString());
    logInfo("job.deleted", {field("job", jobId), field("cancelled", response.cancelled()),
                            field("blobs", response.blobs_removed()),
                            field("bytes", response.blob_bytes_removed())});
    std::lock_guard lock(m_mutex);
    m_deletedJobs.push_back(std::move(deleted));
    return response;
}

v1::GetJobLogResponse Coordinator::jobLog(uint64_t jobId, uint64_t afterSequence) {
    std::lock_guard lock(m_mutex);
    const Job& job = jobLocked(jobId);
    v1::GetJobLogResponse response;
    for (v1::JobEvent& event : job.events.after(afterSequence))
        *response.add_events() = std::move(event);
    response.set_events_dropped(job.events.dropped());
    response.set_state(job.state);
    return response;
}

v1::WorkerInfo Coordinator::setWorkerDraining(uint64_t workerId, bool draining) {
    std::lock_guard lock(m_mutex);
    WorkerRegistry::Worker* worker = m_workers->find(workerId);
    if (!worker)
        throw FarmError(
            Kind::UnknownWorker,
            absl::StrFormat("no worker %u (alphorn workers --all lists them)", workerId));
    if (worker->draining != draining) {
        m_store.setWorkerDraining(workerId, draining);
        m_workers->setDraining(*worker, draining);
        logInfo(draining ? "worker.draining" : "worker.undrained",
                {field("worker", workerId), field("by", "client"),
                 field("leases", m_scheduler->leaseCount(workerId))});
        m_workAvailable.notify_all();
    }
    return m_workers->info(workerId, *worker);
}

void Coordinator::pruneFinishedJobs(double wallNow) {
    if (const uint64_t forgotten =
            m_store.removeControlRequestsBefore(wallNow - kControlRequestKeepSeconds))
        logInfo("requests.forgotten", {field("requests", forgotten)});
    const Retention retention(m_options.keepFinishedSeconds);
    if (retention.keepsEverything()) return;
    // Not while retry() holds an ended job outside m_mutex (or deleteJob() works).
    std::lock_guard control(m_controlMutex);
    std::vector<uint64_t> removed;
    std::set<std::string> referenced;
    std::unordered_map<std::string, double> touchedAt;
    std::vector<uint64_t> forgottenWorkers;
    {
        std::lock_guard lock(m_mutex);
        for (auto it = m_jobs.begin(); it != m_jobs.end();) {
            const Job& job = *it->second;
            // Nobody holds a pointer to an ended job outside m_mutex once `completing` is
            // cleared (finishJob), so it can go.
            if (job.state != v1::JOB_STATE_RUNNING && !job.completing &&
                retention.expired(job.finishedAt, wallNow)) {
                removed.push_back(job.id);
                job.changes->close();
                m_scheduler->removeJob(job.id);
                it = m_jobs.erase(it);
                continue;
            }
            for (const v1::BundleFile& file : job.description.bundle().files())
                referenced.insert(file.sha256());
            ++it;
        }
        forgottenWorkers = m_workers->forgetSilent(retention, wallNow);
        std::erase_if(m_blobsTouchedAt,
                      [&](const auto& entry) { return retention.expired(entry.second, wallNow); });
        touchedAt = m_blobsTouchedAt;
    }
    const double keep = m_options.keepFinishedSeconds;
    for (uint64_t jobId : removed) {
        m_store.removeJob(jobId);
        std::error_code ignored;
        fs::remove_all(jobDirectory(jobId), ignored);
        logInfo("job.removed",
                {field("job", jobId), field("kept_hours", absl::StrFormat("%.4g", keep / 3600))});
    }
    for (uint64_t workerId : forgottenWorkers) {
        m_store.removeWorker(workerId);
        logInfo("worker.forgotten", {field("worker", workerId)});
    }
    uint64_t blobCount = 0, blobBytes = 0;
    for (const BlobStore::StoredBlob& blob :
         retention.unusedBlobs(m_blobs.list(), referenced, touchedAt, wallNow)) {
        m_blobs.remove(blob.sha256);
        ++blobCount;
        blobBytes += blob.size;
    }
    if (blobCount > 0)
        logInfo("blobs.removed", {field("blobs", blobCount), field("bytes", blobBytes)});
}

}  // namespace alphorn::coordinator
