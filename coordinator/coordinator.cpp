#include "coordinator/coordinator.h"

#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/film_codec.h"
#include "common/farm/job_scene.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "common/integrator/integrator.h"
#include "common/photon/radius_schedule.h"
#include "common/scene/scene.h"
#include "coordinator/checkpoint.h"
#include "coordinator/log.h"

#include <absl/strings/str_replace.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <openssl/rand.h>
#include <unistd.h>
#include <zstd.h>

#include <cstring>
#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using Kind = FarmError::Kind;

namespace {

double wallSeconds() {
    return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
        .count();
}

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

uint64_t physicalMemoryBytes() {
    return uint64_t(::sysconf(_SC_PHYS_PAGES)) * uint64_t(::sysconf(_SC_PAGE_SIZE));
}

std::string mebibytes(uint64_t bytes) {
    return absl::StrFormat("%.0f MiB", double(bytes) / (1 << 20));
}

}  // namespace

uint64_t Coordinator::jobMemoryBytes(int width, int height, uint64_t unitCount) {
    // Per unit: its slot (72 bytes), its merged flag and a node of the pending set (40 bytes in
    // libstdc++, 48 with the allocator's rounding): about 120 bytes.
    constexpr uint64_t kPendingNode = 48;
    return uint64_t(width) * uint64_t(height) * sizeof(PixelSum) +
           unitCount * (sizeof(UnitSlot) + kPendingNode + 1);
}

Coordinator::Coordinator(CoordinatorOptions options)
    : m_options(std::move(options)),
      m_lock(m_options.stateDirectory),
      m_db(checkedDatabasePath(m_options.stateDirectory)),
      m_blobs(m_options.stateDirectory + "/blobs", m_options.maxBlobBytes),
      m_nextLeaseId(randomLeaseBase()) {
    if (m_options.maxMemoryBytes == 0) m_options.maxMemoryBytes = physicalMemoryBytes() / 2;
    fs::create_directories(fs::path(m_options.stateDirectory) / "jobs");
    fs::create_directories(fs::path(m_options.stateDirectory) / "tmp");
    for (const auto& entry : fs::directory_iterator(fs::path(m_options.stateDirectory) / "tmp"))
        fs::remove_all(entry.path());
    // Lease tokens are signed with a key kept in the database and name this process's epoch,
    // so a later process can tell which leases it may re-adopt (those of earlier processes).
    const auto epochRows = m_db.query("SELECT value FROM meta WHERE key = 'epoch'");
    m_epoch = epochRows.empty() ? 1 : uint64_t(StateDatabase::integer(epochRows[0][0])) + 1;
    m_db.execute("INSERT OR REPLACE INTO meta(key, value) VALUES('epoch', ?)", {int64_t(m_epoch)});
    const auto keyRows = m_db.query("SELECT value FROM meta WHERE key = 'lease_key'");
    if (!keyRows.empty()) m_leaseKey = StateDatabase::text(keyRows[0][0]);
    if (m_leaseKey.size() != 32) {
        m_leaseKey.assign(32, '\0');
        if (RAND_bytes(reinterpret_cast<unsigned char*>(m_leaseKey.data()), 32) != 1)
            fail("cannot generate the lease key (OpenSSL)");
        m_db.execute("INSERT OR REPLACE INTO meta(key, value) VALUES('lease_key', ?)",
                     {m_leaseKey});
    }
    resume();
}

Coordinator::~Coordinator() {
    stop();
}

std::string Coordinator::jobDirectory(uint64_t jobId) const {
    return (fs::path(m_options.stateDirectory) / "jobs" / std::to_string(jobId)).string();
}

void Coordinator::resume() {
    const double now = wallSeconds();
    for (const auto& row :
         m_db.query("SELECT id, name, cores, memory_bytes, version FROM workers")) {
        WorkerRecord worker;
        worker.info.set_worker_id(StateDatabase::integer(row[0]));
        worker.info.set_name(StateDatabase::text(row[1]));
        worker.info.set_cores(StateDatabase::integer(row[2]));
        worker.info.set_memory_bytes(StateDatabase::integer(row[3]));
        worker.info.set_version(StateDatabase::text(row[4]));
        worker.lastSeen = Clock::now() - std::chrono::hours(24 * 365);
        worker.lastContactWall = now;  // forgotten after the keep time unless it calls
        m_workers[worker.info.worker_id()] = std::move(worker);
    }
    const std::string database = m_options.stateDirectory + "/state.sqlite";
    for (const auto& row : m_db.query("SELECT id, description, state, error, width, height, "
                                      "filter_border, created_at, finished_at FROM jobs")) {
        auto job = std::make_unique<Job>();
        job->id = StateDatabase::integer(row[0]);
        job->state = static_cast<v1::JobState>(StateDatabase::integer(row[2]));
        job->error = StateDatabase::text(row[3]);
        if (const double* createdAt = std::get_if<double>(&row[7])) job->createdAt = *createdAt;
        if (const double* finishedAt = std::get_if<double>(&row[8])) job->finishedAt = *finishedAt;
        try {
            resumeJob(*job, StateDatabase::text(row[1]), int(StateDatabase::integer(row[4])),
                      int(StateDatabase::integer(row[5])), int(StateDatabase::integer(row[6])));
        } catch (const std::exception& e) {
            // One damaged record fails its job, never the coordinator or the other jobs.
            const std::string message =
                absl::StrFormat("cannot resume job %u from %s: %s", job->id, database, e.what());
            logWarning("job.unresumable", {field("job", job->id), field("error", message)});
            job->grid = farm::JobGrid();
            job->units.clear();
            job->merged.clear();
            job->pending.clear();
            job->film = FilmBlock();
            job->mergedCount = 0;
            if (job->state == v1::JOB_STATE_RUNNING || job->state == v1::JOB_STATE_DONE) {
                job->state = v1::JOB_STATE_FAILED;
                job->error = message;
                job->finishedAt = now;
                m_db.execute("UPDATE jobs SET state = ?, error = ?, finished_at = ? WHERE id = ?",
                             {int64_t(job->state), message, now, int64_t(job->id)});
            }
        }
        m_memoryInUse += job->memoryBytes;
        m_jobs[job->id] = std::move(job);
    }
    // A job whose last unit was merged but whose end was not recorded before a crash.
    std::vector<Job*> complete;
    for (auto& [id, job] : m_jobs)
        if (job->state == v1::JOB_STATE_RUNNING && job->mergedCount == job->grid.unitCount())
            complete.push_back(job.get());
    for (Job* job : complete) {
        job->completing = true;
        finishJob(*job);
    }
}

void Coordinator::resumeJob(Job& job, const std::string& description, int width, int height,
                            int filterBorder) {
    if (!job.description.ParseFromString(description))
        fail("its description is not a valid alphorn.v1.JobDescription");
    // The id is the row's; descriptions stored before it was known carry 0.
    job.description.set_job_id(job.id);
    if (job.state < v1::JOB_STATE_RUNNING || job.state > v1::JOB_STATE_CANCELLED)
        fail("state %d is not a job state", int(job.state));
    if (filterBorder < 0 || filterBorder > 1024) fail("filter border %d is invalid", filterBorder);
    const v1::JobSettings& settings = job.description.settings();
    job.filterBorder = filterBorder;
    job.grid = farm::JobGrid(width, height, int(settings.tile_size()), settings.passes(),
                             settings.passes_per_unit());
    const uint32_t unitCount = job.grid.unitCount();
    job.units.resize(unitCount);
    job.merged.assign(unitCount, false);
    for (const auto& unitRow :
         m_db.query("SELECT unit_index, attempts, last_error FROM units WHERE job_id = ?",
                    {int64_t(job.id)})) {
        const auto index = static_cast<uint64_t>(StateDatabase::integer(unitRow[0]));
        if (index >= unitCount) continue;
        job.units[index].attempts = static_cast<uint32_t>(StateDatabase::integer(unitRow[1]));
        job.units[index].lastError = StateDatabase::text(unitRow[2]);
        job.attemptsFailed += job.units[index].attempts;
    }
    if (job.state != v1::JOB_STATE_RUNNING && job.state != v1::JOB_STATE_DONE) return;
    const std::string checkpointPath = jobDirectory(job.id) + "/film.ckpt";
    std::string problem;
    if (!fs::exists(checkpointPath)) {
        if (job.state == v1::JOB_STATE_DONE) problem = "its final checkpoint is missing";
    } else {
        try {
            Checkpoint checkpoint = readCheckpoint(checkpointPath, width, height, unitCount);
            job.merged = std::move(checkpoint.merged);
            if (job.state == v1::JOB_STATE_RUNNING) job.film = std::move(checkpoint.film);
        } catch (const Error& e) {
            problem = e.what();
        }
    }
    if (!problem.empty()) {
        // Every unit is a pure function of the job, so rendering again gives the same bytes.
        logWarning("checkpoint.unreadable", {field("job", job.id), field("error", problem),
                                             field("action", "rendering it again")});
        job.merged.assign(unitCount, false);
        job.state = v1::JOB_STATE_RUNNING;
        job.finishedAt = 0;
        m_db.execute("UPDATE jobs SET state = ?, finished_at = NULL WHERE id = ?",
                     {int64_t(job.state), int64_t(job.id)});
    }
    for (uint32_t i = 0; i < unitCount; ++i)
        if (job.merged[i]) {
            job.units[i].state = UnitState::Merged;
            ++job.mergedCount;
        }
    job.checkpointedCount = job.mergedCount;
    if (job.state != v1::JOB_STATE_RUNNING) return;
    if (job.film.width() == 0) job.film = FilmBlock(0, 0, width, height);
    job.memoryBytes = jobMemoryBytes(width, height, unitCount);
    job.restored = job.mergedCount;
    for (uint32_t i = 0; i < unitCount; ++i)
        if (!job.merged[i]) job.pending.insert(i);
    logInfo("job.resumed", {field("job", job.id), field("units_restored", job.restored),
                            field("units_total", unitCount)});
}

void Coordinator::start() {
    m_background = std::thread([this] { backgroundLoop(); });
}

void Coordinator::beginStop() {
    {
        std::lock_guard lock(m_mutex);
        m_stopping = true;
    }
    m_workAvailable.notify_all();  // long-polling AcquireWork calls return at once
}

void Coordinator::stop() {
    {
        std::lock_guard lock(m_mutex);
        if (m_stopped) return;
        m_stopped = true;
        m_stopping = true;
    }
    m_backgroundWake.notify_all();
    m_workAvailable.notify_all();
    if (m_background.joinable()) m_background.join();
    checkpointDirtyJobs();
    logInfo("coordinator.stopped");
}

void Coordinator::backgroundLoop() {
    auto nextCheckpoint =
        Clock::now() + std::chrono::duration_cast<Clock::duration>(
                           std::chrono::duration<double>(m_options.checkpointIntervalSeconds));
    auto nextPrune = Clock::now() + std::chrono::seconds(1);
    std::unique_lock lock(m_mutex);
    while (!m_stopping) {
        m_backgroundWake.wait_for(lock, std::chrono::milliseconds(200));
        if (m_stopping) break;
        lock.unlock();
        try {
            expireLeases();
        } catch (const std::exception& e) {
            logWarning("leases.expiry_failed", {field("error", e.what())});
        }
        if (Clock::now() >= nextPrune) {
            try {
                pruneFinishedJobs(wallSeconds());
            } catch (const std::exception& e) {
                logWarning("prune.failed", {field("error", e.what())});
            }
            nextPrune = Clock::now() + std::chrono::minutes(1);
        }
        if (Clock::now() >= nextCheckpoint) {
            checkpointDirtyJobs();
            nextCheckpoint =
                Clock::now() +
                std::chrono::duration_cast<Clock::duration>(
                    std::chrono::duration<double>(m_options.checkpointIntervalSeconds));
        }
        lock.lock();
    }
}

void Coordinator::recordBlob(const std::string& sha256, uint64_t size) {
    try {
        // Informational: the blob directory is what counts, and the blob is in it already.
        m_db.execute("INSERT OR IGNORE INTO blobs(sha256, size, stored_at) VALUES(?, ?, ?)",
                     {sha256, int64_t(size), wallSeconds()});
    } catch (const StorageError& e) {
        logWarning("blob.not_recorded", {field("sha256", sha256), field("error", e.what())});
    }
    touchBlobs({sha256});
}

void Coordinator::touchBlobs(const std::vector<std::string>& sha256s) {
    const double now = wallSeconds();
    std::lock_guard lock(m_mutex);
    for (const std::string& sha : sha256s) m_blobsTouchedAt[sha] = now;
}

void Coordinator::pruneFinishedJobs(double wallNow) {
    const double keep = m_options.keepFinishedSeconds;
    if (!(keep > 0)) return;
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
                job.finishedAt + keep <= wallNow) {
                removed.push_back(job.id);
                it = m_jobs.erase(it);
                continue;
            }
            for (const v1::BundleFile& file : job.description.bundle().files())
                referenced.insert(file.sha256());
            ++it;
        }
        for (auto& [id, worker] : m_workers)
            for (uint64_t jobId : removed) worker.lastChunk.erase(jobId);
        // Workers that have not called for the keep time are forgotten (each restart of a
        // worker registers a new id, so the table would grow without bound).
        for (auto it = m_workers.begin(); it != m_workers.end();) {
            if (it->second.leases.empty() && it->second.lastContactWall + keep <= wallNow) {
                forgottenWorkers.push_back(it->first);
                it = m_workers.erase(it);
            } else {
                ++it;
            }
        }
        std::erase_if(m_blobsTouchedAt,
                      [&](const auto& entry) { return entry.second + keep <= wallNow; });
        touchedAt = m_blobsTouchedAt;
    }
    for (uint64_t jobId : removed) {
        m_db.execute("DELETE FROM units WHERE job_id = ?", {int64_t(jobId)});
        m_db.execute("DELETE FROM jobs WHERE id = ?", {int64_t(jobId)});
        std::error_code ignored;
        fs::remove_all(jobDirectory(jobId), ignored);
        logInfo("job.removed",
                {field("job", jobId), field("kept_hours", absl::StrFormat("%.4g", keep / 3600))});
    }
    for (uint64_t workerId : forgottenWorkers) {
        m_db.execute("DELETE FROM workers WHERE id = ?", {int64_t(workerId)});
        logInfo("worker.forgotten", {field("worker", workerId)});
    }
    uint64_t blobCount = 0, blobBytes = 0;
    for (const BlobStore::StoredBlob& blob : m_blobs.list()) {
        double lastUse = blob.storedAt;
        if (auto it = touchedAt.find(blob.sha256); it != touchedAt.end())
            lastUse = std::max(lastUse, it->second);
        if (referenced.count(blob.sha256) || lastUse + keep > wallNow) continue;
        m_blobs.remove(blob.sha256);
        m_db.execute("DELETE FROM blobs WHERE sha256 = ?", {blob.sha256});
        ++blobCount;
        blobBytes += blob.size;
    }
    if (blobCount > 0)
        logInfo("blobs.removed", {field("blobs", blobCount), field("bytes", blobBytes)});
}

// ---- jobs ------------------------------------------------------------------------------------

v1::JobStatus Coordinator::submit(const v1::SubmitJobRequest& request) {
    farm::Bundle bundle = farm::fromProto(request.bundle());
    try {
        farm::validateBundle(bundle);
    } catch (const Error& e) {
        throw FarmError(Kind::InvalidArgument, e.what());
    }
    uint64_t total = 0;
    for (const farm::BundleEntry& file : bundle.files) {
        if (!m_blobs.has(file.sha256))
            throw FarmError(
                Kind::FailedPrecondition,
                absl::StrFormat("blob %s (%s) has not been uploaded", file.sha256, file.path));
        const uint64_t size = m_blobs.size(file.sha256);
        if (size != file.size)
            throw FarmError(Kind::InvalidArgument,
                            absl::StrFormat("%s: the manifest says %u bytes, the blob has %u",
                                            file.path, file.size, size));
        total += size;
    }
    if (total > m_options.maxBundleBytes)
        throw FarmError(Kind::ResourceExhausted,
                        absl::StrFormat("the bundle has %u bytes, more than the limit of %u", total,
                                        m_options.maxBundleBytes));

    // Materialize and load the scene now, so a broken scene fails at submit with the loader's
    // "file:line: problem", with paths as the client knows them (relative to the bundle).
    const std::string staging =
        (fs::path(m_options.stateDirectory) / "tmp" / farm::generateToken().substr(0, 16)).string();
    const std::string bundleDirectory = staging + "/bundle";
    v1::JobSettings settings = request.settings();
    std::shared_ptr<Scene> scene;
    try {
        const std::string scenePath = farm::materializeBundle(
            bundle, bundleDirectory, [&](const std::string& sha) { return m_blobs.pathOf(sha); });
        scene = farm::loadJobScene(bundleDirectory, scenePath, settings.integrator_override());
    } catch (const Error& e) {
        fs::remove_all(staging);
        throw FarmError(Kind::InvalidArgument,
                        absl::StrReplaceAll(e.what(), {{bundleDirectory + "/", ""}}));
    }
    const Vector2i size = scene->camera()->outputSize();
    if (settings.passes() == 0)
        settings.set_passes(static_cast<uint32_t>(scene->sampler()->sampleCount()));
    if (settings.tile_size() == 0) settings.set_tile_size(m_options.defaultTileSize);
    if (settings.passes_per_unit() == 0) {
        // Units of at least ~64k samples keep the per-unit cost (two round trips, compression,
        // merge) near 1% of rendering, while at least 4 pass chunks keep previews progressive.
        const uint64_t tilePixels = std::min<uint64_t>(
            uint64_t(settings.tile_size()) * settings.tile_size(), uint64_t(size.x()) * size.y());
        const uint64_t bySamples = std::max<uint64_t>(1, 65536 / std::max<uint64_t>(1, tilePixels));
        const uint64_t byPreview = std::max<uint64_t>(1, settings.passes() / 4);
        settings.set_passes_per_unit(static_cast<uint32_t>(
            std::max<uint64_t>(m_options.defaultPassesPerUnit, std::min(bySamples, byPreview))));
    }
    // A unit never spans more passes than the job has (the image does not depend on it).
    settings.set_passes_per_unit(std::min(settings.passes_per_unit(), settings.passes()));
    if (settings.name().empty()) settings.set_name(fs::path(bundle.scenePath).stem().string());
    const std::optional<RadiusSchedule> radiusSchedule = scene->integrator()->radiusSchedule();
    const int filterBorder = -makeUnitBlock(*scene, Tile{0, 0, 1, 1}).x0();
    scene.reset();
    auto refuse = [&](Kind kind, const std::string& message) {
        fs::remove_all(staging);
        throw FarmError(kind, message);
    };
    if (uint64_t(size.x()) * uint64_t(size.y()) > m_options.maxImagePixels)
        refuse(Kind::ResourceExhausted,
               absl::StrFormat("the image has %dx%d pixels, more than the limit of %u", size.x(),
                               size.y(), m_options.maxImagePixels));
    if (settings.passes() > m_options.maxPasses)
        refuse(Kind::ResourceExhausted, absl::StrFormat("%u passes requested, the limit is %u",
                                                        settings.passes(), m_options.maxPasses));
    if (settings.tile_size() > 16384)
        refuse(Kind::InvalidArgument, "tile size must be at most 16384");
    farm::JobGrid grid;
    try {
        grid = farm::JobGrid(size.x(), size.y(), int(settings.tile_size()), settings.passes(),
                             settings.passes_per_unit());
    } catch (const Error& e) {
        refuse(Kind::InvalidArgument, e.what());
    }
    const uint64_t memory = jobMemoryBytes(size.x(), size.y(), grid.unitCount());
    {
        std::lock_guard lock(m_mutex);
        if (m_memoryInUse + memory > m_options.maxMemoryBytes)
            refuse(Kind::ResourceExhausted,
                   absl::StrFormat(
                       "the job needs about %s of coordinator memory (a %dx%d film and %u units; "
                       "larger tiles or more passes per unit need fewer units); running jobs "
                       "hold %s of the %s allowed (--max-memory)",
                       mebibytes(memory), size.x(), size.y(), grid.unitCount(),
                       mebibytes(m_memoryInUse), mebibytes(m_options.maxMemoryBytes)));
        // Reserved now, so concurrent submissions cannot overshoot together.
        m_memoryInUse += memory;
    }
    auto release = [&] {
        std::lock_guard lock(m_mutex);
        m_memoryInUse -= memory;
    };

    auto job = std::make_unique<Job>();
    job->description.mutable_bundle()->CopyFrom(request.bundle());
    job->description.mutable_settings()->CopyFrom(settings);
    if (radiusSchedule) {
        v1::PhotonRadiusSchedule& schedule = *job->description.mutable_photon_radius_schedule();
        schedule.set_initial_radius(radiusSchedule->initialRadius);
        schedule.set_alpha(radiusSchedule->alpha);
    }
    job->createdAt = wallSeconds();
    try {
        const auto rows = m_db.query(
            "INSERT INTO jobs(description, state, width, height, filter_border, created_at) "
            "VALUES(?, ?, ?, ?, ?, ?) RETURNING id",
            {job->description.SerializeAsString(), int64_t(v1::JOB_STATE_RUNNING),
             int64_t(size.x()), int64_t(size.y()), int64_t(filterBorder), job->createdAt});
        job->id = static_cast<uint64_t>(StateDatabase::integer(rows.at(0).at(0)));
    } catch (const Error& e) {
        release();
        refuse(Kind::ResourceExhausted, absl::StrFormat("cannot record the job: %s", e.what()));
    }
    job->description.set_job_id(job->id);
    try {
        // The stored description carries its id too, so workers told of a resumed job load
        // that job's scene and no other.
        m_db.execute("UPDATE jobs SET description = ? WHERE id = ?",
                     {job->description.SerializeAsString(), int64_t(job->id)});
        // A directory for a new id means the database lost jobs: never delete their films.
        if (fs::exists(jobDirectory(job->id)))
            fail("%s exists already although the database had no job %u", jobDirectory(job->id),
                 job->id);
        fs::rename(staging, jobDirectory(job->id));
    } catch (const std::exception& e) {
        release();
        try {
            m_db.execute("DELETE FROM jobs WHERE id = ?", {int64_t(job->id)});
        } catch (const Error&) {
            // The row stays; resume() fails that job with a clear error instead.
        }
        refuse(Kind::ResourceExhausted, absl::StrFormat("cannot store the job: %s", e.what()));
    }
    job->memoryBytes = memory;
    job->grid = grid;
    job->filterBorder = filterBorder;
    job->film = FilmBlock(0, 0, size.x(), size.y());
    job->units.resize(grid.unitCount());
    job->merged.assign(grid.unitCount(), false);
    for (uint32_t i = 0; i < grid.unitCount(); ++i) job->pending.insert(i);

    std::lock_guard lock(m_mutex);
    const uint64_t id = job->id;
    m_jobs[id] = std::move(job);
    logInfo("job.submitted", {field("job", id), field("name", settings.name()),
                              field("size", absl::StrFormat("%dx%d", size.x(), size.y())),
                              field("passes", settings.passes()), field("units", grid.unitCount()),
                              field("priority", settings.priority())});
    m_workAvailable.notify_all();
    return statusLocked(*m_jobs[id]);
}

Coordinator::Job& Coordinator::jobLocked(uint64_t jobId) {
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) throw FarmError(Kind::NotFound, absl::StrFormat("no job %u", jobId));
    return *it->second;
}

v1::JobStatus Coordinator::statusLocked(const Job& job) const {
    v1::JobStatus status;
    status.set_job_id(job.id);
    *status.mutable_settings() = job.description.settings();
    status.set_state(job.state);
    status.set_error(job.error);
    if (job.state == v1::JOB_STATE_RUNNING && !job.checkpointError.empty())
        status.set_error(absl::StrFormat(
            "cannot write the checkpoint (%s); retrying every %.3g s",
            absl::StrReplaceAll(job.checkpointError, {{m_options.stateDirectory + "/", ""}}),
            m_options.checkpointIntervalSeconds));
    status.set_width(job.grid.width());
    status.set_height(job.grid.height());
    status.set_units_total(job.grid.unitCount());
    status.set_units_done(job.mergedCount);
    std::set<uint64_t> workers;
    uint32_t leased = 0;
    for (const UnitSlot& slot : job.units)
        if (slot.state == UnitState::Leased) {
            ++leased;
            workers.insert(slot.workerId);
        }
    status.set_units_leased(leased);
    status.set_active_workers(static_cast<uint32_t>(workers.size()));
    const uint32_t passesDone = job.grid.passesComplete(job.merged);
    status.set_passes_done(passesDone);
    const v1::PhotonRadiusSchedule& schedule = job.description.photon_radius_schedule();
    if (job.description.has_photon_radius_schedule() && isValidRadiusAlpha(schedule.alpha())) {
        status.set_photon_radius(
            reportedProgressiveRadius(schedule.initial_radius(), schedule.alpha(), passesDone));
    }
    status.set_units_restored(job.restored);
    status.set_units_merged_this_run(job.mergedThisRun);
    status.set_results_discarded(job.discarded);
    status.set_attempts_failed(job.attemptsFailed);
    status.set_checkpoints_written(job.checkpointsWritten);
    status.set_units_leased_this_run(job.leasedThisRun);
    status.set_pass_data_builds(job.passDataBuilds);
    status.set_invalid_samples(job.film.invalidSamples);
    status.set_elapsed_seconds(wallSeconds() - job.createdAt);
    double rate = 0.0;
    if (job.firstMergeAt) {
        const double seconds =
            std::chrono::duration<double>(Clock::now() - *job.firstMergeAt).count();
        if (seconds > 0.05) rate = job.samplesMergedThisRun / seconds;
    }
    status.set_samples_per_second(rate);
    const uint64_t totalSamples =
        uint64_t(job.grid.width()) * job.grid.height() * job.grid.passes();
    uint64_t doneSamples = 0;
    for (uint32_t i = 0; i < job.grid.unitCount(); ++i)
        if (job.merged[i]) {
            const RenderUnit unit = job.grid.unit(i);
            doneSamples +=
                uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
        }
    if (job.state != v1::JOB_STATE_RUNNING)
        status.set_eta_seconds(0.0);
    else
        status.set_eta_seconds(rate > 0 ? double(totalSamples - doneSamples) / rate : -1.0);
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
    job.pending.clear();
    for (UnitSlot& slot : job.units)
        if (slot.state == UnitState::Leased) {
            m_leases.erase(slot.leaseId);
            if (auto it = m_workers.find(slot.workerId); it != m_workers.end())
                it->second.leases.erase(slot.leaseId);
            slot.state = UnitState::Pending;
        }
    job.finishedAt = wallSeconds();
    m_memoryInUse -= job.memoryBytes;
    job.memoryBytes = 0;
    job.checkpointError.clear();
    if (state != v1::JOB_STATE_DONE) job.film = FilmBlock();
    // Memory first, database last: if the write fails (a full disk) the job has ended in this
    // process, and a restart finds it as the database says (a finished film is finished again).
    m_db.execute("UPDATE jobs SET state = ?, error = ?, finished_at = ? WHERE id = ?",
                 {int64_t(state), error, job.finishedAt, int64_t(job.id)});
    (state == v1::JOB_STATE_DONE ? logInfo : logWarning)(
        "job.ended",
        {field("job", job.id), field("state", farm::jobStateName(state)), field("error", error),
         field("units_merged_this_run", job.mergedThisRun), field("units_restored", job.restored),
         field("results_discarded", job.discarded)});
}

v1::JobStatus Coordinator::cancel(uint64_t jobId) {
    std::lock_guard lock(m_mutex);
    Job& job = jobLocked(jobId);
    if (job.state == v1::JOB_STATE_RUNNING && !job.completing)
        endJobLocked(job, v1::JOB_STATE_CANCELLED, "cancelled by a client");
    return statusLocked(job);
}

Coordinator::ImageSnapshot Coordinator::snapshot(uint64_t jobId, bool preview) {
    ImageSnapshot snap;
    int width = 0, height = 0;
    uint32_t units = 0;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        snap.status = statusLocked(job);
        if (job.state == v1::JOB_STATE_RUNNING && !preview)
            throw FarmError(
                Kind::FailedPrecondition,
                absl::StrFormat("job %u is still running (%u of %u units); ask for a preview",
                                jobId, job.mergedCount, job.grid.unitCount()));
        if (job.state == v1::JOB_STATE_FAILED || job.state == v1::JOB_STATE_CANCELLED)
            throw FarmError(Kind::FailedPrecondition,
                            absl::StrFormat("job %u has no image: %s", jobId, job.error));
        if (job.film.width() > 0) {
            snap.film = job.film;
            return snap;
        }
        width = job.grid.width();
        height = job.grid.height();
        units = job.grid.unitCount();
    }
    // A finished job whose film was released from memory: read its final checkpoint.
    Checkpoint checkpoint =
        readCheckpoint(jobDirectory(jobId) + "/film.ckpt", width, height, units);
    snap.film = std::move(checkpoint.film);
    return snap;
}

// ---- workers -----------------------------------------------------------------------------------

uint64_t Coordinator::registerWorker(const v1::RegisterRequest& request) {
    // Units and results are only exchangeable between builds of the same major version.
    const std::string ours = ALPHORN_VERSION;
    const std::string theirs = request.version();
    if (!theirs.empty() && theirs.substr(0, theirs.find('.')) != ours.substr(0, ours.find('.')))
        throw FarmError(
            Kind::FailedPrecondition,
            absl::StrFormat("worker version %s cannot join a %s coordinator", theirs, ours));
    const auto rows = m_db.query(
        "INSERT INTO workers(name, cores, memory_bytes, version, registered_at) VALUES(?, ?, ?, ?, "
        "?) RETURNING id",
        {request.name(), int64_t(request.cores()), int64_t(request.memory_bytes()),
         request.version(), wallSeconds()});
    const uint64_t id = static_cast<uint64_t>(StateDatabase::integer(rows.at(0).at(0)));
    std::lock_guard lock(m_mutex);
    WorkerRecord& worker = m_workers[id];
    worker.info.set_worker_id(id);
    worker.info.set_name(request.name());
    worker.info.set_cores(request.cores());
    worker.info.set_memory_bytes(request.memory_bytes());
    worker.info.set_version(request.version());
    worker.lastSeen = Clock::now();
    worker.lastContactWall = wallSeconds();
    logInfo("worker.registered",
            {field("worker", id), field("name", request.name()), field("cores", request.cores()),
             field("version", request.version())});
    return id;
}

Coordinator::WorkerRecord* Coordinator::touchWorkerLocked(uint64_t workerId) {
    auto it = m_workers.find(workerId);
    if (it == m_workers.end()) return nullptr;
    it->second.lastSeen = Clock::now();
    it->second.lastContactWall = wallSeconds();
    return &it->second;
}

std::string Coordinator::leaseToken(uint64_t epoch, uint64_t leaseId, uint64_t workerId,
                                    uint64_t jobId, uint32_t unitIndex) const {
    uint64_t fields[5] = {epoch, leaseId, workerId, jobId, unitIndex};
    unsigned char mac[EVP_MAX_MD_SIZE];
    unsigned int macSize = 0;
    HMAC(EVP_sha256(), m_leaseKey.data(), int(m_leaseKey.size()),
         reinterpret_cast<const unsigned char*>(fields), sizeof fields, mac, &macSize);
    std::string token(reinterpret_cast<const char*>(&epoch), sizeof epoch);
    token.append(reinterpret_cast<const char*>(mac), macSize);
    return token;
}

bool Coordinator::leaseTokenValid(const std::string& token, uint64_t leaseId, uint64_t workerId,
                                  uint64_t jobId, uint32_t unitIndex) const {
    uint64_t epoch = 0;
    if (token.size() < sizeof epoch) return false;
    std::memcpy(&epoch, token.data(), sizeof epoch);
    if (epoch >= m_epoch) return false;  // this process's own leases are never re-adopted
    const std::string expected = leaseToken(epoch, leaseId, workerId, jobId, unitIndex);
    return token.size() == expected.size() &&
           CRYPTO_memcmp(token.data(), expected.data(), token.size()) == 0;
}

std::vector<v1::WorkerInfo> Coordinator::listWorkers(bool includeDead) {
    std::lock_guard lock(m_mutex);
    std::vector<v1::WorkerInfo> result;
    const auto now = Clock::now();
    for (const auto& [id, worker] : m_workers) {
        v1::WorkerInfo info = worker.info;
        const double since = std::chrono::duration<double>(now - worker.lastSeen).count();
        info.set_seconds_since_seen(since);
        info.set_leases(static_cast<uint32_t>(worker.leases.size()));
        info.set_alive(since < 3 * m_options.leaseSeconds);
        if (info.alive() || includeDead) result.push_back(std::move(info));
    }
    return result;
}

v1::AcquireWorkResponse Coordinator::acquire(uint64_t workerId, Clock::time_point until) {
    std::unique_lock lock(m_mutex);
    v1::AcquireWorkResponse response;
    for (;;) {
        WorkerRecord* worker = touchWorkerLocked(workerId);
        if (!worker)
            throw FarmError(Kind::NotFound,
                            absl::StrFormat("unknown worker %u: register again", workerId));
        if (m_stopping) return response;
        // Highest priority first, then the oldest job (FIFO).
        Job* best = nullptr;
        for (auto& [id, job] : m_jobs) {
            if (job->state != v1::JOB_STATE_RUNNING || job->pending.empty()) continue;
            if (!best ||
                job->description.settings().priority() > best->description.settings().priority())
                best = job.get();
        }
        if (best) {
            const uint32_t index = pickUnitLocked(*best, workerId);
            best->pending.erase(index);
            worker->lastChunk[best->id] = best->grid.chunkOf(index);
            UnitSlot& slot = best->units[index];
            slot.state = UnitState::Leased;
            slot.leaseId = m_nextLeaseId++;
            slot.workerId = workerId;
            slot.deadline =
                Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                   std::chrono::duration<double>(m_options.leaseSeconds));
            m_leases[slot.leaseId] = LeaseRef{best->id, index};
            worker->leases.insert(slot.leaseId);
            ++best->leasedThisRun;
            response.set_has_work(true);
            response.set_lease_id(slot.leaseId);
            *response.mutable_unit() = farm::toProto(best->id, index, best->grid.unit(index));
            *response.mutable_job() = best->description;
            response.set_lease_seconds(m_options.leaseSeconds);
            response.set_lease_token(leaseToken(m_epoch, slot.leaseId, workerId, best->id, index));
            return response;
        }
        if (m_workAvailable.wait_until(lock, until) == std::cv_status::timeout) {
            touchWorkerLocked(workerId);
            return response;
        }
    }
}

// Locality: a worker keeps the per-pass data (photon maps) of the passes it rendered last, so
// it gets another tile of the same pass chunk when one is pending; otherwise the first unit
// of a chunk no other live worker is on, so each chunk's photons are traced by one worker;
// only when every pending unit's chunk is taken does it share one (the end of a job).
uint32_t Coordinator::pickUnitLocked(const Job& job, uint64_t workerId) const {
    const farm::JobGrid& grid = job.grid;
    const auto firstOfChunk = [&](uint32_t chunk) {
        auto it = job.pending.lower_bound(chunk * grid.tileCount());
        return it != job.pending.end() && grid.chunkOf(*it) == chunk ? it : job.pending.end();
    };
    std::set<uint32_t> taken;
    const auto recent = Clock::now() - std::chrono::duration_cast<Clock::duration>(
                                           std::chrono::duration<double>(m_options.leaseSeconds));
    for (const auto& [id, worker] : m_workers) {
        auto chunk = worker.lastChunk.find(job.id);
        if (chunk == worker.lastChunk.end()) continue;
        if (id == workerId) {
            if (auto it = firstOfChunk(chunk->second); it != job.pending.end()) return *it;
        } else if (worker.lastSeen >= recent) {
            taken.insert(chunk->second);
        }
    }
    for (auto it = job.pending.begin(); it != job.pending.end();) {
        const uint32_t chunk = grid.chunkOf(*it);
        if (!taken.count(chunk)) return *it;
        it = job.pending.lower_bound((chunk + 1) * grid.tileCount());
    }
    return *job.pending.begin();
}

v1::HeartbeatResponse Coordinator::heartbeat(const v1::HeartbeatRequest& request) {
    std::lock_guard lock(m_mutex);
    v1::HeartbeatResponse response;
    WorkerRecord* worker = touchWorkerLocked(request.worker_id());
    if (!worker) {
        response.set_unknown_worker(true);
        for (uint64_t lease : request.lease_ids()) response.add_drop_lease_ids(lease);
        return response;
    }
    const auto deadline = Clock::now() + std::chrono::duration_cast<Clock::duration>(
                                             std::chrono::duration<double>(m_options.leaseSeconds));
    for (int i = 0; i < request.lease_ids_size(); ++i) {
        const uint64_t leaseId = request.lease_ids(i);
        auto it = m_leases.find(leaseId);
        bool valid = false;
        if (it == m_leases.end() && i < request.held_units_size()) {
            // A lease granted to this worker by an earlier coordinator process (the token says
            // so): re-adopt the unit if it is still waiting, so the worker's render is not
            // thrown away. Invented leases and leases that expired in this process are fenced.
            const v1::HeldUnit& held = request.held_units(i);
            auto job = m_jobs.find(held.job_id());
            if (job != m_jobs.end() && job->second->state == v1::JOB_STATE_RUNNING &&
                leaseTokenValid(held.lease_token(), leaseId, request.worker_id(), held.job_id(),
                                held.unit_index()) &&
                held.unit_index() < job->second->grid.unitCount() &&
                job->second->units[held.unit_index()].state == UnitState::Pending) {
                UnitSlot& slot = job->second->units[held.unit_index()];
                job->second->pending.erase(held.unit_index());
                slot.state = UnitState::Leased;
                slot.leaseId = leaseId;
                slot.workerId = request.worker_id();
                m_leases[leaseId] = LeaseRef{held.job_id(), held.unit_index()};
                worker->leases.insert(leaseId);
                logInfo("unit.readopted",
                        {field("job", held.job_id()), field("unit", held.unit_index()),
                         field("worker", request.worker_id()), field("lease", leaseId)});
                it = m_leases.find(leaseId);
            }
        }
        if (it != m_leases.end()) {
            Job& job = *m_jobs.at(it->second.jobId);
            UnitSlot& slot = job.units[it->second.unitIndex];
            if (slot.workerId == request.worker_id() && slot.state == UnitState::Leased) {
                slot.deadline = deadline;
                valid = true;
            }
        }
        // Fencing: the lease expired (and the unit may be someone else's now), or the unit is
        // merged or its job ended. The worker stops rendering it.
        if (!valid) response.add_drop_lease_ids(leaseId);
    }
    return response;
}

void Coordinator::releaseLeaseLocked(uint64_t leaseId) {
    auto it = m_leases.find(leaseId);
    if (it == m_leases.end()) return;
    Job& job = *m_jobs.at(it->second.jobId);
    UnitSlot& slot = job.units[it->second.unitIndex];
    if (auto worker = m_workers.find(slot.workerId); worker != m_workers.end())
        worker->second.leases.erase(leaseId);
    m_leases.erase(it);
}

void Coordinator::recordFailureLocked(Job& job, uint32_t unitIndex, const std::string& message) {
    UnitSlot& slot = job.units[unitIndex];
    ++slot.attempts;
    ++job.attemptsFailed;
    slot.lastError = message;
    try {
        m_db.execute(
            "INSERT INTO units(job_id, unit_index, attempts, last_error) VALUES(?, ?, ?, ?) "
            "ON CONFLICT(job_id, unit_index) DO UPDATE SET attempts = excluded.attempts, "
            "last_error = excluded.last_error",
            {int64_t(job.id), int64_t(unitIndex), int64_t(slot.attempts), message});
    } catch (const StorageError& e) {
        // The unit goes back in the queue all the same; only the count may restart from less.
        logWarning("unit.attempt_not_recorded",
                   {field("job", job.id), field("unit", unitIndex), field("error", e.what())});
    }
    logWarning("unit.failed", {field("job", job.id), field("unit", unitIndex),
                               field("attempt", slot.attempts), field("error", message)});
    if (slot.attempts >= m_options.maxAttempts) {
        // A poison unit: it fails its job, never the farm.
        try {
            endJobLocked(job, v1::JOB_STATE_FAILED,
                         absl::StrFormat("unit %u failed %u times (the limit); last error: %s",
                                         unitIndex, slot.attempts, message));
        } catch (const StorageError& e) {
            logWarning("job.end_not_recorded", {field("job", job.id), field("error", e.what())});
        }
        return;
    }
    job.pending.insert(unitIndex);
    m_workAvailable.notify_all();
}

void Coordinator::expireLeases() {
    std::lock_guard lock(m_mutex);
    const auto now = Clock::now();
    std::vector<uint64_t> expired;
    for (const auto& [leaseId, ref] : m_leases) {
        const UnitSlot& slot = m_jobs.at(ref.jobId)->units[ref.unitIndex];
        if (slot.deadline < now) expired.push_back(leaseId);
    }
    for (uint64_t leaseId : expired) {
        auto it = m_leases.find(leaseId);
        if (it == m_leases.end()) continue;  // the job ended while handling an earlier lease
        const LeaseRef ref = it->second;
        Job& job = *m_jobs.at(ref.jobId);
        UnitSlot& slot = job.units[ref.unitIndex];
        const uint64_t workerId = slot.workerId;
        releaseLeaseLocked(leaseId);
        slot.state = UnitState::Pending;
        std::string workerName;
        if (auto worker = m_workers.find(workerId); worker != m_workers.end())
            workerName = worker->second.info.name();
        recordFailureLocked(
            job, ref.unitIndex,
            absl::StrFormat("lease expired: worker %u (%s) stopped responding while rendering "
                            "unit %u (crashed, hung or lost its network)",
                            workerId, workerName, ref.unitIndex));
    }
}

uint64_t Coordinator::maxResultBytes(uint64_t jobId) const {
    std::lock_guard lock(m_mutex);
    auto it = m_jobs.find(jobId);
    if (it == m_jobs.end()) return 0;
    const Job& job = *it->second;
    // The largest unit block: a full tile plus the filter border on each side.
    const uint64_t side =
        uint64_t(job.description.settings().tile_size()) + 2 * uint64_t(job.filterBorder);
    return ZSTD_compressBound(side * side * sizeof(PixelSum)) + 4096;
}

v1::ResultDisposition Coordinator::report(const v1::ResultChunk& header,
                                          const std::string& compressedFilm) {
    const uint64_t jobId = header.job_id();
    const uint32_t unitIndex = header.unit_index();
    RenderUnit unit;
    int border = 0;
    {
        std::lock_guard lock(m_mutex);
        if (!touchWorkerLocked(header.worker_id()))
            throw FarmError(Kind::NotFound, absl::StrFormat("unknown worker %u: register again",
                                                            header.worker_id()));
        Job& job = jobLocked(jobId);
        if (unitIndex >= job.grid.unitCount())
            throw FarmError(Kind::InvalidArgument,
                            absl::StrFormat("job %u has no unit %u", jobId, unitIndex));
        UnitSlot& slot = job.units[unitIndex];
        const bool ownsLease = slot.state == UnitState::Leased && slot.leaseId == header.lease_id();
        if (!header.error().empty() || header.handed_back()) {
            // Failures and hand-backs only count from the current holder of the lease.
            if (!ownsLease || job.state != v1::JOB_STATE_RUNNING) return v1::RESULT_DISCARDED;
            releaseLeaseLocked(slot.leaseId);
            slot.state = UnitState::Pending;
            if (header.handed_back()) {
                logInfo("unit.handed_back", {field("job", jobId), field("unit", unitIndex),
                                             field("worker", header.worker_id())});
                job.pending.insert(unitIndex);
                m_workAvailable.notify_all();
            } else {
                recordFailureLocked(
                    job, unitIndex,
                    absl::StrFormat("worker %u: %s", header.worker_id(), header.error()));
            }
            return v1::RESULT_RECORDED;
        }
        // Fencing: a unit merged already, reassigned to another worker, or of an ended job is
        // dropped. Results are idempotent by unit id: a unit is merged at most once.
        if (job.state != v1::JOB_STATE_RUNNING || slot.state == UnitState::Merged ||
            (slot.state == UnitState::Leased && !ownsLease)) {
            ++job.discarded;
            logInfo("result.discarded",
                    {field("job", jobId), field("unit", unitIndex),
                     field("worker", header.worker_id()), field("lease", header.lease_id())});
            return v1::RESULT_DISCARDED;
        }
        unit = job.grid.unit(unitIndex);
        border = job.filterBorder;
    }

    // Check and decompress outside the lock: this is the expensive part.
    FilmBlock block(unit.tile.x0 - border, unit.tile.y0 - border, unit.tile.width() + 2 * border,
                    unit.tile.height() + 2 * border);
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

    bool complete = false;
    Job* jobPointer = nullptr;
    {
        std::lock_guard lock(m_mutex);
        Job& job = jobLocked(jobId);
        UnitSlot& slot = job.units[unitIndex];
        const bool ownsLease = slot.state == UnitState::Leased && slot.leaseId == header.lease_id();
        if (job.state != v1::JOB_STATE_RUNNING || slot.state == UnitState::Merged ||
            (slot.state == UnitState::Leased && !ownsLease)) {
            ++job.discarded;
            return v1::RESULT_DISCARDED;
        }
        if (slot.state == UnitState::Leased) releaseLeaseLocked(slot.leaseId);
        job.pending.erase(unitIndex);  // a result from an earlier lease of a requeued unit
        job.film.add(block);
        slot.state = UnitState::Merged;
        job.merged[unitIndex] = true;
        ++job.mergedCount;
        ++job.mergedThisRun;
        if (!job.firstMergeAt) job.firstMergeAt = Clock::now();
        if (header.built_pass_data()) job.passDataBuilds += unit.passEnd - unit.passBegin;
        job.samplesMergedThisRun +=
            uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
        if (auto worker = m_workers.find(header.worker_id()); worker != m_workers.end())
            worker->second.info.set_units_merged(worker->second.info.units_merged() + 1);
        if (job.mergedCount == job.grid.unitCount()) {
            job.completing = true;
            complete = true;
            jobPointer = &job;
        }
    }
    if (complete) finishJob(*jobPointer);
    return v1::RESULT_MERGED;
}

void Coordinator::finishJob(Job& job) {
    FilmBlock film;
    std::vector<bool> merged;
    uint32_t count;
    {
        std::lock_guard lock(m_mutex);
        film = job.film;
        merged = job.merged;
        count = job.mergedCount;
    }
    // The final film is on disk before the job is reported done.
    bool written = false;
    try {
        writeJobCheckpoint(job, film, merged, count);
        written = true;
    } catch (const std::exception& e) {
        logWarning("checkpoint.failed",
                   {field("job", job.id), field("final", "yes"), field("error", e.what())});
    }
    std::lock_guard lock(m_mutex);
    if (written && job.state == v1::JOB_STATE_RUNNING) {
        try {
            endJobLocked(job, v1::JOB_STATE_DONE, "");
        } catch (const std::exception& e) {
            logWarning("job.end_not_recorded", {field("job", job.id), field("error", e.what())});
        }
        job.film = FilmBlock();  // served from the checkpoint from now on; memory stays flat
    }
    job.completing = false;
}

void Coordinator::writeJobCheckpoint(Job& job, const FilmBlock& film,
                                     const std::vector<bool>& merged, uint32_t count) {
    std::lock_guard checkpointLock(job.checkpointMutex);
    {
        std::lock_guard lock(m_mutex);
        // Merges only add units, so a higher count is a newer film; never overwrite it.
        if (count < job.checkpointedCount || (count == job.checkpointedCount && count > 0)) return;
    }
    const auto start = Clock::now();
    try {
        writeCheckpoint(jobDirectory(job.id) + "/film.ckpt", film, merged);
    } catch (const std::exception& e) {
        std::lock_guard lock(m_mutex);
        job.checkpointError = e.what();
        throw;
    }
    std::lock_guard lock(m_mutex);
    job.checkpointError.clear();
    job.checkpointedCount = count;
    ++job.checkpointsWritten;
    logInfo("checkpoint.written",
            {field("job", job.id), field("units_merged", count),
             field("units_total", job.grid.unitCount()),
             field("ms",
                   absl::StrFormat(
                       "%.1f",
                       std::chrono::duration<double, std::milli>(Clock::now() - start).count()))});
}

void Coordinator::checkpointDirtyJobs() {
    struct Pending {
        Job* job;
        FilmBlock film;
        std::vector<bool> merged;
        uint32_t count;
    };
    std::vector<Job*> dirty, complete;
    {
        std::lock_guard lock(m_mutex);
        for (auto& [id, job] : m_jobs) {
            if (job->state != v1::JOB_STATE_RUNNING || job->completing) continue;
            if (job->mergedCount == job->grid.unitCount()) {
                // Its final checkpoint failed before: try again.
                job->completing = true;
                complete.push_back(job.get());
            } else if (job->mergedCount > job->checkpointedCount) {
                dirty.push_back(job.get());
            }
        }
    }
    for (Job* job : complete) finishJob(*job);
    // One job at a time, so at most one extra film copy is in memory.
    for (Job* job : dirty) {
        Pending pending{job, {}, {}, 0};
        {
            std::lock_guard lock(m_mutex);
            if (job->state != v1::JOB_STATE_RUNNING || job->completing) continue;
            pending.film = job->film;
            pending.merged = job->merged;
            pending.count = job->mergedCount;
        }
        try {
            writeJobCheckpoint(*job, pending.film, pending.merged, pending.count);
        } catch (const std::exception& e) {
            logWarning("checkpoint.failed", {field("job", job->id), field("error", e.what())});
        }
    }
}

}  // namespace alphorn::coordinator
