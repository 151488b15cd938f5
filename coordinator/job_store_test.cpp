// The job store: typed rows round-trip, a job's description comes back under its own id, the
// epoch counts starts, the lease key stays, and the old never-read blobs table is dropped.
#include "coordinator/job_store.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

class JobStoreTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("alphorn_job_store_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir);
    }
    void TearDown() override { fs::remove_all(m_dir); }
    std::string path() const { return (m_dir / "state.sqlite").string(); }

    fs::path m_dir;
};

TEST_F(JobStoreTest, JobsRoundTripUnderTheirOwnIds) {
    v1::JobDescription description;
    description.mutable_settings()->set_name("first");
    description.mutable_settings()->set_passes(7);
    uint64_t first = 0, second = 0;
    {
        JobStore store(path());
        first = store.addJob(description, 40, 30, 2, 1000.5);
        description.mutable_settings()->set_name("second");
        second = store.addJob(description, 8, 6, 0, 1001);
        store.setJobState(first, v1::JOB_STATE_FAILED, "it broke", 2000.25);
        store.setUnitAttempts(second, 3, 2, "lease expired");
        store.setUnitAttempts(second, 3, 3, "out of memory");
    }
    JobStore store(path());
    const std::vector<JobRow> jobs = store.jobs();
    ASSERT_EQ(jobs.size(), 2u);
    EXPECT_EQ(jobs[0].id, first);
    ASSERT_TRUE(jobs[0].description.has_value());
    EXPECT_EQ(jobs[0].description->job_id(), first);
    EXPECT_EQ(jobs[0].description->settings().name(), "first");
    EXPECT_EQ(jobs[0].state, v1::JOB_STATE_FAILED);
    EXPECT_EQ(jobs[0].error, "it broke");
    EXPECT_EQ(jobs[0].width, 40);
    EXPECT_EQ(jobs[0].height, 30);
    EXPECT_EQ(jobs[0].filterBorder, 2);
    EXPECT_EQ(jobs[0].createdAt, 1000.5);
    EXPECT_EQ(jobs[0].finishedAt, 2000.25);
    EXPECT_EQ(jobs[1].description->job_id(), second);
    EXPECT_EQ(jobs[1].state, v1::JOB_STATE_RUNNING);
    EXPECT_EQ(jobs[1].finishedAt, 0);
    const std::vector<UnitAttemptsRow> attempts = store.unitAttempts(second);
    ASSERT_EQ(attempts.size(), 1u);
    EXPECT_EQ(attempts[0].unitIndex, 3u);
    EXPECT_EQ(attempts[0].attempts, 3u);
    EXPECT_EQ(attempts[0].lastError, "out of memory");
    store.removeJob(second);
    EXPECT_EQ(store.jobs().size(), 1u);
    EXPECT_TRUE(store.unitAttempts(second).empty());
}

// Descriptions stored before their id was known (id 0) come back with the row's id: workers
// cache scenes by it, so a resumed job must not turn into "job 0".
TEST_F(JobStoreTest, ADescriptionStoredWithoutItsIdGetsTheRowsId) {
    {
        JobStore store(path());
        store.database().execute(
            "INSERT INTO jobs(id, description, state, width, height, filter_border, created_at) "
            "VALUES(12, ?, 1, 4, 4, 0, 0)",
            {v1::JobDescription().SerializeAsString()});
        store.database().execute(
            "INSERT INTO jobs(id, description, state, width, height, filter_border, created_at) "
            "VALUES(13, ?, 1, 4, 4, 0, 0)",
            {std::string("\xff\xff not a protobuf")});
    }
    JobStore store(path());
    const std::vector<JobRow> jobs = store.jobs();
    ASSERT_EQ(jobs.size(), 2u);
    ASSERT_TRUE(jobs[0].description.has_value());
    EXPECT_EQ(jobs[0].description->job_id(), 12u);
    EXPECT_FALSE(jobs[1].description.has_value()) << "damaged bytes parsed";
}

TEST_F(JobStoreTest, EpochsCountStartsAndTheLeaseKeyStays) {
    std::string key;
    {
        JobStore store(path());
        EXPECT_EQ(store.beginEpoch(), 1u);
        key = store.leaseKey();
        EXPECT_EQ(key.size(), 32u);
        WorkerRow worker;
        worker.name = "w";
        worker.cores = 8;
        worker.memoryBytes = uint64_t(1) << 34;
        worker.version = "0.1.0";
        const uint64_t id = store.addWorker(worker, 5);
        const uint64_t gone = store.addWorker(worker, 6);
        store.removeWorker(gone);
        ASSERT_EQ(store.workers().size(), 1u);
        EXPECT_EQ(store.workers()[0].id, id);
        EXPECT_EQ(store.workers()[0].memoryBytes, uint64_t(1) << 34);
        EXPECT_EQ(store.workers()[0].cores, 8u);
    }
    JobStore store(path());
    EXPECT_EQ(store.beginEpoch(), 2u);
    EXPECT_EQ(store.leaseKey(), key);
}

TEST_F(JobStoreTest, TheUnusedBlobsTableIsDropped) {
    {
        StateDatabase db(path());
        db.execute("CREATE TABLE blobs(sha256 TEXT PRIMARY KEY, size INTEGER, stored_at REAL)");
    }
    JobStore store(path());
    EXPECT_TRUE(
        store.database().query("SELECT name FROM sqlite_master WHERE name = 'blobs'").empty());
}

}  // namespace
}  // namespace alphorn::coordinator
