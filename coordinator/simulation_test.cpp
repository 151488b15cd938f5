// Deterministic simulation of the coordinator core. Each seed is one random schedule driven
// through the real Coordinator (its store, scheduler and films, on a state directory in a temp
// directory) with a clock that moves only when the simulation says so, and simulated workers that
// deliver synthetic unit results: the film of a unit is a pure function of (the job id the worker
// was told, unit, pass), so the expected final film of a job is the direct sum over its units.
// Schedules mix worker crashes, hangs with late returns, duplicate and late results, failures and
// hand-backs, results for cancelled jobs, several jobs with priorities, cancels, retention (ended
// jobs, their blobs and silent workers forgotten after a keep time chosen per seed), a full disk
// (also on submit and on a worker's registration), coordinator crashes (the state directory
// copied as it is on disk, between two steps or right after a durable write inside one, e.g.
// inside a submission, then reopened) and graceful restarts. After every step the invariants are
// checked (checkInvariants, checkStorage, restarted); a failing seed prints its number and its
// last steps, and replays with --seed (or ALPHORN_SIM_SEED).
//
// Usage: alphorn_coordinator_simulation [--seeds N] [--first-seed S] [--seed S] [--steps K]
//        [--verbose]
#include "common/farm/build_identity.h"
#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/sha256.h"
#include "common/render/local_render.h"
#include "common/scene/accel.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "coordinator/coordinator.h"
#include "coordinator/log.h"
#include "tests/support/source_tree.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

// splitmix64: fully specified, so a seed gives the same schedule with every compiler and library.
class Random {
  public:
    explicit Random(uint64_t seed) : m_state(seed) {}
    uint64_t next() {
        uint64_t z = (m_state += 0x9e3779b97f4a7c15ull);
        z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
        z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
        return z ^ (z >> 31);
    }
    uint32_t below(uint32_t n) { return uint32_t(next() % n); }
    bool chance(uint32_t percent) { return below(100) < percent; }

  private:
    uint64_t m_state;
};

uint64_t mix(uint64_t a, uint64_t b) {
    Random random(a * 0x9e3779b97f4a7c15ull ^ b);
    return random.next();
}

// The synthetic result of a unit as a worker told `jobId` would deliver it: the unit's block
// (tile plus filter border) with, for each pass, a small sample per pixel.
FilmBlock unitResult(uint64_t jobId, const RenderUnit& unit, int border) {
    FilmBlock block(unit.tile.x0 - border, unit.tile.y0 - border, unit.tile.width() + 2 * border,
                    unit.tile.height() + 2 * border);
    for (uint32_t pass = unit.passBegin; pass < unit.passEnd; ++pass)
        for (int y = block.y0(); y < block.y0() + block.height(); ++y)
            for (int x = block.x0(); x < block.x0() + block.width(); ++x) {
                const uint64_t h = mix(mix(jobId, pass), uint64_t(x) << 32 | uint32_t(y));
                PixelSum& sum = block.at(x, y);
                for (int c = 0; c < 3; ++c) sum.rgb[c] += FixedPoint((h >> (16 * c)) & 0xffff);
                sum.weight += 1;
            }
    return block;
}

std::string g_log;  // the coordinator's log lines of the current seed
// What the schedules covered, over all seeds (printed at the end, so a change that makes the
// simulation skip a case shows).
std::map<std::string, uint64_t> g_coverage;
void collectLog(const std::string& line) {
    g_log += line;
}

struct Options {
    uint64_t firstSeed = 1;
    uint64_t seeds = 1;
    int steps = 120;
    bool verbose = false;
};

class Simulation {
  public:
    Simulation(uint64_t seed, const Options& options, const fs::path& root,
               const fs::path& sceneDirectory, int border)
        : m_options(options),
          m_random(seed),
          m_root(root),
          m_sceneDirectory(sceneDirectory),
          m_border(border),
          m_clock(std::make_shared<ManualClock>(kWallStart)) {}

    ~Simulation() {
        m_coordinator.reset();
        std::error_code ignored;
        fs::remove_all(m_root, ignored);
    }

    // Runs the schedule; returns an empty string or what went wrong.
    std::string run() {
        try {
            fs::remove_all(m_root);
            fs::create_directories(m_root);
            // Retention off, or a keep time short enough to act within a schedule.
            const double keeps[] = {0, 20, 45};
            m_keep = keeps[m_random.below(3)];
            note(absl::StrFormat("retention keeps ended jobs %.0f s", m_keep));
            open(stateDirectory());
            m_workers.resize(3);
            for (SimWorker& worker : m_workers) registerWorker(worker);
            submit();
            for (int step = 0; step < m_options.steps; ++step) {
                m_submittedThisStep.clear();
                randomStep();
                if (m_crashTaken) crashAtCopiedPoint();
                checkInvariants();
            }
            m_crashCountdown = -1;
            m_diskFull = false;
            drain();
        } catch (const Violation& violation) {
            return violation.what;
        } catch (const std::exception& e) {
            return std::string("unexpected exception: ") + e.what();
        }
        return "";
    }

    const std::vector<std::string>& trace() const { return m_trace; }

  private:
    struct Violation {
        std::string what;
    };
    struct SimJob {
        uint64_t id = 0;
        farm::JobGrid grid;
        FilmBlock expected;
        v1::JobState state = v1::JOB_STATE_RUNNING;
        std::set<uint32_t> merged;  // units merged in the current coordinator process or restored
        // Units whose result was held for an audit (RESULT_HELD) and not seen merged yet: the
        // coordinator merges one later without an answer to anyone when no other worker is left
        // to audit it (settleHeldResults).
        std::set<uint32_t> held;
        uint32_t durable = 0;  // units in the last checkpoint written
        uint32_t checkpointsSeen = 0;
        bool cancelRequested = false;
        bool paused = false;  // a client paused it: no new leases
        // It ended while the disk was full: the store may not know, and a restart may find it
        // running again (the uncommitted step a restart may lose).
        bool endUncommitted = false;
        bool imageChecked = false;
        std::vector<std::string> blobs;  // its bundle's files (SHA-256)
        double endedAt = 0;              // wall clock when it was seen to end; 0 while running
        bool pruned = false;             // removed by retention
    };
    struct HeldLease {
        v1::AcquireWorkResponse lease;
        bool toldToDrop = false;
    };
    struct SimWorker {
        uint64_t id = 0;
        std::vector<HeldLease> leases;
        // The last result delivered, to deliver again (a duplicate or a late retry).
        std::optional<std::pair<v1::ResultChunk, std::string>> lastResult;
        bool drained = false;  // a client drained it: no new leases
        double lastCall = 0;   // wall clock of its last call the coordinator answered
    };
    // Where the coordinator dies inside a submission: after the client uploaded the blobs but
    // before it submitted, or right after the job's record or its directory was written.
    enum class SubmitCrash { None, AfterUpload, AfterRecord, AfterDirectory };
    // Retention removes what expired at most one prune interval (a minute) plus one step (the
    // longest advance is 15 s) after it expired.
    static constexpr double kRetentionLag = 60 + 16;
    static constexpr double kWallStart = 1.7e9;  // the manual clock's wall time at t=0

    [[noreturn]] void violate(const std::string& what) { throw Violation{what}; }
    void note(const std::string& line) {
        for (const char* event : {"RESULT_MERGED",
                                  "RESULT_HELD",
                                  "RESULT_DISCARDED",
                                  "RESULT_RECORDED",
                                  "crash and restart",
                                  "graceful stop",
                                  "crash inside the step",
                                  "crashes",
                                  "cancel job",
                                  "late for",
                                  "duplicate for",
                                  "disk full",
                                  "pause job",
                                  "resume job",
                                  "drain worker",
                                  "end the drain of worker",
                                  "removed by retention",
                                  "was forgotten",
                                  "submit refused",
                                  "register refused",
                                  "after the upload",
                                  "after the job's record",
                                  "after the job's directory",
                                  "not in the store",
                                  "result for removed job",
                                  "held result merged unaudited"})
            if (line.find(event) != std::string::npos) ++g_coverage[event];
        m_trace.push_back(absl::StrFormat("t=%.1f %s", m_clock->monotonicSeconds(), line));
    }

    fs::path stateDirectory() const { return m_root / ("state" + std::to_string(m_generation)); }

    void open(const fs::path& directory) {
        CoordinatorOptions options;
        options.stateDirectory = directory.string();
        options.leaseSeconds = 10;
        options.checkpointIntervalSeconds = 5;
        options.maxAttempts = 4;
        // The simulation's clock jumps up to 15 s between ticks to stand for time that passed
        // while the coordinator ran: no stall (tested on its own in coordinator_test.cpp).
        options.stallSeconds = std::numeric_limits<double>::infinity();
        options.keepFinishedSeconds = m_keep;
        options.maxMemoryBytes = uint64_t(1) << 30;
        m_coordinator = std::make_unique<Coordinator>(options, m_clock);
        m_coordinator->setDurableWriteHooks({[this] {
                                                 if (m_diskFull)
                                                     throw StorageError(
                                                         "No space left on device (simulated)");
                                             },
                                             [this] { durableWrite(); }});
        for (auto& [id, job] : m_jobs) job.checkpointsSeen = 0;
    }

    // Registers the worker (again). On a full disk the coordinator refuses, leaving no worker
    // behind, and the worker stays unregistered (id 0) and tries again at its next step.
    void registerWorker(SimWorker& worker) {
        worker = SimWorker();
        const size_t known = m_coordinator->listWorkers(true).size();
        v1::RegisterRequest request;
        farm::describeThisBuild(request);
        request.set_name("sim");
        try {
            worker.id = m_coordinator->registerWorker(request);
        } catch (const StorageError& e) {
            if (!m_diskFull) throw;
            note(absl::StrFormat("register refused: %s", e.what()));
            if (m_coordinator->listWorkers(true).size() != known)
                violate("a refused registration left a worker behind");
            return;
        }
        if (m_diskFull) violate(absl::StrFormat("worker %u registered on a full disk", worker.id));
        m_registeredWorkers.insert(worker.id);
        worker.lastCall = m_clock->wallSeconds();
        note(absl::StrFormat("worker %u registered", worker.id));
    }

    // The coordinator does not know the worker: only retention may forget a worker, after the
    // keep time without a call. The worker registers again, as a restarted one.
    void forgotten(SimWorker& worker) {
        if (!(m_keep > 0) || worker.lastCall + m_keep > m_clock->wallSeconds())
            violate(absl::StrFormat("worker %u unknown %.1f s after its last call (keep %.0f s)",
                                    worker.id, m_clock->wallSeconds() - worker.lastCall, m_keep));
        note(absl::StrFormat("worker %u was forgotten; it registers again", worker.id));
        registerWorker(worker);
    }

    // The job's status, or nothing when the coordinator does not list it.
    std::optional<v1::JobStatus> findJob(uint64_t jobId) {
        try {
            return m_coordinator->listJobs(jobId).at(0);
        } catch (const FarmError& e) {
            if (e.kind != FarmError::Kind::NotFound) throw;
            return std::nullopt;
        }
    }

    // The coordinator no longer lists the job: only retention may remove a job, an ended one,
    // after its keep time.
    void jobRemoved(SimJob& job) {
        const double now = m_clock->wallSeconds();
        if (job.state == v1::JOB_STATE_RUNNING)
            violate(absl::StrFormat("running job %u vanished", job.id));
        if (!(m_keep > 0))
            violate(absl::StrFormat("job %u removed, but retention keeps everything", job.id));
        if (now < job.endedAt + m_keep)
            violate(absl::StrFormat("job %u removed %.1f s after it ended (keep %.0f s)", job.id,
                                    now - job.endedAt, m_keep));
        job.pruned = true;
        note(absl::StrFormat("job %u removed by retention", job.id));
    }

    void submit(SubmitCrash crash = SubmitCrash::None) {
        // Three scenes that share the mesh and differ in the scene file, so retention has blobs
        // of one job only and blobs of several.
        const std::string scene = "s" + std::to_string(m_random.below(3)) + ".xml";
        farm::Bundle bundle = farm::gatherBundle((m_sceneDirectory / scene).string());
        const double now = m_clock->wallSeconds();
        std::vector<std::string> blobs;
        for (const auto& file : bundle.files) blobs.push_back(file.sha256);
        // As the CLI does: it asks which blobs are missing (which marks them as about to be
        // used), then uploads those.
        m_coordinator->touchBlobs(blobs);
        for (const std::string& sha : blobs) m_blobTouchedAt[sha] = now;
        for (const auto& file : bundle.files) {
            if (m_coordinator->blobs().has(file.sha256)) continue;
            BlobStore::Upload blob(m_coordinator->blobs(), file.sha256);
            blob.append(farm::readFile(file.sourcePath));
            blob.commit();
            // A blob's age is its file's time: the simulated clock's, so that retention decides
            // the same on every run.
            fs::last_write_time(m_coordinator->blobs().pathOf(file.sha256),
                                std::chrono::time_point_cast<fs::file_time_type::duration>(
                                    std::chrono::file_clock::from_sys(std::chrono::sys_seconds(
                                        std::chrono::seconds(int64_t(now))))));
            m_blobStoredAt[file.sha256] = now;
        }
        if (crash == SubmitCrash::AfterUpload) {
            note("coordinator crash after the upload, before the submission");
            crashCoordinator();
            return;
        }
        if (crash != SubmitCrash::None) {
            // Its first durable write is the job's record, the second its directory.
            m_crashCountdown = crash == SubmitCrash::AfterRecord ? 0 : 1;
            note(crash == SubmitCrash::AfterRecord
                     ? "a crash is due right after the job's record is written"
                     : "a crash is due right after the job's directory is written");
        }
        v1::SubmitJobRequest request;
        *request.mutable_bundle() = farm::toProto(bundle);
        request.mutable_settings()->set_passes(1 + m_random.below(3));
        // 0 asks for the default; more than the passes means one chunk.
        const uint32_t passesPerUnit[] = {1, 2, 0, UINT32_MAX};
        request.mutable_settings()->set_passes_per_unit(passesPerUnit[m_random.below(4)]);
        request.mutable_settings()->set_tile_size(4 + 2 * m_random.below(2));
        request.mutable_settings()->set_priority(int(m_random.below(3)));
        request.mutable_settings()->set_seed(7);
        const size_t jobsBefore = m_coordinator->listJobs(0).size();
        v1::JobStatus status;
        try {
            status = m_coordinator->submit(request);
        } catch (const FarmError& e) {
            if (!m_diskFull || e.kind != FarmError::Kind::ResourceExhausted) throw;
            note(absl::StrFormat("submit refused: %s", e.what()));
            if (m_coordinator->listJobs(0).size() != jobsBefore)
                violate("a refused submission left a job behind");
            return;
        }
        if (m_diskFull) violate(absl::StrFormat("job %u accepted on a full disk", status.job_id()));
        // The submission consumed the marks of its blobs.
        for (const std::string& sha : blobs) m_blobTouchedAt.erase(sha);
        SimJob job;
        job.id = status.job_id();
        job.blobs = blobs;
        m_submittedThisStep.insert(job.id);
        const v1::JobSettings& settings = status.settings();
        // The units' blocks are not checked here: no border.
        job.grid = farm::JobGrid(
            TileGrid(int(status.width()), int(status.height()), int(settings.tile_size()), 0),
            settings.passes(), settings.passes_per_unit());
        // The units cover the image's every pixel with every pass (a job of no units would be
        // "done" at once, with an empty film).
        uint64_t samples = 0;
        for (uint32_t i = 0; i < job.grid.unitCount(); ++i) {
            const RenderUnit unit = job.grid.unit(i);
            samples +=
                uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
        }
        if (samples != uint64_t(status.width()) * status.height() * settings.passes())
            violate(
                absl::StrFormat("job %u: its %u units hold %u samples, the image needs %u", job.id,
                                job.grid.unitCount(), samples,
                                uint64_t(status.width()) * status.height() * settings.passes()));
        job.expected = FilmBlock(0, 0, job.grid.width(), job.grid.height());
        for (uint32_t i = 0; i < job.grid.unitCount(); ++i)
            job.expected.add(unitResult(job.id, job.grid.unit(i), m_border));
        note(absl::StrFormat("submit: job %u, %u units, priority %d", job.id, job.grid.unitCount(),
                             settings.priority()));
        m_jobs[job.id] = std::move(job);
    }

    void acquire(SimWorker& worker) {
        v1::AcquireWorkResponse lease;
        try {
            lease = m_coordinator->acquire(worker.id, std::chrono::steady_clock::now());
        } catch (const FarmError& e) {
            if (e.kind != FarmError::Kind::UnknownWorker) throw;
            forgotten(worker);
            return;
        }
        worker.lastCall = m_clock->wallSeconds();
        if (!lease.has_work()) {
            note(absl::StrFormat("worker %u: no work", worker.id));
            return;
        }
        if (worker.drained)
            violate(absl::StrFormat("drained worker %u was leased a unit", worker.id));
        const uint64_t jobId = lease.unit().job_id();
        note(absl::StrFormat("worker %u: leased job %u unit %u (lease %u)", worker.id, jobId,
                             lease.unit().unit_index(), lease.lease_id()));
        // Workers know a job (and cache its scene) by the id in its description.
        if (lease.job().job_id() != jobId)
            violate(absl::StrFormat("a unit of job %u came with the description of job %u", jobId,
                                    lease.job().job_id()));
        auto job = m_jobs.find(jobId);
        if (job == m_jobs.end()) violate(absl::StrFormat("a lease of unknown job %u", jobId));
        if (job->second.state != v1::JOB_STATE_RUNNING)
            violate(absl::StrFormat("a lease of ended job %u", jobId));
        if (job->second.paused) violate(absl::StrFormat("a lease of paused job %u", jobId));
        if (job->second.merged.count(lease.unit().unit_index()))
            violate(absl::StrFormat("a lease of merged unit %u of job %u",
                                    lease.unit().unit_index(), jobId));
        // Priorities: no running job of a higher priority has a pending unit.
        const int priority = lease.job().settings().priority();
        for (const auto& [id, other] : m_jobs) {
            if (other.state != v1::JOB_STATE_RUNNING || id == jobId) continue;
            const v1::JobStatus status = m_coordinator->listJobs(id).at(0);
            if (status.paused()) continue;
            // A unit of the higher job open to this worker: not one held for an audit that it
            // rendered, nor any while its own first result of that job waits for its audit.
            bool open = false;
            m_coordinator->inspect([&](const LeaseScheduler& scheduler) {
                open = scheduler.couldLease(worker.id, id);
            });
            if (status.settings().priority() > priority && open)
                violate(
                    absl::StrFormat("job %u (priority %d) leased while job %u (priority %d) "
                                    "has pending units",
                                    jobId, priority, id, status.settings().priority()));
        }
        worker.leases.push_back(HeldLease{lease});
    }

    // Delivers the result of the worker's lease `index`, as a worker does: the unit rendered for
    // the job its description names.
    void deliver(SimWorker& worker, size_t index, bool fail, bool handBack) {
        const HeldLease held = worker.leases[index];
        worker.leases.erase(worker.leases.begin() + long(index));
        const v1::AcquireWorkResponse& lease = held.lease;
        const RenderUnit unit = farm::fromProto(lease.unit());
        v1::ResultChunk header;
        header.set_worker_id(worker.id);
        header.set_lease_id(lease.lease_id());
        header.set_job_id(lease.unit().job_id());
        header.set_unit_index(lease.unit().unit_index());
        std::string compressed;
        if (fail) {
            header.set_error("simulated failure");
        } else if (handBack) {
            header.set_handed_back(true);
        } else {
            const FilmBlock block = unitResult(lease.job().job_id(), unit, m_border);
            compressed = farm::compressFilm(block);
            header.set_block_x0(block.x0());
            header.set_block_y0(block.y0());
            header.set_block_width(block.width());
            header.set_block_height(block.height());
            header.set_compressed_size(compressed.size());
            header.set_compressed_sha256(farm::sha256Hex(compressed));
            worker.lastResult = std::make_pair(header, compressed);
        }
        report(worker, header, compressed,
               fail              ? "failure"
               : handBack        ? "hand-back"
               : held.toldToDrop ? "late"
                                 : "result");
    }

    void report(SimWorker& worker, const v1::ResultChunk& header, const std::string& compressed,
                const std::string& kind) {
        const uint64_t jobId = header.job_id();
        const uint32_t unit = header.unit_index();
        v1::ResultDisposition disposition;
        try {
            disposition = m_coordinator->report(header, compressed);
        } catch (const FarmError& e) {
            if (e.kind == FarmError::Kind::UnknownWorker) {
                forgotten(worker);
                return;
            }
            // A result for a job retention removed meanwhile: the worker drops it.
            if (e.kind != FarmError::Kind::NotFound || !m_jobs.at(jobId).pruned) throw;
            note(
                absl::StrFormat("worker %u: %s result for removed job %u", worker.id, kind, jobId));
            return;
        }
        worker.lastCall = m_clock->wallSeconds();
        note(absl::StrFormat("worker %u: %s for job %u unit %u (lease %u): %s", worker.id, kind,
                             jobId, unit, header.lease_id(),
                             v1::ResultDisposition_Name(disposition)));
        SimJob& job = m_jobs.at(jobId);
        if (disposition == v1::RESULT_MERGED) {
            if (job.merged.count(unit))
                violate(absl::StrFormat("job %u unit %u merged twice", jobId, unit));
            if (job.cancelRequested)
                violate(absl::StrFormat("a result merged into cancelled job %u", jobId));
            job.merged.insert(unit);
            job.held.erase(unit);
        } else if (disposition == v1::RESULT_HELD) {
            job.held.insert(unit);
        }
    }

    // Held results the coordinator merged unaudited (nobody else alive to render the unit
    // again) count as merged from the moment the scheduler says so.
    void settleHeldResults() {
        for (auto& [id, job] : m_jobs) {
            if (job.pruned || job.held.empty() || !findJob(id)) continue;
            const uint64_t jobId = id;
            std::vector<uint32_t> settled;
            m_coordinator->inspect([&](const LeaseScheduler& scheduler) {
                for (uint32_t unit : job.held)
                    if (scheduler.unit(jobId, unit).state == LeaseScheduler::UnitState::Merged)
                        settled.push_back(unit);
            });
            for (uint32_t unit : settled) {
                if (job.merged.count(unit))
                    violate(absl::StrFormat("job %u unit %u merged twice", id, unit));
                job.merged.insert(unit);
                job.held.erase(unit);
                note(absl::StrFormat("job %u unit %u: held result merged unaudited", id, unit));
            }
        }
    }

    void heartbeat(SimWorker& worker) {
        v1::HeartbeatRequest request;
        request.set_worker_id(worker.id);
        for (const HeldLease& held : worker.leases) {
            request.add_lease_ids(held.lease.lease_id());
            v1::HeldUnit& unit = *request.add_held_units();
            unit.set_job_id(held.lease.unit().job_id());
            unit.set_unit_index(held.lease.unit().unit_index());
            unit.set_lease_token(held.lease.lease_token());
        }
        const v1::HeartbeatResponse response = m_coordinator->heartbeat(request);
        if (response.unknown_worker()) {
            forgotten(worker);
            return;
        }
        worker.lastCall = m_clock->wallSeconds();
        std::set<uint64_t> dropped(response.drop_lease_ids().begin(),
                                   response.drop_lease_ids().end());
        note(absl::StrFormat("worker %u: heartbeat for %u leases, %u dropped", worker.id,
                             worker.leases.size(), dropped.size()));
        for (auto it = worker.leases.begin(); it != worker.leases.end();) {
            if (dropped.count(it->lease.lease_id())) {
                // Most workers stop; some are slow to notice and deliver late.
                if (m_random.chance(70)) {
                    it = worker.leases.erase(it);
                    continue;
                }
                it->toldToDrop = true;
            }
            ++it;
        }
    }

    void advance(double seconds) {
        m_clock->advance(seconds);
        m_coordinator->tick();
        note(absl::StrFormat("clock +%.1f s, tick", seconds));
    }

    // The state directory as a crash leaves it on disk, blobs with their times (retention reads
    // a blob's age from its file's time, which a copy would reset).
    static void copyStateDirectory(const fs::path& from, const fs::path& to) {
        fs::copy(from, to, fs::copy_options::recursive);
        for (const auto& entry : fs::recursive_directory_iterator(from / "blobs"))
            if (entry.is_regular_file())
                fs::last_write_time(to / fs::relative(entry.path(), from),
                                    fs::last_write_time(entry.path()));
    }

    // The coordinator process dies between two steps: its state directory as it is on disk is
    // what the next process starts from. (The old object then stops, writing only to its own,
    // abandoned directory.)
    void crashCoordinator() {
        m_coordinator->setDurableWriteHooks({});
        const fs::path from = stateDirectory();
        ++m_generation;
        copyStateDirectory(from, stateDirectory());
        fs::remove(stateDirectory() / "lock");
        settleHeldResults();
        m_coordinator.reset();
        note("coordinator crash and restart");
        restarted(true);
    }

    // A crash inside a step, right after the coordinator's `m_crashCountdown`th next durable
    // write (e.g. between a final checkpoint and the job's end in the store): the state directory
    // is copied at that moment; the step finishes in the doomed process, whose replies the
    // simulated clients and workers still see (a superset of what really reaches them), and the
    // next process starts from the copy.
    void durableWrite() {
        if (m_crashCountdown < 0 || m_crashTaken || m_crashCountdown-- > 0) return;
        copyStateDirectory(stateDirectory(), m_root / ("state" + std::to_string(m_generation + 1)));
        m_crashTaken = true;
    }

    void crashAtCopiedPoint() {
        m_crashTaken = false;
        m_crashCountdown = -1;
        m_coordinator->setDurableWriteHooks({});
        settleHeldResults();
        m_coordinator.reset();
        ++m_generation;
        fs::remove(stateDirectory() / "lock");
        note("coordinator crash inside the step, restarted from the state at that point");
        restarted(true);
    }

    void restartCoordinator() {
        m_coordinator->stop();
        if (m_crashTaken) return;  // it crashed while stopping: after the step
        settleHeldResults();
        m_coordinator.reset();
        note("coordinator graceful stop and restart");
        // With a full disk the stop could not checkpoint: as after a crash.
        restarted(m_diskFull);
    }

    // After a restart: every ended job is as it was; a running job lost at most the units merged
    // since its last checkpoint (all of them after a graceful stop), and has no unit it did not
    // have.
    void restarted(bool crashed) {
        std::map<uint64_t, uint32_t> mergedBefore;
        for (auto& [id, job] : m_jobs) mergedBefore[id] = uint32_t(job.merged.size());
        open(stateDirectory());
        for (auto it = m_jobs.begin(); it != m_jobs.end();) {
            SimJob& job = it->second;
            const std::optional<v1::JobStatus> found = job.pruned ? std::nullopt : findJob(job.id);
            if (!found && !job.pruned) {
                if (m_submittedThisStep.count(job.id)) {
                    // Its submission was the uncommitted step: the client got no answer.
                    note(
                        absl::StrFormat("job %u, submitted in the step of the crash, is not in "
                                        "the store",
                                        job.id));
                    it = m_jobs.erase(it);
                    continue;
                }
                // Retention may have removed it in the step of the crash.
                jobRemoved(job);
            }
            ++it;
        }
        for (auto& [id, job] : m_jobs) {
            if (job.pruned) continue;
            const v1::JobStatus status = m_coordinator->listJobs(id).at(0);
            // An end the store never got: the job runs again from its last checkpoint (its film
            // was released when it ended, so nothing later was saved).
            const bool endLost = job.endUncommitted && status.state() == v1::JOB_STATE_RUNNING;
            if (endLost) {
                job.state = v1::JOB_STATE_RUNNING;
                job.cancelRequested = false;
                job.endedAt = 0;
            }
            job.endUncommitted = false;
            if (job.state != v1::JOB_STATE_RUNNING && status.state() != job.state)
                violate(absl::StrFormat("job %u was %s, after the restart %s", id,
                                        v1::JobState_Name(job.state),
                                        v1::JobState_Name(status.state())));
            // A job that ended in the step of the crash is checked as an ended job.
            if (job.state != v1::JOB_STATE_RUNNING || status.state() != v1::JOB_STATE_RUNNING)
                continue;
            std::set<uint32_t> restored;
            const uint64_t jobId = id;
            const uint32_t unitCount = job.grid.unitCount();
            m_coordinator->inspect([&](const LeaseScheduler& scheduler) {
                for (uint32_t i = 0; i < unitCount; ++i)
                    if (scheduler.unit(jobId, i).state == LeaseScheduler::UnitState::Merged)
                        restored.insert(i);
            });
            for (uint32_t unit : restored)
                if (!job.merged.count(unit))
                    violate(absl::StrFormat("job %u unit %u restored but never merged", id, unit));
            const uint32_t atLeast = crashed || endLost ? job.durable : mergedBefore[id];
            if (restored.size() < atLeast)
                violate(absl::StrFormat("job %u restored %u units, %u were checkpointed", id,
                                        restored.size(), atLeast));
            job.merged = restored;
            job.held.clear();  // held results live in the coordinator's memory only
            job.durable = uint32_t(restored.size());
        }
    }

    void randomStep() {
        const uint32_t roll = m_random.below(100);
        SimWorker& worker = m_workers[m_random.below(uint32_t(m_workers.size()))];
        // A worker whose registration was refused (a full disk) tries again before anything else.
        const bool workerCall = roll < 66 || (roll >= 68 && roll < 70);
        if (workerCall && worker.id == 0) {
            registerWorker(worker);
            return;
        }
        if (roll < 22) {
            if (worker.leases.size() < 2) acquire(worker);
        } else if (roll < 44) {
            if (!worker.leases.empty())
                deliver(worker, m_random.below(uint32_t(worker.leases.size())), false, false);
        } else if (roll < 47) {
            if (!worker.leases.empty())
                deliver(worker, m_random.below(uint32_t(worker.leases.size())), true, false);
        } else if (roll < 49) {
            if (!worker.leases.empty())
                deliver(worker, m_random.below(uint32_t(worker.leases.size())), false, true);
        } else if (roll < 54) {
            if (worker.lastResult)
                report(worker, worker.lastResult->first, worker.lastResult->second, "duplicate");
        } else if (roll < 66) {
            heartbeat(worker);
        } else if (roll < 68) {
            togglePause();
        } else if (roll < 70) {
            v1::WorkerInfo info;
            try {
                info = m_coordinator->setWorkerDraining(worker.id, !worker.drained);
            } catch (const FarmError& e) {
                if (e.kind != FarmError::Kind::UnknownWorker) throw;
                forgotten(worker);
                return;
            }
            worker.drained = !worker.drained;
            note(absl::StrFormat("%s worker %u (%u leases)",
                                 worker.drained ? "drain" : "end the drain of", worker.id,
                                 info.leases()));
            if (info.draining() != worker.drained)
                violate(absl::StrFormat("worker %u: draining %d after the call", worker.id,
                                        int(info.draining())));
        } else if (roll < 86) {
            advance(0.5 * (1 + m_random.below(6)));
        } else if (roll < 89) {
            // A hang: the worker's leases run out while it is silent; it returns later.
            advance(11 + m_random.below(5));
        } else if (roll < 91) {
            // A worker crash: its leases are gone with it; it comes back under a new id.
            note(absl::StrFormat("worker %u crashes", worker.id));
            registerWorker(worker);
        } else if (roll < 93) {
            std::vector<uint64_t> running;
            for (const auto& [id, job] : m_jobs)
                if (job.state == v1::JOB_STATE_RUNNING) running.push_back(id);
            if (!running.empty()) {
                SimJob& job = m_jobs.at(running[m_random.below(uint32_t(running.size()))]);
                try {
                    const v1::JobStatus status = m_coordinator->cancel(job.id);
                    note(absl::StrFormat("cancel job %u: %s", job.id,
                                         v1::JobState_Name(status.state())));
                    if (status.state() == v1::JOB_STATE_CANCELLED) job.cancelRequested = true;
                } catch (const StorageError& e) {
                    // Ended in this process, not in the store (the client saw UNAVAILABLE).
                    note(absl::StrFormat("cancel job %u: %s", job.id, e.what()));
                    job.cancelRequested = true;
                    job.endUncommitted = true;
                }
            }
        } else if (roll < 95) {
            size_t listed = 0;
            for (const auto& [id, job] : m_jobs) listed += !job.pruned;
            if (listed < 4) {
                // Some submissions are cut short by a coordinator crash.
                const SubmitCrash crashes[] = {SubmitCrash::AfterUpload, SubmitCrash::AfterRecord,
                                               SubmitCrash::AfterDirectory};
                submit(m_random.chance(30) ? crashes[m_random.below(3)] : SubmitCrash::None);
            }
        } else if (roll < 97) {
            crashCoordinator();
        } else if (roll < 98) {
            m_crashCountdown = int(m_random.below(3));
            note(absl::StrFormat("a crash is due after the next %d durable writes",
                                 m_crashCountdown + 1));
        } else if (roll < 99) {
            restartCoordinator();
        } else {
            m_diskFull = !m_diskFull;
            note(m_diskFull ? "disk full" : "disk space freed");
        }
    }

    // Pauses a running job, or resumes it when it is paused.
    void togglePause() {
        std::vector<uint64_t> running;
        for (const auto& [id, job] : m_jobs)
            if (job.state == v1::JOB_STATE_RUNNING && !job.cancelRequested) running.push_back(id);
        if (running.empty()) return;
        SimJob& job = m_jobs.at(running[m_random.below(uint32_t(running.size()))]);
        try {
            const v1::JobStatus status = m_coordinator->setPaused(job.id, !job.paused);
            job.paused = !job.paused;
            note(absl::StrFormat("%s job %u", job.paused ? "pause" : "resume", job.id));
            if (status.paused() != job.paused)
                violate(absl::StrFormat("job %u: paused %d after the call", job.id,
                                        int(status.paused())));
        } catch (const FarmError& e) {
            // The job ended meanwhile (every unit merged, its final checkpoint being written).
            note(absl::StrFormat("refused to toggle the pause of job %u: %s", job.id, e.what()));
        }
    }

    // `storage`: also what is on disk (checkStorage), which only a submission, a registration, a
    // crash or the clock (retention) changes.
    void checkInvariants(bool storage = true) {
        settleHeldResults();
        std::string problems;
        m_coordinator->inspect(
            [&](const LeaseScheduler& scheduler) { problems = scheduler.checkConsistency(); });
        if (!problems.empty()) violate("lease tables: " + problems);
        for (auto& [id, job] : m_jobs) {
            if (job.pruned) continue;
            const std::optional<v1::JobStatus> found = findJob(id);
            if (!found) {
                jobRemoved(job);
                continue;
            }
            const v1::JobStatus& status = *found;
            if (job.state != v1::JOB_STATE_RUNNING && status.state() != job.state)
                violate(absl::StrFormat("job %u went from %s to %s", id,
                                        v1::JobState_Name(job.state),
                                        v1::JobState_Name(status.state())));
            // (An ended job's count is not restored after a restart unless it is done.)
            const bool endedUnfinished =
                status.state() == v1::JOB_STATE_CANCELLED || status.state() == v1::JOB_STATE_FAILED;
            if (!endedUnfinished && status.units_done() != job.merged.size())
                violate(absl::StrFormat("job %u reports %u units done, %u were merged", id,
                                        status.units_done(), job.merged.size()));
            if (status.state() == v1::JOB_STATE_RUNNING && status.paused() != job.paused)
                violate(absl::StrFormat("job %u: paused %d, expected %d", id, int(status.paused()),
                                        int(job.paused)));
            if (!job.cancelRequested && status.state() == v1::JOB_STATE_CANCELLED)
                violate(absl::StrFormat("job %u cancelled, but nobody cancelled it", id));
            if (job.cancelRequested && status.state() != v1::JOB_STATE_CANCELLED)
                violate(absl::StrFormat("cancelled job %u is %s", id,
                                        v1::JobState_Name(status.state())));
            if (status.state() == v1::JOB_STATE_RUNNING &&
                status.units_done() == status.units_total() &&
                status.error().find("cannot write the checkpoint") != std::string::npos)
                ++g_coverage["done but the final checkpoint failing"];
            if (status.checkpoints_written() > job.checkpointsSeen) {
                job.checkpointsSeen = status.checkpoints_written();
                job.durable = status.units_done();
            }
            if (job.state == v1::JOB_STATE_RUNNING && status.state() != job.state) {
                ++g_coverage[std::string("job ") + v1::JobState_Name(status.state())];
                if (m_diskFull) job.endUncommitted = true;
                job.endedAt = m_clock->wallSeconds();
            }
            job.state = status.state();
            if (job.state != v1::JOB_STATE_RUNNING && m_keep > 0 &&
                m_clock->wallSeconds() >= job.endedAt + m_keep + kRetentionLag)
                violate(absl::StrFormat("job %u ended %.1f s ago and is still kept (keep %.0f s)",
                                        id, m_clock->wallSeconds() - job.endedAt, m_keep));
            if (job.state == v1::JOB_STATE_DONE && !job.imageChecked) {
                if (job.merged.size() != job.grid.unitCount())
                    violate(absl::StrFormat("job %u done with %u of %u units", id,
                                            job.merged.size(), job.grid.unitCount()));
                const FilmBlock film = m_coordinator->snapshot(id, false).film;
                if (film.serialize() != job.expected.serialize())
                    violate(absl::StrFormat(
                        "job %u done, but its film is not the sum of its units' results", id));
                job.imageChecked = true;
            }
            // Only poison units fail jobs here (at least 4 failed attempts: a crash between
            // the last attempt's record and the job's end gives the unit one more).
            if (job.state == v1::JOB_STATE_FAILED &&
                status.error().find("times (the limit)") == std::string::npos)
                violate(absl::StrFormat("job %u failed: %s", id, status.error()));
        }
        if (storage) checkStorage();
    }

    // What is stored matches what the coordinator lists: nothing half-written survives a refused
    // or interrupted submission or registration, and retention removes a job with its directory
    // and its blobs but never what a listed job uses.
    void checkStorage() {
        std::set<uint64_t> listed;
        std::set<std::string> referenced;
        for (const auto& [id, job] : m_jobs)
            if (!job.pruned) {
                listed.insert(id);
                referenced.insert(job.blobs.begin(), job.blobs.end());
            }
        if (m_coordinator->listJobs(0).size() != listed.size())
            violate(absl::StrFormat("the coordinator lists %u jobs, %u were submitted",
                                    m_coordinator->listJobs(0).size(), listed.size()));
        for (const v1::WorkerInfo& info : m_coordinator->listWorkers(true))
            if (!m_registeredWorkers.count(info.worker_id()))
                violate(absl::StrFormat("worker %u is listed, but no registration returned it",
                                        info.worker_id()));
        const fs::path jobs = stateDirectory() / "jobs";
        for (const auto& entry : fs::directory_iterator(jobs))
            if (!listed.count(std::strtoull(entry.path().filename().c_str(), nullptr, 10)))
                violate(absl::StrFormat("%s is left over: the coordinator lists no such job",
                                        entry.path().string()));
        for (uint64_t id : listed)
            if (m_jobs.at(id).state == v1::JOB_STATE_RUNNING &&
                !fs::is_directory(jobs / std::to_string(id)))
                violate(absl::StrFormat("running job %u has no directory for its checkpoints", id));
        const double now = m_clock->wallSeconds();
        for (const std::string& sha : referenced) m_blobReferencedAt[sha] = now;
        std::set<std::string> stored;
        for (const BlobStore::StoredBlob& blob : m_coordinator->blobs().list()) {
            stored.insert(blob.sha256);
            if (referenced.count(blob.sha256) || !(m_keep > 0)) continue;
            // It may go once no job uses it and it was neither stored nor asked for within the
            // keep time.
            double lastUse = m_blobStoredAt[blob.sha256];
            if (auto it = m_blobTouchedAt.find(blob.sha256); it != m_blobTouchedAt.end())
                lastUse = std::max(lastUse, it->second);
            const double unusedSince = std::max(lastUse + m_keep, m_blobReferencedAt[blob.sha256]);
            if (now >= unusedSince + kRetentionLag)
                violate(absl::StrFormat("blob %s, which may go since t=%.1f, is still stored",
                                        blob.sha256.substr(0, 12), unusedSince - kWallStart));
        }
        for (const std::string& sha : referenced)
            if (!stored.count(sha))
                violate(absl::StrFormat("blob %s of a listed job was removed", sha.substr(0, 12)));
    }

    // Everything goes well from here on: every job must end, within a bound.
    void drain() {
        note("drain");
        for (auto& [id, job] : m_jobs)
            if (job.paused && job.state == v1::JOB_STATE_RUNNING) {
                try {
                    m_coordinator->setPaused(id, false);
                } catch (const FarmError&) {
                    // Every unit merged while it was paused: it is finishing.
                }
                job.paused = false;
            }
        for (SimWorker& worker : m_workers)
            if (worker.id == 0) registerWorker(worker);
        for (SimWorker& worker : m_workers)
            if (worker.drained) {
                try {
                    m_coordinator->setWorkerDraining(worker.id, false);
                } catch (const FarmError& e) {
                    if (e.kind != FarmError::Kind::UnknownWorker) throw;
                    forgotten(worker);
                }
                worker.drained = false;
            }
        for (int round = 0; round < 5000; ++round) {
            bool running = false;
            for (const auto& [id, job] : m_jobs) running |= job.state == v1::JOB_STATE_RUNNING;
            if (!running) {
                checkStorage();
                return;
            }
            SimWorker& worker = m_workers[round % m_workers.size()];
            if (!worker.leases.empty())
                deliver(worker, 0, false, false);
            else
                acquire(worker);
            if (round % 8 == 7) advance(1);
            checkInvariants(round % 8 == 7);
        }
        violate("the jobs did not end after the schedule: a hang");
    }

    Options m_options;
    Random m_random;
    fs::path m_root, m_sceneDirectory;
    int m_border;
    std::shared_ptr<ManualClock> m_clock;
    std::unique_ptr<Coordinator> m_coordinator;
    int m_generation = 0;
    int m_crashCountdown = -1;  // durable writes before a crash inside a step; -1: none due
    bool m_crashTaken = false;
    bool m_diskFull = false;  // every durable write fails (DurableWriteHooks::before)
    double m_keep = 0;        // retention's keep time for ended jobs; 0 keeps everything
    std::map<uint64_t, SimJob> m_jobs;
    std::vector<SimWorker> m_workers;
    std::set<uint64_t> m_registeredWorkers;  // every id a registration returned
    std::set<uint64_t> m_submittedThisStep;
    // Blobs by SHA-256: when the client stored each, and when it last asked for each without
    // a submission that consumed the mark (wall clock).
    std::map<std::string, double> m_blobStoredAt, m_blobTouchedAt;
    std::map<std::string, double> m_blobReferencedAt;  // when a listed job last used it
    std::vector<std::string> m_trace;
};

int main(int argc, char** argv) {
    Options options;
    bool replay = false;
    for (int i = 1; i < argc; ++i) {
        const std::string arg = argv[i];
        const auto value = [&] {
            if (i + 1 >= argc) {
                std::fprintf(stderr, "%s needs a value\n", arg.c_str());
                std::exit(2);
            }
            return std::strtoull(argv[++i], nullptr, 10);
        };
        if (arg == "--seeds")
            options.seeds = value();
        else if (arg == "--first-seed")
            options.firstSeed = value();
        else if (arg == "--seed") {
            options.firstSeed = value();
            options.seeds = 1;
            replay = true;
        } else if (arg == "--steps")
            options.steps = int(value());
        else if (arg == "--verbose")
            options.verbose = true;
        else {
            std::fprintf(stderr,
                         "usage: %s [--seeds N] [--first-seed S] [--seed S] [--steps K] "
                         "[--verbose]\n",
                         argv[0]);
            return 2;
        }
    }
    if (const char* seed = std::getenv("ALPHORN_SIM_SEED")) {
        options.firstSeed = std::strtoull(seed, nullptr, 10);
        options.seeds = 1;
        replay = true;
    }
    const fs::path base =
        fs::path(fs::exists("/dev/shm") ? "/dev/shm" : fs::temp_directory_path().string()) /
        ("alphorn_simulation_" + std::to_string(::getpid()));
    fs::remove_all(base);
    const fs::path scene = base / "scene";
    fs::create_directories(scene);
    fs::copy_file(sourcePath("scenes/meshes/triangle.obj"), scene / "triangle.obj");
    for (int variant = 0; variant < 3; ++variant)
        std::ofstream(scene / ("s" + std::to_string(variant) + ".xml"))
            << "<!-- variant " << variant << " -->\n"
            << R"(<scene>
  <integrator type="normals"/>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 3, 0.5" target="0, 0, 0" up="0, 0, 1"/></transform>
    <integer name="width" value="10"/><integer name="height" value="8"/>
  </camera>
  <mesh type="obj"><string name="filename" value="triangle.obj"/></mesh>
  <emitter type="point"><point name="position" value="0, 3, 2"/><color name="power" value="1"/></emitter>
</scene>)";
    const int border =
        -makeUnitBlock(*loadScene((scene / "s0.xml").string()), Tile{0, 0, 1, 1}).x0();
    setLogSink(collectLog);
    int failures = 0;
    for (uint64_t seed = options.firstSeed; seed < options.firstSeed + options.seeds; ++seed) {
        g_log.clear();
        std::string problem;
        std::vector<std::string> trace;
        {
            Simulation simulation(seed, options, base / "run", scene, border);
            problem = simulation.run();
            trace = simulation.trace();
        }
        if (options.verbose || (replay && !problem.empty())) {
            for (const std::string& line : trace) std::printf("  %s\n", line.c_str());
            if (options.verbose) std::fputs(g_log.c_str(), stdout);
        }
        if (problem.empty()) continue;
        ++failures;
        std::printf("seed %llu FAILED after %zu steps: %s\n", (unsigned long long)seed,
                    trace.size(), problem.c_str());
        if (!replay) {
            const size_t from = trace.size() > 12 ? trace.size() - 12 : 0;
            for (size_t i = from; i < trace.size(); ++i) std::printf("  %s\n", trace[i].c_str());
            std::printf("replay: %s --seed %llu --steps %d [--verbose]\n", argv[0],
                        (unsigned long long)seed, options.steps);
        }
        break;
    }
    fs::remove_all(base);
    if (failures == 0) {
        std::printf("%llu seeds from %llu passed (%d steps each); covered:",
                    (unsigned long long)options.seeds, (unsigned long long)options.firstSeed,
                    options.steps);
        for (const auto& [event, count] : g_coverage)
            std::printf(" %s %llu,", event.c_str(), (unsigned long long)count);
        std::printf("\n");
    }
    return failures == 0 ? 0 : 1;
}

}  // namespace
}  // namespace alphorn::coordinator

int main(int argc, char** argv) {
    return alphorn::coordinator::main(argc, argv);
}
