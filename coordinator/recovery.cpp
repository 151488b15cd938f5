// Coordinator: taking up the state directory at start. Every worker and job in the store is
// restored; a running job's merged units come back from its checkpoint, a damaged record fails
// only its own job, and a job whose last unit was merged before a crash is finished.
#include "coordinator/coordinator.h"

#include "common/core/system_memory.h"
#include "common/farm/engine_fingerprint.h"
#include "coordinator/checkpoint.h"
#include "coordinator/log.h"

#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;

void Coordinator::resume() {
    const double now = m_clock->wallSeconds();
    for (const WorkerRow& row : m_store.workers()) m_workers->restore(row);
    const std::string database = m_options.stateDirectory + "/state.sqlite";
    for (const JobRow& row : m_store.jobs()) {
        auto job = std::make_unique<Job>();
        job->id = row.id;
        job->state = static_cast<v1::JobState>(row.state);
        job->error = row.error;
        job->createdAt = row.createdAt;
        job->finishedAt = row.finishedAt;
        job->submissionId = row.submissionId;
        // What the row says, also for a job that fails below: its name and owner are listed.
        if (row.description) job->description = *row.description;
        try {
            job->events = EventLog(m_store.jobLog(job->id));
        } catch (const StorageError& e) {
            logWarning("job.log_unreadable", {field("job", job->id), field("error", e.what())});
        }
        // One damaged record fails its job, never the coordinator or the other jobs.
        std::string message = recordDamage(row, database);
        if (message.empty()) {
            try {
                resumeJob(*job, row);
            } catch (const std::exception& e) {
                message = absl::StrFormat("cannot resume job %u from %s: %s", job->id, database,
                                          e.what());
            }
        }
        if (!message.empty()) {
            logWarning("job.unresumable", {field("job", job->id), field("error", message)});
            job->grid = farm::JobGrid();
            job->film = std::make_unique<JobFilm>(job->grid, "");
            job->memoryBytes = 0;
            m_scheduler->addJob(job->id, 0, job->grid, {}, {}, false, "");
            // The job is listed as failed and kept for --keep-finished-hours from now; a record
            // that was failed or cancelled already keeps its own error and time. Whatever the
            // damage, nothing is deleted at start.
            const bool endedBefore =
                (job->state == v1::JOB_STATE_FAILED || job->state == v1::JOB_STATE_CANCELLED) &&
                job->finishedAt > 0;
            if (!endedBefore) {
                job->state = v1::JOB_STATE_FAILED;
                job->error = message;
                job->finishedAt = now;
                m_store.setJobState(job->id, job->state, message, now);
            }
        }
        m_memoryInUse += job->memoryBytes;
        m_jobs[job->id] = std::move(job);
    }
    // A job whose last unit was merged but whose end was not recorded before a crash.
    std::vector<Job*> complete;
    for (auto& [id, job] : m_jobs)
        if (job->state == v1::JOB_STATE_RUNNING && job->film->complete())
            complete.push_back(job.get());
    for (Job* job : complete) {
        job->completing = true;
        finishJob(*job);
    }
}

std::string Coordinator::recordDamage(const JobRow& row, const std::string& database) {
    // Rows stored before the digest existed have none: only the checks of resumeJob() apply.
    if (row.recordSha256.empty() || !row.description ||
        JobStore::recordDigest(row) == row.recordSha256)
        return "";
    // Which field changed the digest cannot tell; what it can tell is that the row no longer
    // holds the job as submitted. Resuming it would render something (an image of another
    // size, say) that is no render of the submitted scene, and call it done.
    return absl::StrFormat(
        "job %u's record is damaged: its fixed fields (scene bundle, settings, image size, now "
        "%dx%d, filter border, creation time, submission id) differ from those it was submitted "
        "with (their digest in jobs.record_sha256 of %s does not match); the job is not resumed "
        "from a record that may not be its own: submit the scene again",
        row.id, row.width, row.height, database);
}

void Coordinator::resumeJob(Job& job, const JobRow& row) {
    if (!row.description) fail("its description is not a valid alphorn.v1.JobDescription");
    job.description = *row.description;
    if (job.state < v1::JOB_STATE_RUNNING || job.state > v1::JOB_STATE_CANCELLED)
        fail("state %d is not a job state", int(job.state));
    if (row.filterBorder < 0 || row.filterBorder > 1024)
        fail("filter border %d is invalid", row.filterBorder);
    const v1::JobSettings& settings = job.description.settings();
    // The record's sizes are checked against this coordinator's limits before anything is
    // allocated for them: a damaged size must fail its job, not exhaust the machine's memory.
    if (row.width < 1 || row.height < 1)
        fail("its image size %dx%d is invalid", row.width, row.height);
    if (uint64_t(row.width) * uint64_t(row.height) > m_options.maxImagePixels)
        fail("its image of %dx%d pixels is larger than the limit of %u (--max-image-pixels)",
             row.width, row.height, m_options.maxImagePixels);
    if (settings.passes() > m_options.maxPasses)
        fail("its %u passes are more than the limit of %u (--max-passes)", settings.passes(),
             m_options.maxPasses);
    if (settings.tile_size() < 1 || settings.tile_size() > 16384)
        fail("its tile size %u is invalid", settings.tile_size());
    if (settings.passes_per_unit() < 1)
        fail("its passes per unit %u are invalid", settings.passes_per_unit());
    const uint64_t tile = settings.tile_size();
    const uint64_t plannedUnits = ((uint64_t(row.width) + tile - 1) / tile) *
                                  ((uint64_t(row.height) + tile - 1) / tile) *
                                  ((uint64_t(settings.passes()) + settings.passes_per_unit() - 1) /
                                   settings.passes_per_unit());
    // A running job's film is held in memory from now on, beside the jobs resumed before it; a
    // finished job's is read when fetched (and held again only if its checkpoint is unreadable).
    if (job.state == v1::JOB_STATE_RUNNING || job.state == v1::JOB_STATE_DONE) {
        const uint64_t memory =
            jobMemoryBytes(row.width, row.height, plannedUnits,
                           row.smallerRadius ? SmallerRadius::Kept : SmallerRadius::None);
        const uint64_t heldBefore = job.state == v1::JOB_STATE_RUNNING ? m_memoryInUse : 0;
        if (heldBefore + memory > m_options.maxMemoryBytes)
            fail(
                "it needs about %s of coordinator memory (a %dx%d film and %u units); the jobs "
                "resumed before it hold %s of the %s allowed (--max-memory)",
                formatBytes(memory), row.width, row.height, plannedUnits, formatBytes(heldBefore),
                formatBytes(m_options.maxMemoryBytes));
    }
    job.filterBorder = row.filterBorder;
    job.suspect = row.suspect;
    job.grid =
        farm::JobGrid(TileGrid(row.width, row.height, int(settings.tile_size()), row.filterBorder,
                               row.smallerRadius ? SmallerRadius::Kept : SmallerRadius::None),
                      settings.passes(), settings.passes_per_unit());
    const uint32_t unitCount = job.grid.unitCount();
    std::vector<uint32_t> attempts(unitCount, 0);
    for (const UnitAttemptsRow& unit : m_store.unitAttempts(job.id))
        if (unit.unitIndex < unitCount) attempts[unit.unitIndex] = unit.attempts;
    job.film = std::make_unique<JobFilm>(job.grid, jobDirectory(job.id) + "/film.ckpt",
                                         checkpointOwner(job.id), targetError(settings),
                                         settings.adaptive());
    bool running = job.state == v1::JOB_STATE_RUNNING;
    if (running || job.state == v1::JOB_STATE_DONE) {
        const std::string checkpointPath = jobDirectory(job.id) + "/film.ckpt";
        std::string problem;
        if (!fs::exists(checkpointPath)) {
            if (job.state == v1::JOB_STATE_DONE) problem = "its final checkpoint is missing";
        } else {
            try {
                job.film->restore(job.film->readFile(), running);
            } catch (const Error& e) {
                problem = e.what();
            }
        }
        if (!problem.empty()) {
            // Every unit is a pure function of the job, so rendering again gives the same bytes.
            logWarning("checkpoint.unreadable", {field("job", job.id), field("error", problem),
                                                 field("action", "rendering it again")});
            job.film->forget();
            job.state = v1::JOB_STATE_RUNNING;
            job.finishedAt = 0;
            m_store.setJobState(job.id, job.state, job.error, 0);
            running = true;
        }
    }
    // A job admitted before jobs carried a fingerprint was admitted by an earlier build; the
    // closest guess is this one's, which has the version that build had (registration checks).
    if (job.description.settings().engine_fingerprint().empty())
        job.description.mutable_settings()->set_engine_fingerprint(farm::engineFingerprint());
    m_scheduler->addJob(job.id, job.description.settings().priority(), job.grid, job.film->merged(),
                        attempts, running, job.description.settings().engine_fingerprint());
    if (!running) return;
    // A crash inside submit() between the job's record and its directory leaves a running job
    // without one: it starts from nothing, and its checkpoints go there.
    fs::create_directories(jobDirectory(job.id));
    m_scheduler->setPaused(job.id, row.paused);
    if (!job.film->inMemory()) {
        const Checkpoint none{FilmBlock(0, 0, row.width, row.height, PassHalves::Kept,
                                        job.grid.tiles().smallerRadius()),
                              job.film->merged()};
        job.film->restore(none, true);
    }
    m_scheduler->setLeaseLimit(job.id, job.film->leaseLimit());
    job.memoryBytes =
        jobMemoryBytes(row.width, row.height, unitCount, job.grid.tiles().smallerRadius());
    job.restored = job.film->mergedCount();
    eventLocked(job, v1::JOB_EVENT_RESUMED_AFTER_RESTART,
                absl::StrFormat("a coordinator process took the job up again: %u of %u units "
                                "merged in its checkpoint%s",
                                job.restored, unitCount, row.paused ? "; still paused" : ""));
    logInfo("job.resumed", {field("job", job.id), field("units_restored", job.restored),
                            field("units_total", unitCount)});
}

}  // namespace alphorn::coordinator
