// The coordinator's /metrics follow a job through a real Coordinator (no sockets): blobs stored,
// units pending, leased and merged, samples, jobs and workers by state, checkpoints.
#include "coordinator/metrics.h"
#include "common/farm/build_identity.h"

#include "common/farm/metrics.h"
#include "common/scene/accel.h"
#include "coordinator/coordinator_job_test.h"

#include <gtest/gtest.h>
#include <prometheus/collectable.h>

#include <sstream>

namespace alphorn::coordinator {
namespace {

// The value of the sample named exactly `series` (name and labels); -1 when absent.
double sample(const std::string& text, const std::string& series) {
    std::istringstream lines(text);
    for (std::string line; std::getline(lines, line);)
        if (line.rfind(series + " ", 0) == 0) return std::stod(line.substr(series.size() + 1));
    return -1;
}

class CoordinatorMetricsTest : public CoordinatorJobTest {
  protected:
    std::string scrape(Coordinator& coordinator) {
        return farm::metricsText({farm::CoordinatorMetrics::registry(),
                                  std::make_shared<CoordinatorStateMetrics>(coordinator)});
    }

    // Renders a leased unit as a worker does and reports it.
    v1::ResultDisposition renderAndReport(Coordinator& coordinator,
                                          const v1::AcquireWorkResponse& lease, uint64_t worker) {
        std::string compressed;
        const v1::ResultChunk header = render(lease, worker, compressed);
        return coordinator.report(header, compressed);
    }
};

TEST_F(CoordinatorMetricsTest, FollowJobsUnitsWorkersAndBlobs) {
    Coordinator coordinator(m_options);
    const std::string empty = scrape(coordinator);
    for (const char* state : {"running", "done", "failed", "cancelled"})
        EXPECT_EQ(sample(empty, std::string("alphorn_jobs{state=\"") + state + "\"}"), 0) << state;
    EXPECT_EQ(sample(empty, "alphorn_workers{state=\"alive\"}"), 0);
    EXPECT_EQ(sample(empty, "alphorn_blob_store_bytes"), 0);
    EXPECT_EQ(sample(empty, "alphorn_pending_units"), 0);

    const v1::SubmitJobRequest request = upload(coordinator, 2);
    uint64_t bundleBytes = 0;
    for (const auto& file : request.bundle().files()) bundleBytes += file.size();
    const v1::JobStatus job = coordinator.submit(request);
    ASSERT_EQ(job.units_total(), 12u);  // 2 passes x (3 x 2 tiles of 16 px)
    v1::RegisterRequest registration;
    farm::describeThisBuild(registration);
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
    EXPECT_EQ(sample(leased, "alphorn_blob_store_blobs"), double(request.bundle().files_size()));
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
