// The worker loop against a scripted coordinator: a real gRPC server on loopback that implements
// WorkerService with answers each test chooses, so lease -> render -> deliver, fencing, retries
// with backoff, reconnection, re-registration and load failures are exercised end to end
// without a real coordinator. Every wait is bounded: a broken worker fails a test, never hangs it.
#include "worker/worker.h"

#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/error_reason.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/job_scene.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <deque>
#include <filesystem>
#include <fstream>
#include <set>

namespace alphorn::worker {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

const std::string kToken = "worker-test-token-0123456789";
constexpr auto kPatience = 20s;  // how long a test waits for something that should happen

struct Report {
    v1::ResultChunk header;
    std::string data;
    grpc::StatusCode answer = grpc::StatusCode::OK;
};

// WorkerService with scripted answers. Tests queue leases, choose dispositions and fencing, and
// read what the worker sent. All state sits under one mutex; `changed` wakes waiting tests.
class FakeCoordinator final : public v1::WorkerService::Service {
  public:
    grpc::Status Register(grpc::ServerContext* context, const v1::RegisterRequest*,
                          v1::RegisterResponse* response) override {
        if (grpc::Status auth = farm::checkBearer(*context, kToken); !auth.ok()) return auth;
        std::lock_guard lock(mutex);
        const uint64_t id = nextWorkerId++;
        knownWorkers.insert(id);
        ++registrations;
        response->set_worker_id(id);
        response->set_heartbeat_interval_seconds(0.05);
        changed.notify_all();
        return grpc::Status::OK;
    }

    grpc::Status AcquireWork(grpc::ServerContext*, const v1::AcquireWorkRequest* request,
                             v1::AcquireWorkResponse* response) override {
        std::unique_lock lock(mutex);
        ++acquireCalls;
        changed.notify_all();
        if (!knownWorkers.count(request->worker_id())) return unknownWorker(request->worker_id());
        // A short long poll, so an idle worker neither spins nor delays a test.
        changed.wait_for(lock, 50ms, [&] { return !leases.empty(); });
        if (leases.empty()) return grpc::Status::OK;
        *response = leases.front();
        leases.pop_front();
        response->set_has_work(true);
        return grpc::Status::OK;
    }

    grpc::Status Heartbeat(grpc::ServerContext*, const v1::HeartbeatRequest* request,
                           v1::HeartbeatResponse* response) override {
        std::lock_guard lock(mutex);
        heartbeats.push_back(*request);
        if (heartbeatsNoticeUnknown && !knownWorkers.count(request->worker_id())) {
            response->set_unknown_worker(true);
            response->set_error_reason(v1::ERROR_REASON_UNKNOWN_WORKER);
        }
        for (uint64_t lease : request->lease_ids())
            if (fenceOnHeartbeat.count(lease)) {
                response->add_drop_lease_ids(lease);
                fencedAtHeartbeat.emplace(lease, heartbeats.size());  // the first drop
            }
        changed.notify_all();
        return grpc::Status::OK;
    }

    grpc::Status ReportResult(grpc::ServerContext*, grpc::ServerReader<v1::ResultChunk>* reader,
                              v1::ReportResultResponse* response) override {
        Report report;
        if (!reader->Read(&report.header))
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "empty result stream");
        report.data = report.header.data();
        report.header.clear_data();
        v1::ResultChunk chunk;
        while (reader->Read(&chunk)) report.data += chunk.data();
        std::lock_guard lock(mutex);
        changed.notify_all();
        if (!knownWorkers.count(report.header.worker_id())) {
            report.answer = grpc::StatusCode::NOT_FOUND;
            reports.push_back(report);
            return unknownWorker(report.header.worker_id());
        }
        reports.push_back(report);
        auto scripted = dispositions.find(report.header.lease_id());
        if (scripted != dispositions.end())
            response->set_disposition(scripted->second);
        else
            response->set_disposition(report.header.error().empty() ? v1::RESULT_MERGED
                                                                    : v1::RESULT_RECORDED);
        return grpc::Status::OK;
    }

    grpc::Status GetBlob(grpc::ServerContext*, const v1::GetBlobRequest* request,
                         grpc::ServerWriter<v1::GetBlobChunk>* writer) override {
        std::string bytes;
        {
            std::lock_guard lock(mutex);
            auto it = blobs.find(request->sha256());
            if (it == blobs.end())
                return grpc::Status(grpc::StatusCode::NOT_FOUND, "no blob " + request->sha256());
            bytes = it->second;
        }
        v1::GetBlobChunk chunk;
        chunk.set_total_size(bytes.size());
        chunk.set_data(bytes);
        writer->Write(chunk);
        return grpc::Status::OK;
    }

    // Waits until `done()` holds (checked under the mutex); false after kPatience.
    template <typename Predicate>
    bool waitFor(Predicate done) {
        std::unique_lock lock(mutex);
        return changed.wait_for(lock, kPatience, done);
    }
    void queueLease(v1::AcquireWorkResponse lease) {
        std::lock_guard lock(mutex);
        leases.push_back(std::move(lease));
        changed.notify_all();
    }
    std::vector<Report> reportsFor(uint64_t leaseId) {
        std::lock_guard lock(mutex);
        std::vector<Report> found;
        for (const Report& report : reports)
            if (report.header.lease_id() == leaseId) found.push_back(report);
        return found;
    }
    // True when a result for `leaseId` was accepted (not refused as from an unknown worker).
    bool acceptedLocked(uint64_t leaseId) const {
        for (const Report& report : reports)
            if (report.header.lease_id() == leaseId && report.answer == grpc::StatusCode::OK)
                return true;
        return false;
    }

    std::mutex mutex;
    std::condition_variable changed;
    uint64_t nextWorkerId = 1;
    std::set<uint64_t> knownWorkers;
    bool heartbeatsNoticeUnknown = true;  // false: only AcquireWork and ReportResult refuse
    int registrations = 0;
    int acquireCalls = 0;
    std::deque<v1::AcquireWorkResponse> leases;
    std::vector<v1::HeartbeatRequest> heartbeats;
    std::set<uint64_t> fenceOnHeartbeat;
    std::map<uint64_t, size_t> fencedAtHeartbeat;  // lease -> heartbeat count at its first drop
    std::map<uint64_t, v1::ResultDisposition> dispositions;
    std::vector<Report> reports;
    std::map<std::string, std::string> blobs;

  private:
    static grpc::Status unknownWorker(uint64_t id) {
        return farm::statusWithReason(grpc::StatusCode::NOT_FOUND,
                                      "unknown worker " + std::to_string(id) + ": register again",
                                      v1::ERROR_REASON_UNKNOWN_WORKER);
    }
};

// A gRPC server for the fake on 127.0.0.1, which can go away and come back on the same port.
class FakeServer {
  public:
    explicit FakeServer(FakeCoordinator& service) : m_service(service) {}
    ~FakeServer() { stop(); }

    void start(int port = 0) {
        grpc::ServerBuilder builder;
        farm::configureServer(builder);
        builder.AddListeningPort("127.0.0.1:" + std::to_string(port),
                                 grpc::InsecureServerCredentials(), &m_port);
        builder.RegisterService(&m_service);
        m_server = builder.BuildAndStart();
        ASSERT_TRUE(m_server) << "cannot listen on port " << port;
        ASSERT_GT(m_port, 0);
    }
    void stop() {
        if (!m_server) return;
        m_server->Shutdown(std::chrono::system_clock::now() + 100ms);
        m_server->Wait();
        m_server.reset();
    }
    int port() const { return m_port; }
    std::string address() const { return "127.0.0.1:" + std::to_string(m_port); }

  private:
    FakeCoordinator& m_service;
    std::unique_ptr<grpc::Server> m_server;
    int m_port = 0;
};

// A tiny scene (8x8, normals integrator, one quad) written to disk, gathered into a bundle whose
// blobs the fake serves, and rendered locally for comparison.
struct TestJob {
    uint64_t id = 0;
    v1::JobDescription description;
    std::string scenePath;
};

class WorkerTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_root = fs::temp_directory_path() /
                 ("alphorn_worker_test_" + std::to_string(::getpid()) + "_" +
                  ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(m_root);
        fs::create_directories(m_root);
        m_options.token = kToken;
        m_options.cacheDirectory = (m_root / "cache").string();
        m_options.name = "test-worker";
        m_options.threads = 1;
        m_options.retrySeed = 1;
        m_options.retry = {5ms, 50ms};
        m_options.registerTimeout = 300ms;
        m_options.acquireTimeout = 2s;
        m_options.deliverTimeout = 300ms;
        m_options.drainSeconds = 2;
    }
    void TearDown() override {
        stopWorker();
        m_server.stop();
        fs::remove_all(m_root);
    }

    TestJob makeJob(uint64_t id, const std::string& sceneXml) {
        TestJob job;
        job.id = id;
        const fs::path directory = m_root / ("scene" + std::to_string(id));
        fs::create_directories(directory);
        fs::copy_file(sourcePath("scenes/meshes/quad.obj"), directory / "quad.obj");
        job.scenePath = (directory / "s.xml").string();
        std::ofstream(job.scenePath) << sceneXml;
        farm::Bundle bundle;
        bundle.scenePath = "s.xml";
        std::lock_guard lock(m_fake.mutex);
        for (const std::string name : {"s.xml", "quad.obj"}) {
            const std::string bytes = farm::readFile((directory / name).string());
            const std::string sha = farm::sha256Hex(bytes);
            bundle.files.push_back({name, sha, bytes.size(), ""});
            m_fake.blobs[sha] = bytes;
        }
        job.description.set_job_id(id);
        *job.description.mutable_bundle() = farm::toProto(bundle);
        job.description.mutable_settings()->set_seed(1000 + id);
        job.description.mutable_settings()->set_name("job" + std::to_string(id));
        return job;
    }
    TestJob makeGoodJob(uint64_t id) { return makeJob(id, kScene); }

    static v1::AcquireWorkResponse lease(const TestJob& job, uint64_t leaseId, uint32_t unitIndex) {
        v1::AcquireWorkResponse lease;
        lease.set_lease_id(leaseId);
        *lease.mutable_unit() = farm::toProto(job.id, unitIndex, unitOf(unitIndex));
        *lease.mutable_job() = job.description;
        lease.set_lease_seconds(10);
        lease.set_lease_token("token-" + std::to_string(leaseId));
        return lease;
    }
    // Unit i: passes [i, i + 2) over the left or right half of the 8x8 image.
    static RenderUnit unitOf(uint32_t index) {
        RenderUnit unit;
        unit.passBegin = index;
        unit.passEnd = index + 2;
        unit.tile = index % 2 == 0 ? Tile{0, 0, 4, 8} : Tile{4, 0, 8, 8};
        return unit;
    }
    // The film the unit must produce: renderUnit() here, with the same scene and seed.
    static std::string expectedFilm(const TestJob& job, uint32_t unitIndex) {
        auto scene = farm::loadSceneWithIntegrator(job.scenePath, "");
        const uint64_t seed = job.description.settings().seed();
        const RenderUnit unit = unitOf(unitIndex);
        FilmBlock block = makeUnitBlock(*scene, unit.tile);
        EXPECT_TRUE(renderUnit(*scene, seed, unit,
                               preparePasses(*scene, seed, unit.passBegin, unit.passEnd), block));
        return block.serialize();
    }
    static std::string deliveredFilm(const Report& report) {
        EXPECT_EQ(report.header.compressed_size(), report.data.size());
        EXPECT_EQ(report.header.compressed_sha256(), farm::sha256Hex(report.data));
        FilmBlock block(report.header.block_x0(), report.header.block_y0(),
                        report.header.block_width(), report.header.block_height());
        farm::decompressFilm(report.data, block);
        return block.serialize();
    }

    void startWorker() {
        m_options.coordinator = m_serverAddress.empty() ? m_server.address() : m_serverAddress;
        m_worker = std::make_unique<Worker>(m_options);
        m_thread = std::thread([this] {
            try {
                m_exitCode = m_worker->run();
            } catch (const std::exception& e) {
                m_runError = e.what();
            }
        });
    }
    void stopWorker() {
        if (!m_worker) return;
        m_worker->requestStop();
        m_thread.join();
        m_worker.reset();
        EXPECT_EQ(m_runError, "");
        EXPECT_EQ(m_exitCode, 0);
    }
    // Waits for an accepted result of `leaseId`.
    bool waitForAccepted(uint64_t leaseId) {
        return m_fake.waitFor([&] { return m_fake.acceptedLocked(leaseId); });
    }

    static constexpr const char* kScene = R"(<scene>
  <integrator type="normals"/>
  <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 2, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <integer name="width" value="8"/><integer name="height" value="8"/>
  </camera>
  <mesh type="obj"><string name="filename" value="quad.obj"/></mesh>
</scene>)";

    fs::path m_root;
    FakeCoordinator m_fake;
    FakeServer m_server{m_fake};
    std::string m_serverAddress;
    WorkerOptions m_options;
    std::unique_ptr<Worker> m_worker;
    std::thread m_thread;
    int m_exitCode = -1;
    std::string m_runError;
};

TEST_F(WorkerTest, LeasesRendersAndDeliversTheUnitItWasGiven) {
    m_server.start();
    const TestJob job = makeGoodJob(7);
    m_fake.queueLease(lease(job, 11, 1));
    startWorker();
    ASSERT_TRUE(waitForAccepted(11));
    const std::vector<Report> reports = m_fake.reportsFor(11);
    ASSERT_EQ(reports.size(), 1u);
    const v1::ResultChunk& header = reports[0].header;
    EXPECT_EQ(header.worker_id(), 1u);
    EXPECT_EQ(header.job_id(), 7u);
    EXPECT_EQ(header.unit_index(), 1u);
    EXPECT_EQ(header.error(), "");
    EXPECT_FALSE(header.handed_back());
    EXPECT_TRUE(header.built_pass_data());
    // The same bytes as rendering the unit here: the farm changes nothing.
    EXPECT_EQ(deliveredFilm(reports[0]), expectedFilm(job, 1));
    // And it asks for more work afterwards.
    const int callsAfterDelivery = [&] {
        std::lock_guard lock(m_fake.mutex);
        return m_fake.acquireCalls;
    }();
    EXPECT_TRUE(m_fake.waitFor([&] { return m_fake.acquireCalls > callsAfterDelivery; }));
    stopWorker();
    EXPECT_EQ(m_fake.registrations, 1);
}

// The same unit leased twice with idle long polls between: `unloadAfter` decides whether the
// second finds the job's scene and pass data still loaded (the pass data is not built again).
class WorkerIdleTest : public WorkerTest {
  protected:
    Report renderTwiceWithIdlePolls() {
        m_server.start();
        const TestJob job = makeGoodJob(5);
        m_fake.queueLease(lease(job, 51, 0));
        startWorker();
        EXPECT_TRUE(waitForAccepted(51));
        const int callsAfterDelivery = [&] {
            std::lock_guard lock(m_fake.mutex);
            return m_fake.acquireCalls;
        }();
        // Two more calls: the first of them has come back empty and the worker has acted on it.
        EXPECT_TRUE(m_fake.waitFor([&] { return m_fake.acquireCalls >= callsAfterDelivery + 2; }));
        m_fake.queueLease(lease(job, 52, 0));
        EXPECT_TRUE(waitForAccepted(52));
        stopWorker();
        EXPECT_TRUE(m_fake.reportsFor(51).at(0).header.built_pass_data());
        const Report second = m_fake.reportsFor(52).at(0);
        EXPECT_EQ(deliveredFilm(second), expectedFilm(job, 0));
        return second;
    }
};

TEST_F(WorkerIdleTest, KeepsTheJobLoadedThroughAShortIdle) {
    m_options.unloadAfter = std::chrono::hours(1);
    EXPECT_FALSE(renderTwiceWithIdlePolls().header.built_pass_data());
}

TEST_F(WorkerIdleTest, UnloadsTheJobAfterIdlingLongerThanUnloadAfter) {
    m_options.unloadAfter = 0ms;
    EXPECT_TRUE(renderTwiceWithIdlePolls().header.built_pass_data());
}

TEST_F(WorkerTest, DiscardedResultIsNotResentAndWorkGoesOn) {
    m_server.start();
    const TestJob job = makeGoodJob(1);
    m_fake.dispositions[21] = v1::RESULT_DISCARDED;  // fenced: reassigned while we rendered
    m_fake.queueLease(lease(job, 21, 0));
    m_fake.queueLease(lease(job, 22, 1));
    startWorker();
    ASSERT_TRUE(waitForAccepted(22));
    stopWorker();
    EXPECT_EQ(m_fake.reportsFor(21).size(), 1u) << "a discarded result was sent again";
    EXPECT_EQ(deliveredFilm(m_fake.reportsFor(22).at(0)), expectedFilm(job, 1));
}

TEST_F(WorkerTest, HeartbeatsCarryTheLeaseWhileTheUnitRenders) {
    m_server.start();
    const TestJob job = makeGoodJob(3);
    m_fake.queueLease(lease(job, 31, 0));
    bool renewed = false;
    m_options.beforeRender = [&](const v1::AcquireWorkResponse&) {
        // Hold the unit until two heartbeats have named its lease, unit and token.
        renewed = m_fake.waitFor([&] {
            int naming = 0;
            for (const v1::HeartbeatRequest& beat : m_fake.heartbeats)
                if (beat.worker_id() == 1 && beat.lease_ids_size() == 1 &&
                    beat.lease_ids(0) == 31 && beat.held_units_size() == 1 &&
                    beat.held_units(0).job_id() == 3 && beat.held_units(0).unit_index() == 0 &&
                    beat.held_units(0).lease_token() == "token-31")
                    ++naming;
            return naming >= 2;
        });
    };
    startWorker();
    ASSERT_TRUE(waitForAccepted(31));
    EXPECT_TRUE(renewed) << "no heartbeat named the lease being rendered";
    // Once delivered, the lease is no longer claimed.
    const size_t beatsAtDelivery = [&] {
        std::lock_guard lock(m_fake.mutex);
        return m_fake.heartbeats.size();
    }();
    ASSERT_TRUE(m_fake.waitFor([&] { return m_fake.heartbeats.size() > beatsAtDelivery + 1; }));
    stopWorker();
    EXPECT_EQ(m_fake.heartbeats.back().lease_ids_size(), 0);
}

// SIGTERM (the first stop request): the heartbeats say the worker drains, the unit in hand is
// finished and delivered, no new unit is taken, and the last call says the worker leaves.
TEST_F(WorkerTest, AStopRequestFinishesTheUnitTakesNoMoreAndSaysGoodbye) {
    m_server.start();
    const TestJob job = makeGoodJob(5);
    m_fake.queueLease(lease(job, 51, 0));
    m_fake.queueLease(lease(job, 52, 1));
    bool drainingSeen = false;
    m_options.beforeRender = [&](const v1::AcquireWorkResponse& held) {
        if (held.lease_id() != 51) return;
        m_worker->requestStop();
        drainingSeen = m_fake.waitFor([&] {
            for (const v1::HeartbeatRequest& beat : m_fake.heartbeats)
                if (beat.draining() && beat.lease_ids_size() == 1 && beat.lease_ids(0) == 51)
                    return true;
            return false;
        });
    };
    startWorker();
    ASSERT_TRUE(m_fake.waitFor([&] {
        return !m_fake.heartbeats.empty() && m_fake.heartbeats.back().exiting();
    })) << "the worker did not say it leaves";
    m_thread.join();
    EXPECT_EQ(m_exitCode, 0);
    EXPECT_EQ(m_runError, "");
    m_worker.reset();
    EXPECT_TRUE(drainingSeen) << "no heartbeat said the worker drains while it held the unit";
    const std::vector<Report> reports = m_fake.reportsFor(51);
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_FALSE(reports[0].header.handed_back());
    EXPECT_EQ(deliveredFilm(reports[0]), expectedFilm(job, 0));
    EXPECT_GT(reports[0].header.rays(), 0u);
    EXPECT_GT(reports[0].header.render_seconds(), 0.0);
    EXPECT_TRUE(m_fake.reportsFor(52).empty());
    EXPECT_EQ(m_fake.leases.size(), 1u) << "a draining worker took a new unit";
    const v1::HeartbeatRequest& goodbye = m_fake.heartbeats.back();
    EXPECT_TRUE(goodbye.draining());
    EXPECT_EQ(goodbye.lease_ids_size(), 0);
}

// A second stop request (a second SIGTERM or Ctrl-C) abandons the unit, hands it back and exits.
TEST_F(WorkerTest, ASecondStopRequestHandsTheUnitBackAndExits) {
    m_server.start();
    const TestJob job = makeGoodJob(6);
    m_fake.queueLease(lease(job, 61, 0));
    m_options.beforeRender = [&](const v1::AcquireWorkResponse&) {
        m_worker->requestStop();
        m_worker->requestStop();
    };
    startWorker();
    m_thread.join();
    EXPECT_EQ(m_exitCode, 0);
    m_worker.reset();
    const std::vector<Report> reports = m_fake.reportsFor(61);
    ASSERT_EQ(reports.size(), 1u);
    EXPECT_TRUE(reports[0].header.handed_back());
    EXPECT_TRUE(reports[0].data.empty());
}

TEST_F(WorkerTest, LeaseFencedByHeartbeatIsDroppedUnrendered) {
    m_server.start();
    const TestJob job = makeGoodJob(4);
    m_fake.fenceOnHeartbeat.insert(41);
    m_fake.queueLease(lease(job, 41, 0));
    m_fake.queueLease(lease(job, 42, 1));
    m_options.beforeRender = [&](const v1::AcquireWorkResponse& held) {
        if (held.lease_id() != 41) return;
        // Wait for the heartbeat after the one that dropped the lease: by then the worker has
        // taken in the drop (it handles a response before it sends the next heartbeat).
        EXPECT_TRUE(m_fake.waitFor([&] {
            auto fenced = m_fake.fencedAtHeartbeat.find(41);
            return fenced != m_fake.fencedAtHeartbeat.end() &&
                   m_fake.heartbeats.size() > fenced->second;
        }));
    };
    startWorker();
    ASSERT_TRUE(waitForAccepted(42));
    stopWorker();
    EXPECT_TRUE(m_fake.reportsFor(41).empty()) << "a fenced unit was rendered and delivered";
    EXPECT_EQ(deliveredFilm(m_fake.reportsFor(42).at(0)), expectedFilm(job, 1));
}

TEST_F(WorkerTest, RetriesWithBackoffUntilTheCoordinatorIsUp) {
    // Find a free port, then leave it unserved while the worker starts.
    m_server.start();
    const int port = m_server.port();
    m_serverAddress = m_server.address();
    m_server.stop();
    std::mutex delaysMutex;
    std::vector<std::chrono::milliseconds> delays;
    m_options.onBackoff = [&](std::chrono::milliseconds delay) {
        std::lock_guard lock(delaysMutex);
        delays.push_back(delay);
    };
    startWorker();
    const auto deadline = std::chrono::steady_clock::now() + kPatience;
    for (;;) {
        {
            std::lock_guard lock(delaysMutex);
            if (delays.size() >= 3) break;
        }
        ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the worker does not retry";
        std::this_thread::sleep_for(10ms);
    }
    const TestJob job = makeGoodJob(5);
    m_fake.queueLease(lease(job, 51, 0));
    m_server.start(port);
    ASSERT_TRUE(waitForAccepted(51));
    stopWorker();
    EXPECT_EQ(m_fake.registrations, 1);
    // Full jitter under a doubling ceiling: 5, 10, 20, 40, then 50 ms (the cap).
    std::lock_guard lock(delaysMutex);
    for (size_t i = 0; i < delays.size(); ++i)
        EXPECT_LE(delays[i].count(), std::min<int64_t>(50, int64_t(5) << i)) << "delay " << i;
}

TEST_F(WorkerTest, KeepsTheResultThroughACoordinatorRestart) {
    m_server.start();
    const TestJob job = makeGoodJob(6);
    m_fake.queueLease(lease(job, 61, 0));
    m_fake.queueLease(lease(job, 62, 1));
    std::atomic<int> backoffs{0};
    m_options.onBackoff = [&](std::chrono::milliseconds) { ++backoffs; };
    std::thread restarter;
    m_options.beforeRender = [&](const v1::AcquireWorkResponse& held) {
        if (held.lease_id() != 62) return;
        // The coordinator goes away while the unit renders and comes back a little later on
        // the same port, with the same state (it remembers the worker).
        m_server.stop();
        restarter = std::thread([&] {
            std::this_thread::sleep_for(600ms);
            m_server.start(m_server.port());
        });
    };
    startWorker();
    ASSERT_TRUE(waitForAccepted(61));
    const bool delivered = waitForAccepted(62);
    restarter.join();
    ASSERT_TRUE(delivered);
    stopWorker();
    EXPECT_GT(backoffs, 0) << "the delivery never failed: the outage was not seen";
    EXPECT_EQ(m_fake.reportsFor(62).size(), 1u);
    EXPECT_EQ(deliveredFilm(m_fake.reportsFor(62).at(0)), expectedFilm(job, 1));
    EXPECT_EQ(m_fake.registrations, 1);
}

TEST_F(WorkerTest, UnknownWorkerRegistersAgainAndResends) {
    m_server.start();
    const TestJob job = makeGoodJob(8);
    m_fake.heartbeatsNoticeUnknown = false;  // so the refusals below are what the worker sees
    m_fake.queueLease(lease(job, 81, 0));
    m_options.beforeRender = [&](const v1::AcquireWorkResponse& held) {
        // The coordinator loses its workers while this unit renders: the result is refused
        // as from an unknown worker, the worker registers again and sends it under its new id.
        if (held.lease_id() != 81) return;
        std::lock_guard lock(m_fake.mutex);
        m_fake.knownWorkers.clear();
    };
    startWorker();
    ASSERT_TRUE(waitForAccepted(81));
    // The coordinator forgets it again while it asks for work: it registers a third time.
    {
        std::lock_guard lock(m_fake.mutex);
        m_fake.knownWorkers.clear();
    }
    m_fake.queueLease(lease(job, 82, 1));
    ASSERT_TRUE(waitForAccepted(82));
    stopWorker();
    const std::vector<Report> first = m_fake.reportsFor(81);
    ASSERT_GE(first.size(), 2u);
    EXPECT_EQ(first.front().answer, grpc::StatusCode::NOT_FOUND);
    EXPECT_EQ(first.back().header.worker_id(), 2u) << "resent under the old id";
    EXPECT_EQ(deliveredFilm(first.back()), expectedFilm(job, 0));
    EXPECT_EQ(m_fake.reportsFor(82).back().header.worker_id(), 3u);
    EXPECT_EQ(m_fake.registrations, 3);
}

TEST_F(WorkerTest, SceneThatFailsToLoadIsReportedForItsUnit) {
    m_server.start();
    const TestJob broken = makeJob(9, R"(<scene>
  <integrator type="no-such-integrator"/>
</scene>)");
    const TestJob good = makeGoodJob(10);
    m_fake.queueLease(lease(broken, 91, 0));
    m_fake.queueLease(lease(good, 92, 0));
    startWorker();
    ASSERT_TRUE(waitForAccepted(92));
    stopWorker();
    const std::vector<Report> failed = m_fake.reportsFor(91);
    ASSERT_EQ(failed.size(), 1u);
    const std::string& error = failed[0].header.error();
    EXPECT_NE(error.find("s.xml"), std::string::npos) << error;
    EXPECT_NE(error.find("no-such-integrator"), std::string::npos) << error;
    EXPECT_EQ(error.find(m_root.string()), std::string::npos)
        << "names the worker's cache: " << error;
    EXPECT_TRUE(failed[0].data.empty());
    EXPECT_EQ(deliveredFilm(m_fake.reportsFor(92).at(0)), expectedFilm(good, 0));
}

TEST_F(WorkerTest, BundleWhoseBlobIsMissingIsReportedForItsUnit) {
    m_server.start();
    TestJob missing = makeGoodJob(11);
    const std::string absent = farm::sha256Hex("never uploaded");
    missing.description.mutable_bundle()->mutable_files(1)->set_sha256(absent);
    const TestJob good = makeGoodJob(12);
    m_fake.queueLease(lease(missing, 111, 0));
    m_fake.queueLease(lease(good, 112, 0));
    startWorker();
    ASSERT_TRUE(waitForAccepted(112));
    stopWorker();
    const std::vector<Report> failed = m_fake.reportsFor(111);
    ASSERT_EQ(failed.size(), 1u);
    EXPECT_NE(failed[0].header.error().find(absent), std::string::npos) << failed[0].header.error();
    EXPECT_EQ(deliveredFilm(m_fake.reportsFor(112).at(0)), expectedFilm(good, 0));
}

}  // namespace
}  // namespace alphorn::worker
