// The coordinator's /metrics follow a job through a real Coordinator (no sockets): blobs stored,
// units pending, leased and merged, samples, jobs and workers by state, checkpoints.
#include "coordinator/metrics.h"

#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/metrics.h"
#include "common/farm/sha256.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "coordinator/coordinator.h"

#include <gtest/gtest.h>
#include <prometheus/collectable.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

// The value of the sample named exactly `series` (name and labels); -1 when absent.
double sample(const std::string& text, const std::string& series) {
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind(series + " ", 0) == 0) return std::stod(line.substr(series.size() + 1));
    return -1;
}

class CoordinatorMetricsTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("alphorn_metrics_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir / "scene");
        fs::copy_file(fs::path(ALPHORN_SOURCE_DIR) / "scenes/meshes/sphere.obj",
                      m_dir / "scene/sphere.obj");
        std::ofstream(m_dir / "scene/s.xml") << R"(<scene>
  <integrator type="normals"/>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="3, 2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <integer name="width" value="40"/><integer name="height" value="30"/>
  </camera>
  <mesh type="obj"><string name="filename" value="sphere.obj"/></mesh>
</scene>)";
        m_options.stateDirectory = (m_dir / "state").string();
        m_options.leaseSeconds = 60;
    }
    void TearDown() override { fs::remove_all(m_dir); }

    std::string scrape(Coordinator& coordinator) {
        return farm::metricsText({farm::CoordinatorMetrics::registry(),
                                  std::make_shared<CoordinatorStateMetrics>(coordinator)});
    }

    // Renders a leased unit as a worker does and reports it.
    v1::ResultDisposition renderAndReport(Coordinator& coordinator,
                                          const v1::AcquireWorkResponse& lease, uint64_t worker) {
        auto scene = loadScene((m_dir / "scene/s.xml").string());
        const RenderUnit unit = farm::fromProto(lease.unit());
        FilmBlock block = makeUnitBlock(*scene, unit.tile);
        renderUnit(*scene, 5, unit, preparePasses(*scene, 5, unit.passBegin, unit.passEnd), block);
        const std::string compressed = farm::compressFilm(block);
        v1::ResultChunk header;
        header.set_worker_id(worker);
        header.set_lease_id(lease.lease_id());
        header.set_job_id(lease.unit().job_id());
        header.set_unit_index(lease.unit().unit_index());
        header.set_block_x0(block.x0());
        header.set_block_y0(block.y0());
        header.set_block_width(block.width());
        header.set_block_height(block.height());
        header.set_compressed_size(compressed.size());
        header.set_compressed_sha256(farm::sha256Hex(compressed));
        return coordinator.report(header, compressed);
    }

    fs::path m_dir;
    CoordinatorOptions m_options;
};

TEST_F(CoordinatorMetricsTest, FollowJobsUnitsWorkersAndBlobs) {
    Coordinator coordinator(m_options);
    const std::string empty = scrape(coordinator);
    for (const char* state : {"running", "done", "failed", "cancelled"})
        EXPECT_EQ(sample(empty, std::string("alphorn_jobs{state=\"") + state + "\"}"), 0) << state;
    EXPECT_EQ(sample(empty, "alphorn_workers{state=\"alive\"}"), 0);
    EXPECT_EQ(sample(empty, "alphorn_blob_store_bytes"), 0);
    EXPECT_EQ(sample(empty, "alphorn_pending_units"), 0);

    const farm::Bundle bundle = farm::gatherBundle((m_dir / "scene/s.xml").string());
    uint64_t bundleBytes = 0;
    for (const auto& file : bundle.files) {
        BlobStore::Upload blob(coordinator.blobs(), file.sha256);
        const std::string bytes = farm::readFile(file.sourcePath);
        blob.append(bytes);
        blob.commit();
        bundleBytes += bytes.size();
    }
    v1::SubmitJobRequest request;
    *request.mutable_bundle() = farm::toProto(bundle);
    request.mutable_settings()->set_passes(2);
    request.mutable_settings()->set_seed(5);
    request.mutable_settings()->set_tile_size(16);
    request.mutable_settings()->set_passes_per_unit(1);
    const v1::JobStatus job = coordinator.submit(request);
    ASSERT_EQ(job.units_total(), 12u);  // 2 passes x (3 x 2 tiles of 16 px)
    v1::RegisterRequest registration;
    registration.set_name("metrics-worker");
    const uint64_t worker = coordinator.registerWorker(registration);

    const v1::AcquireWorkResponse first =
        coordinator.acquire(worker, std::chrono::steady_clock::now());
    const v1::AcquireWorkResponse second =
        coordinator.acquire(worker, std::chrono::steady_clock::now());
    ASSERT_TRUE(first.has_work() && second.has_work());
    const std::string leased = scrape(coordinator);
    EXPECT_EQ(sample(leased, "alphorn_jobs{state=\"running\"}"), 1);
    EXPECT_EQ(sample(leased, "alphorn_pending_units"), 10);
    EXPECT_EQ(sample(leased, "alphorn_leased_units"), 2);
    EXPECT_EQ(sample(leased, "alphorn_workers{state=\"alive\"}"), 1);
    EXPECT_EQ(sample(leased, "alphorn_workers_draining"), 0);
    coordinator.setWorkerDraining(worker, true);
    EXPECT_EQ(sample(scrape(coordinator), "alphorn_workers_draining"), 1);
    coordinator.setWorkerDraining(worker, false);
    EXPECT_EQ(sample(leased, "alphorn_blob_store_bytes"), double(bundleBytes));
    EXPECT_EQ(sample(leased, "alphorn_blob_store_blobs"), double(bundle.files.size()));
    EXPECT_EQ(
        sample(leased, "alphorn_units_leased_total") - sample(empty, "alphorn_units_leased_total"),
        2);
    EXPECT_EQ(sample(leased, "alphorn_blob_uploaded_bytes_total") -
                  sample(empty, "alphorn_blob_uploaded_bytes_total"),
              double(bundleBytes));

    // The second lease is handed back and leased again; everything is merged.
    v1::ResultChunk handBack;
    handBack.set_worker_id(worker);
    handBack.set_lease_id(second.lease_id());
    handBack.set_job_id(second.unit().job_id());
    handBack.set_unit_index(second.unit().unit_index());
    handBack.set_handed_back(true);
    ASSERT_EQ(coordinator.report(handBack, ""), v1::RESULT_RECORDED);
    ASSERT_EQ(renderAndReport(coordinator, first, worker), v1::RESULT_MERGED);
    for (;;) {
        const v1::AcquireWorkResponse lease =
            coordinator.acquire(worker, std::chrono::steady_clock::now());
        if (!lease.has_work()) break;
        ASSERT_EQ(renderAndReport(coordinator, lease, worker), v1::RESULT_MERGED);
    }
    ASSERT_EQ(coordinator.listJobs(job.job_id()).at(0).state(), v1::JOB_STATE_DONE);

    const std::string done = scrape(coordinator);
    const auto delta = [&](const std::string& series) {
        return sample(done, series) - sample(empty, series);
    };
    EXPECT_EQ(sample(done, "alphorn_jobs{state=\"done\"}"), 1);
    EXPECT_EQ(sample(done, "alphorn_jobs{state=\"running\"}"), 0);
    EXPECT_EQ(sample(done, "alphorn_pending_units"), 0);
    EXPECT_EQ(sample(done, "alphorn_leased_units"), 0);
    EXPECT_EQ(delta("alphorn_units_merged_total"), 12);
    EXPECT_EQ(delta("alphorn_samples_merged_total"), 40 * 30 * 2);
    EXPECT_EQ(delta("alphorn_units_leased_total"), 13);
    EXPECT_EQ(delta("alphorn_units_leased_again_total"), 1);
    EXPECT_EQ(delta("alphorn_units_handed_back_total"), 1);
    EXPECT_EQ(
        sample(done, "alphorn_units_merged_by_worker_total{worker=\"metrics-worker\",worker_id=\"" +
                         std::to_string(worker) + "\"}"),
        12);
    EXPECT_GE(delta("alphorn_checkpoint_write_seconds_count"), 1);  // the final checkpoint
    EXPECT_GT(delta("alphorn_checkpoint_written_bytes_total"), 0);
}

}  // namespace
}  // namespace alphorn::coordinator
