// Unit tests of the coordinator's core without sockets: blob store checks, checkpoints, and a
// whole job driven through Coordinator (submit, lease, report out of order, late and duplicate
// results, restart from the checkpoint) compared byte for byte with renderLocal().
#include "coordinator/coordinator.h"
#include "common/farm/build_identity.h"
#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/engine_fingerprint.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/sha256.h"
#include "common/render/local_render.h"
#include "common/scene/accel.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "coordinator/checkpoint.h"
#include "coordinator/coordinator_job_test.h"

#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/resource.h>

#include <csignal>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <future>
#include <optional>
#include <set>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

// A worker's registration as a worker of this build sends it.
v1::RegisterRequest thisBuild() {
    v1::RegisterRequest request;
    farm::describeThisBuild(request);
    return request;
}

fs::path freshDirectory(const std::string& name) {
    fs::path path =
        fs::temp_directory_path() / ("alphorn_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(path);
    fs::create_directories(path);
    return path;
}

TEST(BlobStore, VerifiesLimitsAndDeduplicates) {
    const fs::path dir = freshDirectory("blobs");
    BlobStore store(dir.string(), 10);
    {
        BlobStore::Upload upload(store, farm::sha256Hex("hello"));
        upload.append("hello");
        EXPECT_TRUE(upload.commit());
    }
    EXPECT_TRUE(store.has(farm::sha256Hex("hello")));
    EXPECT_EQ(store.size(farm::sha256Hex("hello")), 5u);
    {
        BlobStore::Upload again(store, farm::sha256Hex("hello"));
        again.append("hello");
        EXPECT_FALSE(again.commit());  // already there
    }
    {
        BlobStore::Upload forged(store, farm::sha256Hex("other"));
        forged.append("hello");
        EXPECT_THROW(forged.commit(), Error);
    }
    EXPECT_FALSE(store.has(farm::sha256Hex("other")));
    {
        BlobStore::Upload big(store, farm::sha256Hex("0123456789ab"));
        EXPECT_THROW(big.append("0123456789ab"), Error);
    }
    EXPECT_THROW(BlobStore::Upload(store, "../../etc/passwd"), Error);
    EXPECT_FALSE(store.has("../../etc/passwd"));
    fs::remove_all(dir);
}

// A database error names the database's file and the statement's first line (a CREATE TABLE
// statement spans ten), not the statement whole.
TEST(StateDatabase, ErrorsNameTheFileAndTheStatementsFirstLine) {
    const fs::path dir = freshDirectory("state_db_errors");
    const std::string path = (dir / "state.sqlite").string();
    StateDatabase db(path);
    try {
        db.execute("SELECT * FROM no_such_table\nWHERE 1 = 1");
        ADD_FAILURE() << "no error";
    } catch (const StorageError& e) {
        EXPECT_EQ(std::string(e.what()), path +
                                             ": SQL error in \"SELECT * FROM no_such_table...\": "
                                             "no such table: no_such_table");
    }
    fs::remove_all(dir);
}

TEST(Checkpoint, RoundTripAndCorruption) {
    const fs::path dir = freshDirectory("checkpoint");
    FilmBlock film(0, 0, 5, 4);
    film.at(3, 2).rgb[1] = FixedPoint(77) << 64;
    film.at(3, 2).weight = 5;
    film.invalidSamples = 3;
    const std::vector<bool> merged{true, false, true};
    const std::string path = (dir / "film.ckpt").string();
    writeCheckpoint(path, "job 1", film, merged);
    Checkpoint back = readCheckpoint(path, "job 1", 5, 4, 3);
    EXPECT_EQ(back.film.serialize(), film.serialize());
    EXPECT_EQ(back.merged, merged);
    EXPECT_EQ(back.film.invalidSamples, 3u);
    EXPECT_THROW(readCheckpoint(path, "job 1", 5, 4, 4), Error);  // another job's shape
    EXPECT_THROW(readCheckpoint(path, "job 2", 5, 4, 3), Error);  // another job's file
    std::string bytes = farm::readFile(path);
    bytes[20] ^= 1;
    farm::writeFileAtomically(path, bytes);
    EXPECT_THROW(readCheckpoint(path, "job 1", 5, 4, 3), Error);
    fs::remove_all(dir);
}

class CoordinatorJob : public CoordinatorJobTest {
  protected:
    // Makes a rendered result wrong, as a worker with a damaged scene file or a bad build
    // would: one unit of fixed point more red in the block's first pixel.
    static void perturbResult(v1::ResultChunk& header, std::string& compressed) {
        FilmBlock block(header.block_x0(), header.block_y0(), header.block_width(),
                        header.block_height(), PassHalves::Kept);
        farm::decompressFilm(compressed, block);
        block.at(block.x0(), block.y0()).rgb[0] += 1;
        compressed = farm::compressFilm(block);
        header.set_compressed_size(compressed.size());
        header.set_compressed_sha256(farm::sha256Hex(compressed));
    }
    // Leases every pending unit to `worker`, renders and reports it as a worker does, and
    // calls `afterMerge` with each lease once its result is merged.
    void renderAllUnits(
        Coordinator& coordinator, uint64_t worker,
        const std::function<void(const v1::AcquireWorkResponse&)>& afterMerge = {}) {
        for (;;) {
            const v1::AcquireWorkResponse lease =
                coordinator.acquire(worker, std::chrono::steady_clock::now());
            if (!lease.has_work()) return;
            std::string compressed;
            const v1::ResultChunk header = render(lease, worker, compressed);
            ASSERT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
            if (afterMerge) afterMerge(lease);
        }
    }

    // Leases one unit to `worker`, renders and reports it as a worker does; it must merge.
    void mergeOneUnit(Coordinator& coordinator, uint64_t worker) {
        const v1::AcquireWorkResponse lease =
            coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(lease.has_work());
        std::string compressed;
        const v1::ResultChunk header = render(lease, worker, compressed);
        ASSERT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
    }

    std::string localFilm(uint32_t passes = 3) {
        auto scene = loadScene((m_dir / "scene/s.xml").string());
        RenderSettings settings;
        settings.seed = 5;
        settings.passes = passes;
        return renderLocal(*scene, settings).serialize();
    }

    template <typename Predicate>
    static bool waitFor(Predicate done) {
        // A bound for background work, not a timing assertion: it normally takes milliseconds.
        for (int i = 0; i < 1000 && !done(); ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(10));
        return done();
    }
};

// Runs `change` and returns the FailedPrecondition message it throws ("" when it throws none).
template <typename Change>
std::string refusal(Change change) {
    try {
        change();
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, FarmError::Kind::FailedPrecondition) << e.what();
        return e.what();
    }
    return "";
}

std::vector<v1::JobEventKind> eventKinds(const v1::GetJobLogResponse& log) {
    std::vector<v1::JobEventKind> kinds;
    for (const v1::JobEvent& event : log.events()) kinds.push_back(event.kind());
    return kinds;
}

bool hasEvent(const v1::GetJobLogResponse& log, v1::JobEventKind kind) {
    const auto kinds = eventKinds(log);
    return std::find(kinds.begin(), kinds.end(), kind) != kinds.end();
}

TEST_F(CoordinatorJob, ReverseOrderDuplicatesAndRestartGiveTheLocalFilm) {
    auto scene = loadScene((m_dir / "scene/s.xml").string());
    RenderSettings settings;
    settings.seed = 5;
    settings.passes = 3;
    const std::string expected = renderLocal(*scene, settings).serialize();

    uint64_t jobId = 0;
    uint32_t mergedBeforeRestart = 0;
    {
        Coordinator coordinator(m_options);
        const v1::JobStatus submitted = coordinator.submit(upload(coordinator));
        jobId = submitted.job_id();
        const uint32_t total = submitted.units_total();
        EXPECT_EQ(total, 3u * 6u);  // 3 passes x (3 x 2 tiles of 16 px)
        EXPECT_FALSE(submitted.has_photon_radius()) << "a normals job has no photon radius";
        v1::RegisterRequest registration = thisBuild();
        registration.set_name("test");
        const uint64_t worker = coordinator.registerWorker(registration);
        std::vector<v1::AcquireWorkResponse> leases;
        for (uint32_t i = 0; i < total; ++i) {
            leases.push_back(coordinator.acquire(worker, std::chrono::steady_clock::now()));
            ASSERT_TRUE(leases.back().has_work());
        }
        EXPECT_FALSE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work());
        // Deliver the second half in reverse order, one unit twice, then stop and restart.
        for (uint32_t i = total - 1; i >= total / 2; --i) {
            std::string compressed;
            const v1::ResultChunk header = render(leases[i], worker, compressed);
            EXPECT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
            if (i == total - 1) {
                EXPECT_EQ(coordinator.report(header, compressed), v1::RESULT_DISCARDED);
            }
        }
        mergedBeforeRestart = total - total / 2;
        // The heartbeat fences merged units and keeps the others.
        v1::HeartbeatRequest heartbeat;
        heartbeat.set_worker_id(worker);
        heartbeat.add_lease_ids(leases[0].lease_id());
        heartbeat.add_lease_ids(leases[total - 1].lease_id());
        const v1::HeartbeatResponse response = coordinator.heartbeat(heartbeat);
        ASSERT_EQ(response.drop_lease_ids_size(), 1);
        EXPECT_EQ(response.drop_lease_ids(0), leases[total - 1].lease_id());
        coordinator.stop();  // checkpoints
    }
    Coordinator coordinator(m_options);
    v1::JobStatus status = coordinator.listJobs(jobId).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(status.units_restored(), mergedBeforeRestart);
    v1::RegisterRequest registration = thisBuild();
    const uint64_t worker = coordinator.registerWorker(registration);
    renderAllUnits(coordinator, worker, [&](const v1::AcquireWorkResponse& lease) {
        EXPECT_LT(lease.unit().unit_index(), status.units_total() / 2)
            << "a restored unit was leased again";
    });
    status = coordinator.listJobs(jobId).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(status.units_merged_this_run() + status.units_restored(), status.units_total());
    EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), expected);
}

// The progress report's photon radius comes from the job's scene through the shared schedule:
// pass 0's radius until a pass is complete, then the last complete pass's, also after a restart.
// The expected radii follow the Knaus-Zwicker recurrence r²(N + 1) = r²(N) (N + α) / (N + 1),
// not the closed form the coordinator uses.
TEST_F(CoordinatorJob, ReportsThePhotonRadiusOfTheLastCompletePass) {
    writeScene(R"(<integrator type="photonmapper">
    <integer name="photonCount" value="200"/>
    <float name="surfacePhotonRadius" value="0.25"/>
    <boolean name="progressive" value="true"/>
    <float name="alpha" value="0.7"/>
  </integrator>)",
               40, 30,
               R"(<emitter type="point">
    <point name="position" value="0, 3, 0"/><color name="power" value="10, 10, 10"/>
  </emitter>)");
    const double alpha = 0.7f;  // the scene's float, as the integrator holds it
    std::vector<double> expected{0.25};
    for (int n = 1; n < 3; ++n)
        expected.push_back(expected.back() * std::sqrt((n + alpha) / (n + 1)));

    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        v1::JobStatus status = coordinator.submit(upload(coordinator));
        jobId = status.job_id();
        ASSERT_TRUE(status.has_photon_radius());
        EXPECT_EQ(status.photon_radius(), expected[0]);
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        std::set<uint32_t> passesSeen;
        renderAllUnits(coordinator, worker, [&](const v1::AcquireWorkResponse&) {
            status = coordinator.listJobs(jobId).at(0);
            const uint32_t done = status.passes_done();
            passesSeen.insert(done);
            ASSERT_TRUE(status.has_photon_radius());
            EXPECT_NEAR(status.photon_radius(), expected[done > 0 ? done - 1 : 0],
                        1e-12 * expected[0])
                << done << " passes done";
        });
        EXPECT_EQ(passesSeen, (std::set<uint32_t>{0, 1, 2, 3}));
        EXPECT_EQ(status.state(), v1::JOB_STATE_DONE);
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    const v1::JobStatus status = restarted.listJobs(jobId).at(0);
    ASSERT_TRUE(status.has_photon_radius()) << "the schedule is persisted with the job";
    EXPECT_NEAR(status.photon_radius(), expected[2], 1e-12 * expected[0]);
}

// An ended job stays until keepFinishedSeconds have passed, then its record, directory and the
// blobs only it used go; a running job and the blobs it uses stay, also across a restart.
TEST_F(CoordinatorJob, EndedJobsAndUnusedBlobsAreRemovedAfterTheKeepTime) {
    m_options.keepFinishedSeconds = 1000;
    const auto wallNow = [] {
        return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    };
    uint64_t ended = 0, running = 0;
    std::string endedScene, runningScene, sphere, orphan;
    {
        Coordinator coordinator(m_options);
        const v1::SubmitJobRequest first = upload(coordinator);
        ended = coordinator.submit(first).job_id();
        renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
        ASSERT_EQ(coordinator.listJobs(ended).at(0).state(), v1::JOB_STATE_DONE);
        // A second scene file shares sphere.obj with the first job.
        std::ofstream(m_dir / "scene/s.xml", std::ios::app) << "<!-- another scene -->\n";
        const v1::SubmitJobRequest second = upload(coordinator);
        running = coordinator.submit(second).job_id();
        for (const v1::BundleFile& file : first.bundle().files())
            (file.path() == "sphere.obj" ? sphere : endedScene) = file.sha256();
        for (const v1::BundleFile& file : second.bundle().files())
            if (file.path() != "sphere.obj") runningScene = file.sha256();
        // A blob uploaded but never submitted.
        const std::string bytes = "never used";
        orphan = farm::sha256Hex(bytes);
        BlobStore::Upload blob(coordinator.blobs(), orphan);
        blob.append(bytes);
        blob.commit();
        coordinator.touchBlobs({orphan});

        coordinator.pruneFinishedJobs(wallNow() + 900);
        EXPECT_EQ(coordinator.listJobs(0).size(), 2u) << "removed before the keep time";
        EXPECT_TRUE(coordinator.blobs().has(orphan));
        EXPECT_TRUE(coordinator.blobs().has(endedScene));

        coordinator.pruneFinishedJobs(wallNow() + 1100);
        try {
            coordinator.listJobs(ended);
            ADD_FAILURE() << "the ended job is still listed";
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::NotFound);
        }
        EXPECT_FALSE(fs::exists(coordinator.jobDirectory(ended)));
        EXPECT_TRUE(fs::exists(coordinator.jobDirectory(running)));
        EXPECT_EQ(coordinator.listJobs(running).at(0).state(), v1::JOB_STATE_RUNNING);
        EXPECT_FALSE(coordinator.blobs().has(endedScene)) << "used by the removed job only";
        EXPECT_FALSE(coordinator.blobs().has(orphan)) << "never used, stored long ago";
        EXPECT_TRUE(coordinator.blobs().has(sphere)) << "still used by the running job";
        EXPECT_TRUE(coordinator.blobs().has(runningScene));
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    const std::vector<v1::JobStatus> jobs = restarted.listJobs(0);
    ASSERT_EQ(jobs.size(), 1u) << "the removal is persistent";
    EXPECT_EQ(jobs.at(0).job_id(), running);
    // The running job's blobs survive however late it is: only ended jobs release theirs.
    restarted.pruneFinishedJobs(wallNow() + 1e9);
    EXPECT_TRUE(restarted.blobs().has(sphere));
    EXPECT_TRUE(restarted.blobs().has(runningScene));
    EXPECT_EQ(restarted.listJobs(0).size(), 1u);
}

TEST_F(CoordinatorJob, BrokenSceneIsRefusedWithFileAndLine) {
    std::ofstream(m_dir / "scene/s.xml")
        << "<scene>\n  <integrator type=\"no_such_integrator\"/>\n</scene>\n";
    Coordinator coordinator(m_options);
    farm::Bundle bundle;
    bundle.scenePath = "s.xml";
    const std::string text = farm::readFile((m_dir / "scene/s.xml").string());
    BlobStore::Upload blob(coordinator.blobs(), farm::sha256Hex(text));
    blob.append(text);
    blob.commit();
    bundle.files.push_back({"s.xml", farm::sha256Hex(text), text.size(), ""});
    v1::SubmitJobRequest request;
    *request.mutable_bundle() = farm::toProto(bundle);
    try {
        coordinator.submit(request);
        FAIL() << "a broken scene was accepted";
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, FarmError::Kind::InvalidArgument);
        EXPECT_EQ(std::string(e.what()).rfind("s.xml:2:", 0), 0u) << e.what();
    }
    EXPECT_TRUE(coordinator.listJobs(0).empty());
}

// A client that lost SubmitJob's answer (the coordinator restarted, the connection broke) sends
// the same request again: the submission id makes that give the job the first call created,
// also after a restart, and never a second job.
TEST_F(CoordinatorJob, ASubmissionSentAgainGivesTheSameJobOnce) {
    const std::string id = "0123456789abcdef0123456789abcdef";
    uint64_t first = 0;
    {
        Coordinator coordinator(m_options);
        v1::SubmitJobRequest request = upload(coordinator);
        request.mutable_settings()->set_owner("ana@render-1");
        request.set_submission_id(id);
        first = coordinator.submit(request).job_id();
        EXPECT_EQ(coordinator.submit(request).job_id(), first);
        EXPECT_EQ(coordinator.listJobs(0).size(), 1u);

        v1::SubmitJobRequest another = request;
        another.set_submission_id("fedcba9876543210fedcba9876543210");
        const uint64_t second = coordinator.submit(another).job_id();
        EXPECT_NE(second, first);
        v1::SubmitJobRequest otherOwner = request;
        otherOwner.mutable_settings()->set_owner("ben@render-2");
        const uint64_t third = coordinator.submit(otherOwner).job_id();
        EXPECT_NE(third, first);
        EXPECT_NE(third, second);
        v1::SubmitJobRequest withoutId = request;
        withoutId.clear_submission_id();
        coordinator.submit(withoutId);
        coordinator.submit(withoutId);
        EXPECT_EQ(coordinator.listJobs(0).size(), 5u) << "requests without an id were merged";
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    v1::SubmitJobRequest request = upload(restarted);
    request.mutable_settings()->set_owner("ana@render-1");
    request.set_submission_id(id);
    EXPECT_EQ(restarted.submit(request).job_id(), first);
    EXPECT_EQ(restarted.listJobs(0).size(), 5u);
    restarted.stop();
}

TEST_F(CoordinatorJob, AMalformedSubmissionIdIsRefused) {
    Coordinator coordinator(m_options);
    v1::SubmitJobRequest request = upload(coordinator);
    for (const std::string& id : {std::string(65, 'a'), std::string("a b"), std::string("a\nb")}) {
        request.set_submission_id(id);
        try {
            coordinator.submit(request);
            FAIL() << "submission id \"" << id << "\" was accepted";
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::InvalidArgument);
            EXPECT_NE(std::string(e.what()).find("submission id"), std::string::npos) << e.what();
        }
    }
    EXPECT_TRUE(coordinator.listJobs(0).empty());
    coordinator.stop();
}

// A caller gone by the time the scene has loaded gets no job; its retry, with the same id,
// creates it then.
TEST_F(CoordinatorJob, NoJobIsCreatedForACallerThatIsGone) {
    Coordinator coordinator(m_options);
    v1::SubmitJobRequest request = upload(coordinator);
    request.set_submission_id("0123456789abcdef0123456789abcdef");
    try {
        coordinator.submit(request, [] { return true; });
        FAIL() << "a job was created for a caller that had gone";
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, FarmError::Kind::CallerGone);
    }
    EXPECT_TRUE(coordinator.listJobs(0).empty());
    EXPECT_TRUE(fs::is_empty(fs::path(m_options.stateDirectory) / "tmp"))
        << "the refused job's bundle stayed behind";
    const uint64_t job = coordinator.submit(request, [] { return false; }).job_id();
    EXPECT_EQ(coordinator.submit(request).job_id(), job);
    EXPECT_EQ(coordinator.listJobs(0).size(), 1u);
    coordinator.stop();
}

// A client whose SubmitJob outlasted its time limit while the scene loaded asks again with the
// same submission id while the first call still loads: the second call waits for the first,
// which creates the job for it although its own caller is gone. One job, and both calls name it.
TEST_F(CoordinatorJob, ASubmissionSentAgainWhileTheFirstLoadsGetsTheJobItCreates) {
    Coordinator coordinator(m_options);
    v1::SubmitJobRequest request = upload(coordinator);
    request.set_submission_id("0123456789abcdef0123456789abcdef");
    std::promise<void> firstLoaded;
    std::atomic<bool> secondWaits{false};
    auto first = std::async(std::launch::async, [&] {
        return coordinator
            .submit(request,
                    [&] {
                        // The scene has loaded: the caller gave up meanwhile and asks again.
                        firstLoaded.set_value();
                        EXPECT_TRUE(waitFor([&] { return secondWaits.load(); }))
                            << "the second call did not wait for the first";
                        return true;
                    })
            .job_id();
    });
    firstLoaded.get_future().wait();
    const uint64_t second = coordinator
                                .submit(request,
                                        [&] {
                                            secondWaits = true;
                                            return false;
                                        })
                                .job_id();
    EXPECT_EQ(first.get(), second);
    EXPECT_EQ(coordinator.listJobs(0).size(), 1u);
    coordinator.stop();
}

// A job row changed after submission (here its width, so that its checkpoint is refused for
// its shape and it would be rendered again at a size that is not its scene's) fails that job at
// start, saying its record is damaged; the other jobs resume and finish with their images.
TEST_F(CoordinatorJob, AJobRowChangedAfterSubmissionFailsThatJobOnly) {
    writeScene(R"(<integrator type="normals"/>)", 48, 32);
    uint64_t damaged = 0, healthy = 0;
    {
        Coordinator coordinator(m_options);
        damaged = coordinator.submit(upload(coordinator)).job_id();
        healthy = coordinator.submit(upload(coordinator)).job_id();
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        mergeOneUnit(coordinator, worker);
        mergeOneUnit(coordinator, worker);
        coordinator.stop();
    }
    {
        StateDatabase db(m_options.stateDirectory + "/state.sqlite");
        db.execute("UPDATE jobs SET width = 32 WHERE id = ?", {int64_t(damaged)});
    }
    std::string reason;
    {
        Coordinator coordinator(m_options);
        const v1::JobStatus status = coordinator.listJobs(damaged).at(0);
        reason = status.error();
        EXPECT_EQ(status.state(), v1::JOB_STATE_FAILED);
        EXPECT_EQ(
            status.error().rfind("job " + std::to_string(damaged) + "'s record is damaged: ", 0),
            0u)
            << status.error();
        // Named for the client relative to the state directory, never by the server's path.
        EXPECT_NE(status.error().find("jobs.record_sha256 of state.sqlite"), std::string::npos)
            << status.error();
        EXPECT_EQ(status.error().find(m_options.stateDirectory), std::string::npos)
            << status.error();
        EXPECT_EQ(coordinator.listJobs(healthy).at(0).state(), v1::JOB_STATE_RUNNING);
        renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
        EXPECT_EQ(coordinator.listJobs(damaged).at(0).state(), v1::JOB_STATE_FAILED);
        EXPECT_EQ(coordinator.listJobs(healthy).at(0).state(), v1::JOB_STATE_DONE);
        EXPECT_EQ(coordinator.snapshot(healthy, false).film.serialize(), localFilm());
        const std::string refused = refusal([&] { coordinator.retry(damaged); });
        EXPECT_NE(refused.find("its record could not be resumed"), std::string::npos) << refused;
        coordinator.stop();
    }
    // Failed for good: the next start keeps the job failed with the same reason.
    Coordinator again(m_options);
    EXPECT_EQ(again.listJobs(damaged).at(0).error(), reason);
    again.stop();
}

TEST_F(CoordinatorJob, ASecondCoordinatorOnTheStateDirectoryIsRefused) {
    Coordinator first(m_options);
    try {
        Coordinator second(m_options);
        FAIL() << "two coordinators opened one state directory";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("in use by another coordinator (pid " +
                                             std::to_string(::getpid())),
                  std::string::npos)
            << e.what();
    }
    first.stop();
}

// The lock file only names the holder: removing it (a temporary-file cleaner, an operator
// "removing a stale lock") must not let a second coordinator run beside the first.
TEST_F(CoordinatorJob, ASecondCoordinatorIsRefusedAlsoWhenTheLockFileWasRemoved) {
    Coordinator first(m_options);
    ASSERT_TRUE(fs::remove(fs::path(m_options.stateDirectory) / "lock"));
    try {
        Coordinator second(m_options);
        FAIL() << "a second coordinator opened the state directory once its lock file was removed";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("in use by another coordinator (its lock file"),
                  std::string::npos)
            << e.what();
    }
    first.stop();
}

// A lost (emptied) database must not start afresh: it would hand out job 1 again and delete
// job 1's film.
TEST_F(CoordinatorJob, ALostDatabaseIsRefusedAndNoFilmIsDeleted) {
    {
        Coordinator coordinator(m_options);
        coordinator.submit(upload(coordinator));
        renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
        coordinator.stop();
    }
    const fs::path state = m_options.stateDirectory;
    ASSERT_TRUE(fs::exists(state / "jobs/1/film.ckpt"));
    fs::remove(state / "state.sqlite-wal");
    fs::remove(state / "state.sqlite-shm");
    std::ofstream(state / "state.sqlite", std::ios::trunc).close();
    try {
        Coordinator coordinator(m_options);
        FAIL() << "started on an emptied database";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("lost or truncated"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::exists(state / "jobs/1/film.ckpt"));
}

// What a restarted coordinator knows of each job equals what it knew before: the description
// workers get (its id included), settings, state, errors, counts and attempts.
TEST_F(CoordinatorJob, EveryPersistedFieldRoundTrips) {
    m_options.maxAttempts = 1;
    std::vector<v1::JobStatus> before;
    v1::JobDescription description;
    uint64_t running = 0;
    {
        Coordinator coordinator(m_options);
        v1::SubmitJobRequest request = upload(coordinator);
        request.mutable_settings()->set_name("failing");
        const uint64_t failing = coordinator.submit(request).job_id();
        request.mutable_settings()->set_name("cancelled");
        const uint64_t cancelled = coordinator.submit(request).job_id();
        request.mutable_settings()->set_name("done");
        request.mutable_settings()->set_priority(3);
        const uint64_t done = coordinator.submit(request).job_id();
        request.mutable_settings()->set_name("running");
        request.mutable_settings()->set_priority(2);
        request.mutable_settings()->set_seed(11);
        request.mutable_settings()->set_integrator_override("normals");
        running = coordinator.submit(request).job_id();
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        // Job "done" (priority 3) renders completely, then "running" (2) partly.
        for (int i = 0; i < 18 + 5; ++i) {
            const v1::AcquireWorkResponse lease =
                coordinator.acquire(worker, std::chrono::steady_clock::now());
            ASSERT_TRUE(lease.has_work());
            ASSERT_EQ(lease.job().job_id(), i < 18 ? done : running);
            if (i == 18) description = lease.job();
            std::string compressed;
            v1::ResultChunk header = render(lease, worker, compressed);
            ASSERT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
        }
        coordinator.cancel(cancelled);
        // One failed attempt fails job "failing" (maxAttempts 1).
        for (;;) {
            const v1::AcquireWorkResponse lease =
                coordinator.acquire(worker, std::chrono::steady_clock::now());
            ASSERT_TRUE(lease.has_work());
            if (lease.job().job_id() != failing) continue;  // left leased, not persisted
            v1::ResultChunk header;
            header.set_worker_id(worker);
            header.set_lease_id(lease.lease_id());
            header.set_job_id(failing);
            header.set_unit_index(lease.unit().unit_index());
            header.set_error("out of memory");
            ASSERT_EQ(coordinator.report(header, ""), v1::RESULT_RECORDED);
            break;
        }
        before = coordinator.listJobs(0);
        coordinator.stop();
    }
    ASSERT_EQ(description.job_id(), running);
    Coordinator restarted(m_options);
    const std::vector<v1::JobStatus> after = restarted.listJobs(0);
    ASSERT_EQ(after.size(), before.size());
    for (size_t i = 0; i < after.size(); ++i) {
        v1::JobStatus expected = before[i], actual = after[i];
        // Counters of one process and clock readings are not state.
        for (v1::JobStatus* status : {&expected, &actual}) {
            status->clear_units_leased();
            status->clear_active_workers();
            status->clear_units_restored();
            status->clear_units_merged_this_run();
            status->clear_units_leased_this_run();
            status->clear_results_discarded();
            status->clear_checkpoints_written();
            status->clear_elapsed_seconds();
            status->clear_eta_seconds();
            status->clear_samples_per_second();
            status->clear_pass_data_builds();
        }
        EXPECT_EQ(actual.DebugString(), expected.DebugString()) << "job " << before[i].job_id();
    }
    // The description a worker gets for the resumed job is the one it got before, id included:
    // a worker caching scenes by job must load this job's scene.
    const uint64_t worker = restarted.registerWorker(thisBuild());
    const v1::AcquireWorkResponse lease =
        restarted.acquire(worker, std::chrono::steady_clock::now());
    ASSERT_TRUE(lease.has_work());
    EXPECT_EQ(lease.job().DebugString(), description.DebugString());
    restarted.stop();
}

TEST_F(CoordinatorJob, CountsThatWouldOverflowAreClampedOrRefused) {
    // A budget of 1 GiB, not the default half of the machine's memory: the job of 2^30 units
    // below must be refused on any machine.
    m_options.maxMemoryBytes = uint64_t(1) << 30;
    Coordinator coordinator(m_options);
    v1::SubmitJobRequest request = upload(coordinator);
    // Passes per unit beyond the passes: one chunk, not zero units.
    request.mutable_settings()->set_passes_per_unit(UINT32_MAX);
    const v1::JobStatus status = coordinator.submit(request);
    EXPECT_EQ(status.units_total(), 6u);
    EXPECT_EQ(status.settings().passes_per_unit(), 3u);
    renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
    EXPECT_EQ(coordinator.listJobs(status.job_id()).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(coordinator.snapshot(status.job_id(), false).film.serialize(), localFilm());
    // 1200 one-pixel tiles x 2^20 passes: about 2^30 units, which a 32-bit index still names;
    // refused for the coordinator memory they would take (about 100 GB, beyond the budget).
    request.mutable_settings()->set_tile_size(1);
    request.mutable_settings()->set_passes(1u << 20);
    request.mutable_settings()->set_passes_per_unit(1);
    try {
        coordinator.submit(request);
        FAIL() << "a job of 2^30 units was accepted";
    } catch (const FarmError& e) {
        EXPECT_NE(std::string(e.what()).find("units"), std::string::npos) << e.what();
    }
    EXPECT_EQ(coordinator.listJobs(0).size(), 1u);
}

TEST_F(CoordinatorJob, JobsBeyondTheMemoryBudgetAreRefused) {
    // Room for one 40x30 job of 18 units, not two.
    m_options.maxMemoryBytes = Coordinator::jobMemoryBytes(40, 30, 18) * 3 / 2;
    // The scene's meshes must fit the budget too while it is loaded at submit: one triangle.
    std::ofstream(m_dir / "scene/sphere.obj") << "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    Coordinator coordinator(m_options);
    const v1::SubmitJobRequest request = upload(coordinator);
    const uint64_t first = coordinator.submit(request).job_id();
    try {
        coordinator.submit(request);
        FAIL() << "the second job was accepted beyond the budget";
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, FarmError::Kind::ResourceExhausted);
        EXPECT_NE(std::string(e.what()).find("--max-memory"), std::string::npos) << e.what();
    }
    // 1200 one-pixel tiles x 3 passes: too many units for the budget even alone.
    v1::SubmitJobRequest small = request;
    small.mutable_settings()->set_tile_size(1);
    coordinator.cancel(first);  // ending a job gives its memory back
    EXPECT_THROW(coordinator.submit(small), FarmError);
    EXPECT_NO_THROW(coordinator.submit(request));
}

// A scene placing one mesh thousands of times is counted, not built, at submit: beyond
// --max-memory it is refused at once (building it took minutes and gigabytes), naming the figures.
TEST_F(CoordinatorJob, ScenesWhoseMeshesExceedTheMemoryBudgetAreRefusedBeforeTheyAreBuilt) {
    m_options.maxMemoryBytes = uint64_t(256) << 20;
    Coordinator coordinator(m_options);
    v1::SubmitJobRequest request = upload(coordinator);
    // The same bundle with the scene placing the sphere (9024 triangles) 2000 times: 18 million
    // triangles, about 2.8 GiB. (The client's own check would build it: its blobs go up here.)
    std::string spheres;
    for (int i = 0; i < 2000; ++i)
        spheres += absl::StrFormat(
            "<mesh type=\"obj\"><string name=\"filename\" value=\"sphere.obj\"/><transform "
            "name=\"toWorld\"><translate value=\"%d, 0, 0\"/></transform></mesh>\n",
            3 * i);
    writeScene(R"(<integrator type="normals"/>)", 40, 30, spheres);
    const std::string text = farm::readFile((m_dir / "scene/s.xml").string());
    farm::Bundle bundle = farm::fromProto(request.bundle());
    for (farm::BundleEntry& file : bundle.files)
        if (file.path == bundle.scenePath) {
            file.sha256 = farm::sha256Hex(text);
            file.size = text.size();
            BlobStore::Upload blob(coordinator.blobs(), file.sha256);
            blob.append(text);
            blob.commit();
        }
    *request.mutable_bundle() = farm::toProto(bundle);
    const auto start = std::chrono::steady_clock::now();
    try {
        coordinator.submit(request);
        FAIL() << "a scene of 18 million triangles was accepted within 256 MiB";
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, FarmError::Kind::ResourceExhausted);
        const std::string message = e.what();
        for (const std::string& expected :
             {std::string("s.xml:"), std::string("(mesh type=\"obj\")"),
              std::string("its 2001 meshes have 18057024 triangles"),
              std::string("more than the limit of 256 MiB (--max-memory)")})
            EXPECT_NE(message.find(expected), std::string::npos) << expected << " in " << message;
        EXPECT_EQ(message.find(m_options.stateDirectory), std::string::npos) << message;
    }
    // Building it took about 40 s here; counting it takes a fraction of a second.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
              10.0);
    EXPECT_TRUE(coordinator.listJobs(0).empty());
}

// A job keeps the film layout it was admitted with, and the lease tells the worker which: a
// progressive photon job admitted by a coordinator that kept no smaller radius's image (an older
// version: its row says 0) is leased, rendered and merged without one after an upgrade, instead
// of having every result refused for its size.
TEST_F(CoordinatorJob, AJobKeepsTheFilmLayoutItWasAdmittedWith) {
    writeProgressivePhotonScene();
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator, 2)).job_id();
        const v1::AcquireWorkResponse lease = coordinator.acquire(
            coordinator.registerWorker(thisBuild()), std::chrono::steady_clock::now());
        ASSERT_TRUE(lease.has_work());
        EXPECT_TRUE(lease.unit().smaller_radius()) << "a progressive photon job keeps it";
        coordinator.stop();
    }
    // What an older coordinator stored for the same job (without a record digest).
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open((m_dir / "state/state.sqlite").c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "UPDATE jobs SET smaller_radius = 0, record_sha256 = ''", nullptr,
                           nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
    Coordinator coordinator(m_options);
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    renderAllUnits(coordinator, worker, [](const v1::AcquireWorkResponse& lease) {
        EXPECT_FALSE(lease.unit().smaller_radius());
    });
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).state(), v1::JOB_STATE_DONE);
    coordinator.stop();
}

// A preview of a progressive photon job holds every sum its film keeps, the smaller radius's
// image included (copyFilmInBands copies the film's whole layout).
TEST_F(CoordinatorJob, APreviewKeepsTheSmallerRadiusImage) {
    writeProgressivePhotonScene();
    Coordinator coordinator(m_options);
    const v1::JobStatus status = coordinator.submit(upload(coordinator, 2));
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    FilmBlock expected(0, 0, 40, 30, PassHalves::Kept, SmallerRadius::Kept);
    for (uint32_t unit = 0; unit + 1 < status.units_total(); ++unit) {
        const v1::AcquireWorkResponse lease =
            coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(lease.has_work());
        std::string compressed;
        const v1::ResultChunk header = render(lease, worker, compressed);
        ASSERT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
        FilmBlock block(header.block_x0(), header.block_y0(), header.block_width(),
                        header.block_height(), PassHalves::Kept, SmallerRadius::Kept);
        farm::decompressFilm(compressed, block);
        expected.add(block);
    }
    const FilmBlock preview = coordinator.snapshot(status.job_id(), true).film;
    ASSERT_TRUE(preview.keepsSmallerRadius());
    EXPECT_EQ(preview.serialize(), expected.serialize());
}

// A preview copies the job's film in bands of rows (about 1 MiB each), one lock hold per band:
// the copy of a film of several bands must still be the whole film, every row once.
TEST_F(CoordinatorJob, APreviewOfAFilmOfSeveralBandsIsTheWholeFilm) {
    // 192 x 128 pixels at 128 bytes: 3 MiB, four bands of 42, 42, 42 and 2 rows.
    writeScene(R"(<integrator type="normals"/>)", 192, 128);
    Coordinator coordinator(m_options);
    const v1::JobStatus status = coordinator.submit(upload(coordinator, 2));
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    FilmBlock expected(0, 0, 192, 128);
    for (uint32_t unit = 0; unit + 1 < status.units_total(); ++unit) {
        const v1::AcquireWorkResponse lease =
            coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(lease.has_work());
        std::string compressed;
        const v1::ResultChunk header = render(lease, worker, compressed);
        ASSERT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
        FilmBlock block(header.block_x0(), header.block_y0(), header.block_width(),
                        header.block_height());
        farm::decompressFilm(compressed, block);
        expected.add(block);
    }
    ASSERT_EQ(coordinator.listJobs(status.job_id()).at(0).state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(coordinator.snapshot(status.job_id(), true).film.serialize(), expected.serialize());
}

// A final checkpoint that cannot be written (here: the job's directory replaced by a file, which
// fails for root too) leaves the job running with the error shown, never "done" without its film
// on disk and never stuck: the next attempt, or a graceful stop, finishes it.
TEST_F(CoordinatorJob, AFailingFinalCheckpointIsRetriedAndNeverHangs) {
    const std::string expected = localFilm();
    for (const bool gracefulStop : {true, false}) {
        SCOPED_TRACE(gracefulStop ? "graceful stop" : "background retry");
        m_options.checkpointIntervalSeconds = gracefulStop ? 3600 : 0.05;
        uint64_t jobId = 0;
        fs::path directory, aside;
        {
            Coordinator coordinator(m_options);
            coordinator.start();
            jobId = coordinator.submit(upload(coordinator)).job_id();
            directory = coordinator.jobDirectory(jobId);
            aside = directory.string() + ".aside";
            const uint64_t worker = coordinator.registerWorker(thisBuild());
            fs::rename(directory, aside);
            std::ofstream(directory) << "not a directory";
            renderAllUnits(coordinator, worker);
            v1::JobStatus status = coordinator.listJobs(jobId).at(0);
            EXPECT_EQ(status.state(), v1::JOB_STATE_RUNNING);
            EXPECT_EQ(status.units_done(), status.units_total());
            EXPECT_NE(status.error().find("cannot write the checkpoint"), std::string::npos)
                << status.error();
            fs::remove(directory);
            fs::rename(aside, directory);
            if (!gracefulStop) {
                EXPECT_TRUE(waitFor([&] {
                    return coordinator.listJobs(jobId).at(0).state() == v1::JOB_STATE_DONE;
                })) << "the final checkpoint was not retried";
                EXPECT_TRUE(coordinator.listJobs(jobId).at(0).error().empty());
            }
            coordinator.stop();
        }
        Coordinator restarted(m_options);
        EXPECT_EQ(restarted.listJobs(jobId).at(0).state(), v1::JOB_STATE_DONE);
        EXPECT_EQ(restarted.snapshot(jobId, false).film.serialize(), expected);
        restarted.stop();
    }
}

// Leases survive a coordinator restart only for the worker that really holds them: a forged
// token or invented lease is fenced, and so is a lease that expired in the current process.
TEST_F(CoordinatorJob, OnlyLeasesGrantedEarlierAreReadopted) {
    v1::AcquireWorkResponse held;
    uint64_t jobId = 0, worker = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        worker = coordinator.registerWorker(thisBuild());
        held = coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(held.has_work());
        coordinator.stop();
    }
    m_options.leaseSeconds = 0.2;
    m_options.checkpointIntervalSeconds = 3600;
    Coordinator coordinator(m_options);
    const auto heartbeat = [&](uint64_t leaseId, uint32_t unit, const std::string& token) {
        v1::HeartbeatRequest request;
        request.set_worker_id(worker);
        request.add_lease_ids(leaseId);
        v1::HeldUnit& heldUnit = *request.add_held_units();
        heldUnit.set_job_id(jobId);
        heldUnit.set_unit_index(unit);
        heldUnit.set_lease_token(token);
        return coordinator.heartbeat(request).drop_lease_ids_size() == 0;
    };
    const uint32_t unit = held.unit().unit_index();
    std::string forged = held.lease_token();
    forged.back() ^= 1;
    EXPECT_FALSE(heartbeat(held.lease_id() + 1, unit + 1, held.lease_token()))
        << "a token re-adopted a unit it was not granted for";
    EXPECT_FALSE(heartbeat(held.lease_id(), unit, forged)) << "a forged token was accepted";
    EXPECT_FALSE(heartbeat(held.lease_id(), unit, "")) << "a lease without a token was adopted";
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).units_leased(), 0u);
    EXPECT_TRUE(heartbeat(held.lease_id(), unit, held.lease_token()))
        << "the lease granted before the restart was not re-adopted";
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).units_leased(), 1u);

    // A lease of this process that expires is fenced, also when its holder comes back.
    const uint64_t other = coordinator.registerWorker(thisBuild());
    const v1::AcquireWorkResponse lease =
        coordinator.acquire(other, std::chrono::steady_clock::now());
    ASSERT_TRUE(lease.has_work());
    coordinator.start();
    ASSERT_TRUE(waitFor([&] { return coordinator.listJobs(jobId).at(0).attempts_failed() >= 2; }));
    v1::HeartbeatRequest late;
    late.set_worker_id(other);
    late.add_lease_ids(lease.lease_id());
    v1::HeldUnit& lateUnit = *late.add_held_units();
    lateUnit.set_job_id(jobId);
    lateUnit.set_unit_index(lease.unit().unit_index());
    lateUnit.set_lease_token(lease.lease_token());
    EXPECT_EQ(coordinator.heartbeat(late).drop_lease_ids_size(), 1)
        << "an expired lease of this process was re-adopted instead of fenced";
    coordinator.stop();
}

// Registers `registration`, expecting a refusal of `kind` whose message mentions `mention`.
void expectRefusedRegistration(Coordinator& coordinator, const v1::RegisterRequest& registration,
                               FarmError::Kind kind, const std::string& mention) {
    try {
        coordinator.registerWorker(registration);
        ADD_FAILURE() << "a worker joined: " << registration.ShortDebugString();
    } catch (const FarmError& e) {
        EXPECT_EQ(e.kind, kind) << e.what();
        EXPECT_NE(std::string(e.what()).find(mention), std::string::npos) << e.what();
    }
}

// A worker of another build, or one that states no version, cannot join: the units of two builds
// need not sum to the same image. Refused workers leave no record.
TEST_F(CoordinatorJob, WorkersOfAnotherVersionOrNoneAreRefused) {
    Coordinator coordinator(m_options);
    const std::string ours = ALPHORN_VERSION;
    const std::string otherPatch = ours.substr(0, ours.rfind('.') + 1) + "999";
    for (const std::string& version : {std::string(), otherPatch, "9" + ours, ours + "-dirty"}) {
        v1::RegisterRequest registration;
        registration.set_version(version);
        expectRefusedRegistration(coordinator, registration, FarmError::Kind::FailedPrecondition,
                                  ours);
    }
    EXPECT_TRUE(coordinator.listWorkers(true).empty());
    EXPECT_GT(coordinator.registerWorker(thisBuild()), 0u);
    EXPECT_EQ(coordinator.listWorkers(true).size(), 1u);
}

// Nor can a worker of this build on another kind of CPU, or one that states no platform: Embree's
// kernels for another instruction set round hits differently.
TEST_F(CoordinatorJob, WorkersOfAnotherPlatformOrNoneAreRefused) {
    Coordinator coordinator(m_options);
    const std::string ours = renderPlatform();
    for (const std::string& platform :
         {std::string(), std::string("aarch64"), std::string("x86-64 sse2"), ours + " avx512"}) {
        if (platform == ours) continue;
        v1::RegisterRequest registration = thisBuild();
        registration.set_platform(platform);
        expectRefusedRegistration(coordinator, registration, FarmError::Kind::FailedPrecondition,
                                  ours);
    }
    EXPECT_TRUE(coordinator.listWorkers(true).empty());
    EXPECT_GT(coordinator.registerWorker(thisBuild()), 0u);
}

// A worker's name is listed, logged and exported as a metrics label: one that is too long or
// holds control characters (a forged log line, terminal escapes) is refused.
TEST_F(CoordinatorJob, WorkerNamesThatAreTooLongOrHoldControlCharactersAreRefused) {
    Coordinator coordinator(m_options);
    for (const std::string& name : {std::string(257, 'w'), std::string("w\nlevel=error"),
                                    std::string("w\x1b]0;title\x07"), std::string("w\0x", 3)}) {
        v1::RegisterRequest registration = thisBuild();
        registration.set_name(name);
        expectRefusedRegistration(coordinator, registration, FarmError::Kind::InvalidArgument,
                                  "the worker's name");
    }
    EXPECT_TRUE(coordinator.listWorkers(true).empty());
}

TEST_F(CoordinatorJob, WorkersNotSeenForTheKeepTimeAreForgotten) {
    m_options.keepFinishedSeconds = 1000;
    const double now =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    {
        Coordinator coordinator(m_options);
        coordinator.registerWorker(thisBuild());
        coordinator.pruneFinishedJobs(now + 900);
        EXPECT_EQ(coordinator.listWorkers(true).size(), 1u);
        coordinator.pruneFinishedJobs(now + 1100);
        EXPECT_EQ(coordinator.listWorkers(true).size(), 0u);
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    EXPECT_EQ(restarted.listWorkers(true).size(), 0u) << "the worker's row was kept";
}

// A damaged job record fails that job with a message naming it and the database; the other
// jobs resume and finish. The row has no record digest (as rows stored before it existed), so
// what resumeJob() checks is what finds the damage.
TEST_F(CoordinatorJob, ADamagedJobRecordFailsOnlyThatJob) {
    uint64_t damaged = 0, healthy = 0;
    {
        Coordinator coordinator(m_options);
        damaged = coordinator.submit(upload(coordinator)).job_id();
        healthy = coordinator.submit(upload(coordinator)).job_id();
        coordinator.stop();
    }
    {
        StateDatabase db(m_options.stateDirectory + "/state.sqlite");
        v1::JobDescription description;
        description.mutable_settings()->set_tile_size(16);  // passes 0: not a valid job
        db.execute("UPDATE jobs SET description = ?, record_sha256 = '' WHERE id = ?",
                   {description.SerializeAsString(), int64_t(damaged)});
    }
    Coordinator coordinator(m_options);
    const v1::JobStatus status = coordinator.listJobs(damaged).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_FAILED);
    EXPECT_NE(
        status.error().find("cannot resume job " + std::to_string(damaged) + " from state.sqlite"),
        std::string::npos)
        << status.error();
    EXPECT_EQ(status.error().find(m_options.stateDirectory), std::string::npos) << status.error();
    renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
    EXPECT_EQ(coordinator.listJobs(healthy).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(coordinator.snapshot(healthy, false).film.serialize(), localFilm());
    const std::string message = refusal([&] { coordinator.retry(damaged); });
    EXPECT_NE(message.find("its record could not be resumed"), std::string::npos) << message;
    coordinator.stop();
}

// Damaged records fail their jobs at start and keep them (listed with the error, their files in
// place) for the keep time: a state that is no job state, and sizes beyond this coordinator's
// limits, which are refused before anything is allocated for them. The sizes are changed in rows
// without a record digest (as rows stored before it existed), which only these checks guard.
TEST_F(CoordinatorJob, DamagedRecordsFailTheirJobsAndKeepThem) {
    m_options.maxMemoryBytes = uint64_t(256) << 20;  // an 8000x8000 film needs ~8 GB
    const std::pair<std::string, std::string> damages[] = {
        {"UPDATE jobs SET state = 77 WHERE id = ?", "state 77 is not a job state"},
        {"UPDATE jobs SET width = 100000, height = 100000, record_sha256 = '' WHERE id = ?",
         "--max-image-pixels"},
        {"UPDATE jobs SET width = 8000, height = 8000, record_sha256 = '' WHERE id = ?",
         "--max-memory"},
    };
    std::vector<uint64_t> damaged;
    uint64_t healthy = 0;
    {
        Coordinator coordinator(m_options);
        for (size_t i = 0; i < std::size(damages); ++i)
            damaged.push_back(coordinator.submit(upload(coordinator)).job_id());
        healthy = coordinator.submit(upload(coordinator)).job_id();
        coordinator.stop();
    }
    {
        StateDatabase db(m_options.stateDirectory + "/state.sqlite");
        for (size_t i = 0; i < std::size(damages); ++i)
            db.execute(damages[i].first, {int64_t(damaged[i])});
    }
    Coordinator coordinator(m_options);
    const double now =
        std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
    coordinator.pruneFinishedJobs(now + 60);
    for (size_t i = 0; i < std::size(damages); ++i) {
        const auto listed = coordinator.listJobs(damaged[i]);
        ASSERT_EQ(listed.size(), 1u) << "job " << damaged[i] << " was removed at start";
        EXPECT_EQ(listed[0].state(), v1::JOB_STATE_FAILED);
        EXPECT_NE(listed[0].error().find("cannot resume job " + std::to_string(damaged[i])),
                  std::string::npos)
            << listed[0].error();
        EXPECT_NE(listed[0].error().find(damages[i].second), std::string::npos)
            << listed[0].error();
        EXPECT_TRUE(fs::exists(coordinator.jobDirectory(damaged[i])));
    }
    renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
    EXPECT_EQ(coordinator.listJobs(healthy).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(coordinator.snapshot(healthy, false).film.serialize(), localFilm());
    coordinator.stop();
}

// A checkpoint names the job it belongs to: one copied into another job's directory (the same
// image shape, another seed) is not taken for that job's, which is rendered from nothing instead
// of finishing with the other job's image.
TEST_F(CoordinatorJob, AnotherJobsCheckpointIsNotTakenForThisJobs) {
    uint64_t finished = 0, running = 0;
    {
        Coordinator coordinator(m_options);
        finished = coordinator.submit(upload(coordinator)).job_id();
        renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
        v1::SubmitJobRequest other = upload(coordinator);
        other.mutable_settings()->set_seed(99);
        running = coordinator.submit(other).job_id();
        coordinator.stop();
        fs::copy_file(coordinator.jobDirectory(finished) + "/film.ckpt",
                      coordinator.jobDirectory(running) + "/film.ckpt",
                      fs::copy_options::overwrite_existing);
    }
    Coordinator coordinator(m_options);
    const v1::JobStatus status = coordinator.listJobs(running).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(status.units_done(), 0u) << "the other job's merged units were taken up";
    EXPECT_EQ(coordinator.listJobs(finished).at(0).state(), v1::JOB_STATE_DONE);
    coordinator.stop();
}

TEST_F(CoordinatorJob, AFinishedJobWhoseCheckpointIsLostIsRenderedAgain) {
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
        coordinator.stop();
        fs::remove(coordinator.jobDirectory(jobId) + "/film.ckpt");
    }
    Coordinator coordinator(m_options);
    const v1::JobStatus status = coordinator.listJobs(jobId).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_RUNNING) << "done without its film";
    EXPECT_EQ(status.units_done(), 0u);
    renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
    EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), localFilm());
    coordinator.stop();
}

// A crash inside submit() after the job's record but before its directory: the restarted
// coordinator makes the directory, so the job's checkpoints can be written and it finishes
// (without that, its final checkpoint would fail for ever and it would stay running).
TEST_F(CoordinatorJob, AJobRecordedWithoutItsDirectoryRunsToTheEnd) {
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        coordinator.stop();
        fs::remove_all(coordinator.jobDirectory(jobId));
    }
    Coordinator coordinator(m_options);
    renderAllUnits(coordinator, coordinator.registerWorker(thisBuild()));
    const v1::JobStatus status = coordinator.listJobs(jobId).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_DONE) << status.error();
    EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), localFilm());
    coordinator.stop();
}

// ---- job and worker control ---------------------------------------------------------------

// Paused: no new leases, while the lease already out merges; resumed: leasing again. The pause
// survives a restart; a job that ended cannot be paused or resumed.
TEST_F(CoordinatorJob, APausedJobLeasesNothingNewButMergesWhatIsOut) {
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        const v1::AcquireWorkResponse out =
            coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(out.has_work());
        EXPECT_TRUE(coordinator.setPaused(jobId, true).paused());
        EXPECT_FALSE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work())
            << "a paused job leased a unit";
        std::string compressed;
        EXPECT_EQ(coordinator.report(render(out, worker, compressed), compressed),
                  v1::RESULT_MERGED);
        EXPECT_EQ(coordinator.listJobs(jobId).at(0).units_done(), 1u);
        coordinator.stop();
    }
    Coordinator coordinator(m_options);
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    EXPECT_TRUE(coordinator.listJobs(jobId).at(0).paused()) << "the pause was not stored";
    EXPECT_FALSE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work());
    const v1::JobStatus resumed = coordinator.setPaused(jobId, false);
    EXPECT_FALSE(resumed.paused());
    EXPECT_EQ(resumed.state(), v1::JOB_STATE_RUNNING);
    renderAllUnits(coordinator, worker);
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), localFilm());
    const std::string message = refusal([&] { coordinator.setPaused(jobId, true); });
    EXPECT_NE(message.find("it is done; only a running job can be paused"), std::string::npos)
        << message;
    EXPECT_NE(refusal([&] { coordinator.setPaused(jobId, false); }), "");
    coordinator.stop();
}

// A new priority reorders the queue at once and is stored; an ended job keeps its own.
TEST_F(CoordinatorJob, APriorityChangeReordersTheQueue) {
    uint64_t first = 0, second = 0;
    {
        Coordinator coordinator(m_options);
        first = coordinator.submit(upload(coordinator)).job_id();
        second = coordinator.submit(upload(coordinator)).job_id();
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        EXPECT_EQ(coordinator.acquire(worker, std::chrono::steady_clock::now()).unit().job_id(),
                  first);
        EXPECT_EQ(coordinator.setPriority(second, 7).settings().priority(), 7);
        EXPECT_EQ(coordinator.acquire(worker, std::chrono::steady_clock::now()).unit().job_id(),
                  second)
            << "the higher priority did not go first";
        coordinator.stop();
    }
    Coordinator coordinator(m_options);
    EXPECT_EQ(coordinator.listJobs(second).at(0).settings().priority(), 7) << "not stored";
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    EXPECT_EQ(coordinator.acquire(worker, std::chrono::steady_clock::now()).unit().job_id(),
              second);
    coordinator.cancel(first);
    const std::string message = refusal([&] { coordinator.setPriority(first, 3); });
    EXPECT_NE(message.find("it is cancelled"), std::string::npos) << message;
    coordinator.stop();
}

// A cancelled job run again keeps the units of its checkpoint, renders the rest and ends with
// the bytes of a fresh job; units merged after the last checkpoint are rendered again.
TEST_F(CoordinatorJob, ARetriedCancelledJobGivesTheBytesOfAFreshJob) {
    m_options.checkpointIntervalSeconds = 0;  // every tick() checkpoints
    Coordinator coordinator(m_options);
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    const auto mergeOne = [&] {
        const auto lease = coordinator.acquire(worker, std::chrono::steady_clock::now());
        std::string compressed;
        ASSERT_EQ(coordinator.report(render(lease, worker, compressed), compressed),
                  v1::RESULT_MERGED);
    };
    for (int i = 0; i < 5; ++i) mergeOne();
    coordinator.tick();  // checkpoints 5 units
    mergeOne();          // not in the checkpoint
    EXPECT_NE(refusal([&] { coordinator.retry(jobId); }).find("it is running"), std::string::npos);
    coordinator.cancel(jobId);
    const v1::JobStatus retried = coordinator.retry(jobId);
    EXPECT_EQ(retried.state(), v1::JOB_STATE_RUNNING);
    EXPECT_TRUE(retried.error().empty());
    EXPECT_EQ(retried.units_restored(), 5u);
    EXPECT_EQ(retried.units_done(), 5u);
    renderAllUnits(coordinator, worker);
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), localFilm());
    EXPECT_NE(refusal([&] { coordinator.retry(jobId); }).find("it is done"), std::string::npos);
    const v1::GetJobLogResponse log = coordinator.jobLog(jobId, 0);
    EXPECT_TRUE(hasEvent(log, v1::JOB_EVENT_CANCELLED));
    EXPECT_TRUE(hasEvent(log, v1::JOB_EVENT_RETRIED));
    coordinator.stop();
}

// A job failed by a poison unit runs again with its attempts forgotten.
TEST_F(CoordinatorJob, ARetriedFailedJobForgetsItsAttempts) {
    m_options.maxAttempts = 2;
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        for (uint32_t attempt = 0; attempt < 2; ++attempt) {
            const auto lease = coordinator.acquire(worker, std::chrono::steady_clock::now());
            v1::ResultChunk failure;
            failure.set_worker_id(worker);
            failure.set_lease_id(lease.lease_id());
            failure.set_job_id(jobId);
            failure.set_unit_index(lease.unit().unit_index());
            failure.set_error("the renderer ran out of memory");
            EXPECT_EQ(coordinator.report(failure, ""), v1::RESULT_RECORDED);
        }
        const v1::JobStatus failed = coordinator.listJobs(jobId).at(0);
        ASSERT_EQ(failed.state(), v1::JOB_STATE_FAILED);
        const v1::GetJobLogResponse log = coordinator.jobLog(jobId, 0);
        EXPECT_TRUE(hasEvent(log, v1::JOB_EVENT_POISONED));
        bool sawError = false;
        for (const v1::JobEvent& event : log.events())
            sawError =
                sawError ||
                (event.kind() == v1::JOB_EVENT_FAILED && event.worker_id() == worker &&
                 event.message().find("the renderer ran out of memory") != std::string::npos);
        EXPECT_TRUE(sawError) << "the worker's error text is not in the log";
        coordinator.stop();
    }
    {
        Coordinator coordinator(m_options);
        const v1::JobStatus retried = coordinator.retry(jobId);
        EXPECT_EQ(retried.attempts_failed(), 0u);
        EXPECT_EQ(retried.state(), v1::JOB_STATE_RUNNING);
        coordinator.stop();
    }
    Coordinator restarted(m_options);  // the retry is stored
    EXPECT_EQ(restarted.listJobs(jobId).at(0).state(), v1::JOB_STATE_RUNNING);
    EXPECT_EQ(restarted.listJobs(jobId).at(0).attempts_failed(), 0u);
    renderAllUnits(restarted, restarted.registerWorker(thisBuild()));
    EXPECT_EQ(restarted.listJobs(jobId).at(0).state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(restarted.snapshot(jobId, false).film.serialize(), localFilm());
    restarted.stop();
}

// Delete: a running job is refused unless cancelled with it; the record, the directory and the
// blobs only it used go at once (a blob another job uses stays; the uses of a blob before the
// job's submission do not keep it), also for a restart.
TEST_F(CoordinatorJob, DeleteRemovesTheJobItsFilesAndTheBlobsOnlyItUsed) {
    uint64_t deleted = 0, kept = 0;
    std::string scene, sphere;
    {
        Coordinator coordinator(m_options);
        const v1::SubmitJobRequest request = upload(coordinator);
        for (const v1::BundleFile& file : request.bundle().files())
            (file.path() == "sphere.obj" ? sphere : scene) = file.sha256();
        coordinator.touchBlobs({scene, sphere});  // as the client's HasBlobs before it submits
        deleted = coordinator.submit(request).job_id();
        std::string message = refusal([&] { coordinator.deleteJob(deleted, false); });
        EXPECT_NE(message.find("is running: cancel it first"), std::string::npos) << message;
        EXPECT_TRUE(fs::exists(coordinator.jobDirectory(deleted)));
        // A second job shares sphere.obj but not the scene file.
        std::ofstream(m_dir / "scene/s.xml", std::ios::app) << "<!-- another scene -->\n";
        kept = coordinator.submit(upload(coordinator)).job_id();
        const v1::DeleteJobResponse response = coordinator.deleteJob(deleted, true);
        EXPECT_TRUE(response.cancelled());
        EXPECT_EQ(response.blobs_removed(), 1u);
        EXPECT_FALSE(coordinator.blobs().has(scene));
        EXPECT_TRUE(coordinator.blobs().has(sphere)) << "a blob another job uses was removed";
        EXPECT_FALSE(fs::exists(coordinator.jobDirectory(deleted)));
        EXPECT_THROW(coordinator.listJobs(deleted), FarmError);
        EXPECT_THROW(coordinator.jobLog(deleted, 0), FarmError);
        EXPECT_EQ(coordinator.listJobs(0).size(), 1u);
        coordinator.tick();  // frees the deleted job
        coordinator.stop();
    }
    Coordinator coordinator(m_options);
    EXPECT_THROW(coordinator.listJobs(deleted), FarmError) << "the deleted job came back";
    EXPECT_EQ(coordinator.listJobs(kept).at(0).state(), v1::JOB_STATE_RUNNING);
    coordinator.cancel(kept);
    EXPECT_EQ(coordinator.deleteJob(kept, false).blobs_removed(), 2u);
    EXPECT_THROW(coordinator.deleteJob(kept, false), FarmError);
    coordinator.stop();
}

// Runs `call` and returns the kind of the FarmError it throws, with its message in `message`.
template <typename Call>
std::optional<FarmError::Kind> farmErrorKind(Call call, std::string* message = nullptr) {
    try {
        call();
    } catch (const FarmError& e) {
        if (message) *message = e.what();
        return e.kind;
    }
    return std::nullopt;
}

// A client that lost RetryJob's answer (the coordinator restarted after the job ran again)
// sends the same request again: its request id, recorded with the retry, makes that give the
// first answer and change nothing, also after a restart, where without it the job (running
// again) would be refused. An id is one request's: sent with another job or a delete, it is
// refused.
TEST_F(CoordinatorJob, ARetrySentAgainGetsTheFirstAnswer) {
    const std::string id = "0123456789abcdef0123456789abcdef";
    uint64_t jobId = 0, other = 0;
    v1::JobStatus first;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        other = coordinator.submit(upload(coordinator)).job_id();
        coordinator.cancel(jobId);
        coordinator.cancel(other);
        first = coordinator.retry(jobId, id);
        EXPECT_EQ(first.state(), v1::JOB_STATE_RUNNING);
        EXPECT_EQ(coordinator.retry(jobId, id).SerializeAsString(), first.SerializeAsString());
        const std::string refused = refusal([&] { coordinator.retry(jobId, "another-request"); });
        EXPECT_NE(refused.find("it is running"), std::string::npos) << refused;
        std::string message;
        EXPECT_EQ(farmErrorKind([&] { coordinator.retry(other, id); }, &message),
                  FarmError::Kind::InvalidArgument);
        EXPECT_NE(message.find("request id " + id + " was sent with a retry of job"),
                  std::string::npos)
            << message;
        EXPECT_EQ(farmErrorKind([&] { coordinator.deleteJob(jobId, true, id); }),
                  FarmError::Kind::InvalidArgument);
        EXPECT_EQ(coordinator.listJobs(other).at(0).state(), v1::JOB_STATE_CANCELLED);
        EXPECT_EQ(coordinator.listJobs(jobId).at(0).state(), v1::JOB_STATE_RUNNING);
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    EXPECT_EQ(restarted.retry(jobId, id).SerializeAsString(), first.SerializeAsString());
    const auto kinds = eventKinds(restarted.jobLog(jobId, 0));
    EXPECT_EQ(std::count(kinds.begin(), kinds.end(), v1::JOB_EVENT_RETRIED), 1);
    restarted.stop();
}

// The same for DeleteJob, whose job is gone when the request comes again: the record outlives
// the job's row, for a bounded time (kControlRequestKeepSeconds), after which the request is
// forgotten and the job unknown.
TEST_F(CoordinatorJob, ADeleteSentAgainGetsTheFirstAnswerUntilItsRecordExpires) {
    const std::string id = "fedcba9876543210fedcba9876543210";
    uint64_t jobId = 0;
    v1::DeleteJobResponse first;
    {
        Coordinator coordinator(m_options);
        jobId = coordinator.submit(upload(coordinator)).job_id();
        first = coordinator.deleteJob(jobId, true, id);
        EXPECT_TRUE(first.cancelled());
        EXPECT_EQ(first.blobs_removed(), 2u);
        EXPECT_EQ(coordinator.deleteJob(jobId, true, id).SerializeAsString(),
                  first.SerializeAsString());
        EXPECT_EQ(farmErrorKind([&] { coordinator.deleteJob(jobId, true); }),
                  FarmError::Kind::NotFound);
        coordinator.tick();  // frees the deleted job
        coordinator.stop();
    }
    Coordinator restarted(m_options);
    EXPECT_EQ(restarted.deleteJob(jobId, true, id).SerializeAsString(), first.SerializeAsString());
    const double now = SystemClock().wallSeconds();
    restarted.pruneFinishedJobs(now + kControlRequestKeepSeconds - 3600);
    EXPECT_EQ(restarted.deleteJob(jobId, true, id).SerializeAsString(), first.SerializeAsString());
    restarted.pruneFinishedJobs(now + kControlRequestKeepSeconds + 3600);
    EXPECT_EQ(farmErrorKind([&] { restarted.deleteJob(jobId, true, id); }),
              FarmError::Kind::NotFound);
    restarted.stop();
}

TEST_F(CoordinatorJob, AMalformedRequestIdIsRefused) {
    Coordinator coordinator(m_options);
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    coordinator.cancel(jobId);
    for (const std::string& id : {std::string(65, 'a'), std::string("a b"), std::string("a\nb")}) {
        std::string message;
        EXPECT_EQ(farmErrorKind([&] { coordinator.retry(jobId, id); }, &message),
                  FarmError::Kind::InvalidArgument);
        EXPECT_NE(message.find("request id"), std::string::npos) << message;
        EXPECT_EQ(farmErrorKind([&] { coordinator.deleteJob(jobId, false, id); }),
                  FarmError::Kind::InvalidArgument);
    }
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).state(), v1::JOB_STATE_CANCELLED);
    coordinator.stop();
}

// Fields of the description this coordinator does not know (a newer client's) are dropped at
// admission. Kept, they would be serialized after the known fields here, but in field order
// (JobSettings field 8 between name = 6 and owner = 20) by a coordinator upgraded to know them,
// which would find the record's digest changed at start and fail the running job as damaged.
TEST_F(CoordinatorJob, FieldsUnknownToTheCoordinatorAreNotStoredWithTheJob) {
    uint64_t jobId = 0;
    {
        Coordinator coordinator(m_options);
        v1::SubmitJobRequest request = upload(coordinator);
        request.mutable_settings()
            ->GetReflection()
            ->MutableUnknownFields(request.mutable_settings())
            ->AddVarint(8, 1);
        request.mutable_bundle()
            ->mutable_files(0)
            ->GetReflection()
            ->MutableUnknownFields(request.mutable_bundle()->mutable_files(0))
            ->AddLengthDelimited(9, "newer");
        jobId = coordinator.submit(request).job_id();
        coordinator.stop();
    }
    {
        StateDatabase db(m_options.stateDirectory + "/state.sqlite");
        const auto rows = db.query("SELECT description FROM jobs WHERE id = ?", {int64_t(jobId)});
        ASSERT_EQ(rows.size(), 1u);
        v1::JobDescription stored;
        ASSERT_TRUE(stored.ParseFromString(StateDatabase::text(rows[0][0])));
        v1::JobDescription known = stored;
        known.DiscardUnknownFields();
        EXPECT_EQ(stored.SerializeAsString(), known.SerializeAsString())
            << "the stored description keeps fields this coordinator does not know";
    }
    Coordinator restarted(m_options);
    const v1::JobStatus status = restarted.listJobs(jobId).at(0);
    EXPECT_EQ(status.state(), v1::JOB_STATE_RUNNING) << status.error();
    renderAllUnits(restarted, restarted.registerWorker(thisBuild()));
    EXPECT_EQ(restarted.snapshot(jobId, false).film.serialize(), localFilm());
    restarted.stop();
}

// The event log records the job's life in order and is stored with it.
TEST_F(CoordinatorJob, TheEventLogRecordsTheJobsLifeAndSurvivesARestart) {
    m_options.checkpointIntervalSeconds = 0;
    uint64_t jobId = 0;
    std::vector<v1::JobEventKind> before;
    {
        Coordinator coordinator(m_options);
        v1::SubmitJobRequest request = upload(coordinator);
        request.mutable_settings()->set_owner("ana@render-1");
        jobId = coordinator.submit(request).job_id();
        const v1::JobStatus status = coordinator.listJobs(jobId).at(0);
        EXPECT_EQ(status.settings().owner(), "ana@render-1");
        EXPECT_GT(status.submitted_at_unix_seconds(), 1.5e9);
        coordinator.setPaused(jobId, true);
        coordinator.setPaused(jobId, false);
        coordinator.setPriority(jobId, 4);
        const uint64_t worker = coordinator.registerWorker(thisBuild());
        renderAllUnits(coordinator, worker);
        const v1::GetJobLogResponse log = coordinator.jobLog(jobId, 0);
        before = eventKinds(log);
        ASSERT_GE(before.size(), 6u);
        EXPECT_EQ(before[0], v1::JOB_EVENT_SUBMITTED);
        EXPECT_NE(log.events(0).message().find("ana@render-1"), std::string::npos);
        EXPECT_EQ(before[1], v1::JOB_EVENT_PAUSED);
        EXPECT_EQ(before[2], v1::JOB_EVENT_RESUMED);
        EXPECT_EQ(before[3], v1::JOB_EVENT_PRIORITY_CHANGED);
        EXPECT_EQ(log.events(3).message(), "priority 0 -> 4");
        EXPECT_EQ(before[4], v1::JOB_EVENT_LEASED);
        EXPECT_EQ(log.events(4).worker_id(), worker);
        EXPECT_TRUE(log.events(4).has_unit());
        EXPECT_EQ(before.back(), v1::JOB_EVENT_FINISHED);
        EXPECT_TRUE(hasEvent(log, v1::JOB_EVENT_MERGED));
        EXPECT_TRUE(hasEvent(log, v1::JOB_EVENT_CHECKPOINTED));
        for (int i = 1; i < log.events_size(); ++i)
            EXPECT_EQ(log.events(i).sequence(), log.events(i - 1).sequence() + 1);
        const auto tail = coordinator.jobLog(jobId, log.events(2).sequence());
        EXPECT_EQ(tail.events(0).kind(), v1::JOB_EVENT_PRIORITY_CHANGED);
        EXPECT_EQ(tail.state(), v1::JOB_STATE_DONE);
        coordinator.stop();
    }
    Coordinator coordinator(m_options);
    EXPECT_EQ(eventKinds(coordinator.jobLog(jobId, 0)), before) << "the log was not stored";
    coordinator.stop();
}

// A drained worker is given nothing new, while the unit it holds still merges; undrained it
// works again. The drain is stored; an unknown worker is named.
TEST_F(CoordinatorJob, ADrainedWorkerGetsNoNewUnits) {
    uint64_t worker = 0;
    {
        Coordinator coordinator(m_options);
        coordinator.submit(upload(coordinator));
        worker = coordinator.registerWorker(thisBuild());
        const auto out = coordinator.acquire(worker, std::chrono::steady_clock::now());
        ASSERT_TRUE(out.has_work());
        const v1::WorkerInfo info = coordinator.setWorkerDraining(worker, true);
        EXPECT_TRUE(info.draining());
        EXPECT_FALSE(info.exiting());
        EXPECT_EQ(info.leases(), 1u);
        const auto none = coordinator.acquire(worker, std::chrono::steady_clock::now());
        EXPECT_FALSE(none.has_work()) << "a drained worker was given a unit";
        EXPECT_TRUE(none.draining());
        std::string compressed;
        EXPECT_EQ(coordinator.report(render(out, worker, compressed), compressed),
                  v1::RESULT_MERGED);
        try {
            coordinator.setWorkerDraining(worker + 100, true);
            ADD_FAILURE() << "an unknown worker was drained";
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::UnknownWorker);
        }
        coordinator.stop();
    }
    Coordinator coordinator(m_options);
    EXPECT_FALSE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work())
        << "the drain was not stored";
    EXPECT_FALSE(coordinator.setWorkerDraining(worker, false).draining());
    EXPECT_TRUE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work());
    coordinator.stop();
}

// A worker whose results are wrong (here: one more unit of red in one pixel of each film, as a
// damaged scene file or a bad build would) is caught by the audit of its first unit: a third
// worker's render agrees with the second's, the wrong worker is quarantined, and the job's film
// is the local render's.
TEST_F(CoordinatorJob, AnAuditQuarantinesAWrongWorkerAndTheFilmStaysRight) {
    auto clock = std::make_shared<ManualClock>();
    uint64_t wrong = 0;
    {
        Coordinator coordinator(m_options, clock);
        const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
        wrong = coordinator.registerWorker(thisBuild());
        const uint64_t right = coordinator.registerWorker(thisBuild());
        const uint64_t judge = coordinator.registerWorker(thisBuild());
        const auto deliver = [&](uint64_t worker, bool perturb) {
            const auto lease = coordinator.acquire(worker, std::chrono::steady_clock::now());
            EXPECT_TRUE(lease.has_work());
            std::string compressed;
            v1::ResultChunk header = render(lease, worker, compressed);
            if (perturb) perturbResult(header, compressed);
            return std::make_pair(lease.unit().unit_index(),
                                  coordinator.report(header, compressed));
        };
        const auto [unit, first] = deliver(wrong, true);
        EXPECT_EQ(first, v1::RESULT_HELD) << "a worker's first result was merged unaudited";
        EXPECT_FALSE(coordinator.acquire(wrong, std::chrono::steady_clock::now()).has_work())
            << "a worker on probation got another unit of the job";
        const auto [audited, second] = deliver(right, false);
        EXPECT_EQ(audited, unit) << "the audit did not go first";
        EXPECT_EQ(second, v1::RESULT_HELD) << "results that differ were merged";
        const auto [decided, third] = deliver(judge, false);
        EXPECT_EQ(decided, unit);
        EXPECT_EQ(third, v1::RESULT_MERGED);
        const std::vector<v1::WorkerInfo> workers = coordinator.listWorkers(true);
        for (const v1::WorkerInfo& worker : workers)
            EXPECT_EQ(worker.quarantined().empty(), worker.worker_id() != wrong)
                << worker.worker_id();
        EXPECT_FALSE(coordinator.acquire(wrong, std::chrono::steady_clock::now()).has_work());
        // The good workers finish the job (their first units audit each other).
        for (int round = 0; round < 100; ++round) {
            if (coordinator.listJobs(jobId).at(0).state() != v1::JOB_STATE_RUNNING) break;
            deliver(round % 2 ? right : judge, false);
        }
        const v1::JobStatus status = coordinator.listJobs(jobId).at(0);
        EXPECT_EQ(status.state(), v1::JOB_STATE_DONE);
        EXPECT_GE(status.units_audited(), 1u);
        EXPECT_EQ(status.suspect(), "");
        EXPECT_EQ(coordinator.snapshot(jobId, false).film.serialize(), localFilm());
        coordinator.stop();
    }
    // The quarantine is stored: a restarted coordinator leases the worker nothing.
    Coordinator restarted(m_options, clock);
    bool listed = false;
    for (const v1::WorkerInfo& worker : restarted.listWorkers(true))
        if (worker.worker_id() == wrong) listed = !worker.quarantined().empty();
    EXPECT_TRUE(listed) << "the quarantine was forgotten by a restart";
    restarted.stop();
}

// A worker that passed its first audit and is found wrong later (an intermittent fault): the
// running job it merged into is rendered again from nothing, a done one is marked suspect.
TEST_F(CoordinatorJob, AWorkerFoundWrongLaterRestartsItsJobsOrMarksThemSuspect) {
    auto clock = std::make_shared<ManualClock>();
    m_options.auditFraction = 0;  // only first units: the test decides when the fault shows
    Coordinator coordinator(m_options, clock);
    const uint64_t done = coordinator.submit(upload(coordinator, 1)).job_id();
    const uint64_t a = coordinator.registerWorker(thisBuild());
    const uint64_t b = coordinator.registerWorker(thisBuild());
    const uint64_t c = coordinator.registerWorker(thisBuild());
    const auto deliver = [&](uint64_t worker, bool perturb) {
        const auto lease = coordinator.acquire(worker, std::chrono::steady_clock::now());
        if (!lease.has_work()) return v1::RESULT_DISPOSITION_UNSPECIFIED;
        std::string compressed;
        v1::ResultChunk header = render(lease, worker, compressed);
        if (perturb) perturbResult(header, compressed);
        return coordinator.report(header, compressed);
    };
    // Job 1: A's first unit is audited by B and agrees; A's later units merge unaudited.
    ASSERT_EQ(deliver(a, false), v1::RESULT_HELD);
    ASSERT_EQ(deliver(b, false), v1::RESULT_MERGED);
    for (int i = 0; i < 100 && coordinator.listJobs(done).at(0).state() == v1::JOB_STATE_RUNNING;
         ++i)
        deliver(a, false);
    ASSERT_EQ(coordinator.listJobs(done).at(0).state(), v1::JOB_STATE_DONE);
    // Job 2: A passes its first audit, then merges a wrong unit unaudited.
    const uint64_t running = coordinator.submit(upload(coordinator, 3)).job_id();
    ASSERT_EQ(deliver(a, false), v1::RESULT_HELD);
    ASSERT_EQ(deliver(c, false), v1::RESULT_MERGED);
    ASSERT_EQ(deliver(a, true), v1::RESULT_MERGED);
    EXPECT_GT(coordinator.listJobs(running).at(0).units_done(), 1u);
    // B's first unit of job 2 is audited by A, wrongly: C decides against A.
    ASSERT_EQ(deliver(b, false), v1::RESULT_HELD);
    ASSERT_EQ(deliver(a, true), v1::RESULT_HELD);
    ASSERT_EQ(deliver(c, false), v1::RESULT_MERGED);
    v1::JobStatus status = coordinator.listJobs(running).at(0);
    EXPECT_EQ(status.units_done(), 1u) << "the job was not rendered again from nothing";
    EXPECT_NE(coordinator.listJobs(done).at(0).suspect().find("quarantined"), std::string::npos);
    for (int i = 0; i < 400 && coordinator.listJobs(running).at(0).state() == v1::JOB_STATE_RUNNING;
         ++i)
        deliver(i % 2 ? b : c, false);
    status = coordinator.listJobs(running).at(0);
    ASSERT_EQ(status.state(), v1::JOB_STATE_DONE);
    EXPECT_EQ(status.suspect(), "");
    EXPECT_EQ(coordinator.snapshot(running, false).film.serialize(), localFilm());
    coordinator.stop();
}

// A coordinator that stood still (SIGSTOP, a paused VM) longer than a lease charges no attempt
// to the workers whose heartbeats it did not read meanwhile.
TEST_F(CoordinatorJob, AStalledCoordinatorChargesNoAttempt) {
    auto clock = std::make_shared<ManualClock>();
    m_options.leaseSeconds = 5;
    Coordinator coordinator(m_options, clock);
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    ASSERT_TRUE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work());
    coordinator.tick();
    clock->advance(60);
    coordinator.tick();
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).attempts_failed(), 0u)
        << "a healthy worker was charged for the coordinator's stall";
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).units_leased(), 1u);
    // Real silence after the stall still expires the lease: ticks every 0.2 s for 6 s.
    for (int i = 0; i < 30; ++i) {
        clock->advance(0.2);
        coordinator.tick();
    }
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).attempts_failed(), 1u);
    coordinator.stop();
}

// A worker of another build registers but is leased none of the job's units, and is told why; a
// job pinned to its fingerprint is its.
TEST_F(CoordinatorJob, AWorkerOfAnotherBuildIsLeasedNothingOfTheJob) {
    Coordinator coordinator(m_options);
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    EXPECT_EQ(coordinator.listJobs(jobId).at(0).settings().engine_fingerprint(),
              farm::engineFingerprint());
    v1::RegisterRequest other = thisBuild();
    other.set_engine_fingerprint(
        farm::engineFingerprint() == "0123456789abcdef" ? "fedcba9876543210" : "0123456789abcdef");
    const uint64_t foreign = coordinator.registerWorker(other);
    const auto idle = coordinator.acquire(foreign, std::chrono::steady_clock::now());
    EXPECT_FALSE(idle.has_work());
    EXPECT_NE(idle.idle_reason().find(farm::engineFingerprint()), std::string::npos)
        << idle.idle_reason();
    EXPECT_EQ(coordinator.listWorkers(true).at(0).engine_fingerprint(), other.engine_fingerprint());
    v1::SubmitJobRequest pinned = upload(coordinator);
    pinned.mutable_settings()->set_engine_fingerprint(other.engine_fingerprint());
    const uint64_t pinnedId = coordinator.submit(pinned).job_id();
    const auto lease = coordinator.acquire(foreign, std::chrono::steady_clock::now());
    ASSERT_TRUE(lease.has_work());
    EXPECT_EQ(lease.unit().job_id(), pinnedId);
    // Not a fingerprint: refused with what one looks like.
    for (const std::string& bad :
         {std::string("xyz"), std::string(16, 'G'), std::string(17, '1')}) {
        v1::SubmitJobRequest request = upload(coordinator);
        request.mutable_settings()->set_engine_fingerprint(bad);
        std::string refused;
        try {
            coordinator.submit(request);
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::InvalidArgument) << e.what();
            refused = e.what();
        }
        EXPECT_NE(refused.find("16 lowercase hex digits"), std::string::npos) << refused;
        v1::RegisterRequest registration = thisBuild();
        registration.set_engine_fingerprint(bad);
        expectRefusedRegistration(coordinator, registration, FarmError::Kind::InvalidArgument,
                                  "engine fingerprint");
    }
    v1::RegisterRequest none = thisBuild();
    none.clear_engine_fingerprint();
    expectRefusedRegistration(coordinator, none, FarmError::Kind::InvalidArgument,
                              "engine fingerprint");
    coordinator.stop();
}

// What `alphorn workers` shows of liveness: silent after two heartbeat intervals without a call
// (long before the lease expires), dead after three lease periods; draining and then left for
// a worker stopping on SIGTERM, which is given nothing new meanwhile.
TEST_F(CoordinatorJob, WorkerStatesFollowTheirCalls) {
    auto clock = std::make_shared<ManualClock>();
    Coordinator coordinator(m_options, clock);
    coordinator.submit(upload(coordinator));
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    const auto state = [&] { return coordinator.listWorkers(true).at(0).state(); };
    EXPECT_EQ(state(), v1::WORKER_STATE_ALIVE);
    clock->advance(coordinator.silentAfterSeconds() - 0.5);
    EXPECT_EQ(state(), v1::WORKER_STATE_ALIVE);
    clock->advance(1);
    EXPECT_EQ(state(), v1::WORKER_STATE_SILENT);
    EXPECT_TRUE(coordinator.listWorkers(false).at(0).alive());
    clock->advance(3 * m_options.leaseSeconds);
    EXPECT_EQ(state(), v1::WORKER_STATE_DEAD);
    EXPECT_TRUE(coordinator.listWorkers(false).empty());

    v1::HeartbeatRequest stopping;
    stopping.set_worker_id(worker);
    stopping.set_draining(true);
    coordinator.heartbeat(stopping);
    v1::WorkerInfo info = coordinator.listWorkers(true).at(0);
    EXPECT_EQ(info.state(), v1::WORKER_STATE_ALIVE);
    EXPECT_TRUE(info.draining());
    EXPECT_TRUE(info.exiting());
    EXPECT_FALSE(coordinator.acquire(worker, std::chrono::steady_clock::now()).has_work());
    stopping.set_exiting(true);
    coordinator.heartbeat(stopping);
    info = coordinator.listWorkers(true).at(0);
    EXPECT_EQ(info.state(), v1::WORKER_STATE_LEFT);
    EXPECT_FALSE(info.alive());
    EXPECT_TRUE(coordinator.listWorkers(false).empty());
    stopping.set_exiting(false);  // a heartbeat of the stopping process, late on the network
    coordinator.heartbeat(stopping);
    EXPECT_EQ(coordinator.listWorkers(true).at(0).state(), v1::WORKER_STATE_LEFT);
    coordinator.stop();
}

// Checkpoints come every interval while they are quick; a round that takes longer than a
// twentieth of the interval stretches the next wait to twenty times its own length, so a large
// film does not keep the coordinator (and, on one machine, the workers' core) busy writing.
TEST_F(CoordinatorJob, SlowCheckpointsStretchTheInterval) {
    auto clock = std::make_shared<ManualClock>();
    m_options.checkpointIntervalSeconds = 10;
    Coordinator coordinator(m_options, clock);
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    double writeSeconds = 0.1;  // how long each durable write takes on the manual clock
    coordinator.setDurableWriteHooks({[&] { clock->advance(writeSeconds); }, {}});
    const auto mergeOne = [&] {
        const auto lease = coordinator.acquire(worker, std::chrono::steady_clock::now());
        std::string compressed;
        ASSERT_EQ(coordinator.report(render(lease, worker, compressed), compressed),
                  v1::RESULT_MERGED);
    };
    // Merges a unit, lets `seconds` pass and ticks; returns the checkpoints written so far.
    const auto mergeWaitTick = [&](double seconds) {
        mergeOne();
        clock->advance(seconds);
        coordinator.tick();
        return coordinator.listJobs(jobId).at(0).checkpoints_written();
    };
    // Quick writes: every 10 s.
    ASSERT_EQ(mergeWaitTick(10), 1u);
    ASSERT_EQ(mergeWaitTick(10), 2u);
    // A write of 2 s: the next round waits 40 s, not 10.
    writeSeconds = 2;
    ASSERT_EQ(mergeWaitTick(10), 3u);
    EXPECT_EQ(mergeWaitTick(30), 3u) << "a slow checkpoint did not stretch the interval";
    EXPECT_EQ(mergeWaitTick(11), 4u);
    // Quick again: back to 10 s after the next round.
    writeSeconds = 0.1;
    ASSERT_EQ(mergeWaitTick(41), 5u);
    EXPECT_EQ(mergeWaitTick(10), 6u);
    coordinator.setDurableWriteHooks({});
    coordinator.stop();
}

// What WatchJob waits on: a job's change signal moves when a unit merges and when the job is
// cancelled, waking a waiter at once; on a quiet job the wait returns at its deadline with the
// version it saw; beginStop() closes it, so no watcher holds up a shutdown.
TEST_F(CoordinatorJob, AJobsChangeSignalWakesWatchersOnMergeAndCancel) {
    using namespace std::chrono_literals;
    const auto inAWhile = [] { return std::chrono::steady_clock::now() + 10s; };
    Coordinator coordinator(m_options, std::make_shared<ManualClock>());
    const uint64_t jobId = coordinator.submit(upload(coordinator)).job_id();
    const uint64_t worker = coordinator.registerWorker(thisBuild());
    const std::shared_ptr<const ChangeSignal> changes = coordinator.changeSignal(jobId);

    ChangeSignal::Seen seen = changes->current();
    EXPECT_EQ(changes->waitForChange(seen.version, std::chrono::steady_clock::now() + 20ms).version,
              seen.version)
        << "the signal moved on a quiet job";
    const v1::AcquireWorkResponse lease =
        coordinator.acquire(worker, std::chrono::steady_clock::now());
    ASSERT_TRUE(lease.has_work());
    EXPECT_GT(changes->current().version, seen.version) << "a lease changes units_leased";

    std::string compressed;
    const v1::ResultChunk header = render(lease, worker, compressed);
    seen = changes->current();
    auto merged = std::async(std::launch::async,
                             [&] { return changes->waitForChange(seen.version, inAWhile()); });
    EXPECT_EQ(coordinator.report(header, compressed), v1::RESULT_MERGED);
    ASSERT_EQ(merged.wait_for(5s), std::future_status::ready) << "a merge did not wake the waiter";
    EXPECT_GT(merged.get().version, seen.version);

    seen = changes->current();
    EXPECT_EQ(coordinator.report(header, compressed), v1::RESULT_DISCARDED);
    EXPECT_GT(changes->current().version, seen.version) << "a discard changes results_discarded";

    auto ended = std::async(std::launch::async, [&] { return changes->waitForEnd(inAWhile()); });
    coordinator.cancel(jobId);
    ASSERT_EQ(ended.wait_for(5s), std::future_status::ready) << "a cancel did not wake the waiter";
    EXPECT_TRUE(ended.get().ended);

    seen = changes->current();
    auto stopping = std::async(std::launch::async,
                               [&] { return changes->waitForChange(seen.version, inAWhile()); });
    coordinator.beginStop();
    ASSERT_EQ(stopping.wait_for(5s), std::future_status::ready) << "beginStop left a waiter";
    EXPECT_TRUE(stopping.get().closed);
    coordinator.stop();
}

// A stop whose last checkpoint cannot be written (here a file size limit, as a full state disk)
// counts the jobs left unsaved, for the process to exit non-zero (it exited 0, silently losing
// the merges to re-rendering).
TEST_F(CoordinatorJob, AStopThatCannotSaveMergedUnitsCountsTheJobs) {
    m_options.checkpointIntervalSeconds = 1e6;  // no checkpoint before the stop's
    Coordinator coordinator(m_options);
    coordinator.submit(upload(coordinator));
    mergeOneUnit(coordinator, coordinator.registerWorker(thisBuild()));
    ASSERT_FALSE(HasFatalFailure());
    std::signal(SIGXFSZ, SIG_IGN);  // a failed write, not a killed process
    rlimit original{};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &original), 0);
    rlimit limited = original;
    limited.rlim_cur = 100;
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
    coordinator.stop();
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &original), 0);
    EXPECT_EQ(coordinator.jobsUnsavedAtStop(), 1);
}

// A write that fails (here a file size limit, as a full disk) must not publish a short blob
// under the full blob's hash; once writes succeed again the same upload stores it.
TEST(BlobStore, AFailedWriteNeverPublishesTheBlob) {
    const fs::path dir = freshDirectory("blobs_full");
    BlobStore store(dir.string(), 1 << 20);
    const std::string bytes(3000, 'x');
    const std::string sha = farm::sha256Hex(bytes);
    std::signal(SIGXFSZ, SIG_IGN);  // a failed write, not a killed process
    rlimit original{};
    ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &original), 0);
    rlimit limited = original;
    limited.rlim_cur = 1000;
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &limited), 0);
    try {
        BlobStore::Upload upload(store, sha);
        upload.append(bytes);
        upload.commit();
        ADD_FAILURE() << "a blob was stored beyond the file size limit";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("cannot store blob"), std::string::npos) << e.what();
    }
    ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &original), 0);
    EXPECT_FALSE(store.has(sha));
    BlobStore::Upload upload(store, sha);
    upload.append(bytes);
    EXPECT_TRUE(upload.commit());
    EXPECT_EQ(store.size(sha), 3000u);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace alphorn::coordinator
