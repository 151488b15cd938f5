// The job store: typed rows round-trip, a job's description comes back under its own id, the
// epoch counts starts, the lease key stays, the old never-read blobs table is dropped, and the
// job and worker controls (pause, priority, event log, drain) are stored, also in a database of
// an earlier version.
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
        second = store.addJob(description, 8, 6, 0, 1001, true, "5f0c2a");
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
    EXPECT_FALSE(jobs[0].smallerRadius);
    EXPECT_TRUE(jobs[1].smallerRadius);
    EXPECT_EQ(jobs[0].submissionId, "");
    EXPECT_EQ(jobs[1].submissionId, "5f0c2a");
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

// A retry's or delete's writes and the record of its request are one transaction: a request
// that cannot be recorded (here its id is taken) leaves the job as it was. Records are kept
// after the job's row and forgotten by their time.
TEST_F(JobStoreTest, AControlRequestIsRecordedWithItsChangeOrNeither) {
    JobStore store(path());
    const uint64_t job = store.addJob(v1::JobDescription(), 8, 6, 0, 1000);
    store.setJobState(job, v1::JOB_STATE_FAILED, "it broke", 2000);
    store.setJobPaused(job, true);
    store.setUnitAttempts(job, 1, 3, "out of memory");
    const ControlRequestRow retry{"r1", "retry", job, "", 3000};
    store.markJobRetried(job, &retry);
    ASSERT_EQ(store.jobs().size(), 1u);
    EXPECT_EQ(store.jobs()[0].state, v1::JOB_STATE_RUNNING);
    EXPECT_EQ(store.jobs()[0].error, "");
    EXPECT_EQ(store.jobs()[0].finishedAt, 0);
    EXPECT_FALSE(store.jobs()[0].paused);
    EXPECT_TRUE(store.unitAttempts(job).empty());
    store.setControlRequestAnswer("r1", "the first answer");
    ASSERT_TRUE(store.controlRequest("r1"));
    EXPECT_EQ(store.controlRequest("r1")->action, "retry");
    EXPECT_EQ(store.controlRequest("r1")->answer, "the first answer");

    store.setUnitAttempts(job, 2, 1, "lease expired");
    const ControlRequestRow taken{"r1", "delete", job, "", 3001};
    EXPECT_THROW(store.removeJob(job, &taken), StorageError);
    EXPECT_EQ(store.jobs().size(), 1u) << "the job was removed without its request";
    EXPECT_EQ(store.unitAttempts(job).size(), 1u);
    EXPECT_EQ(store.controlRequest("r1")->action, "retry");

    const ControlRequestRow deletion{"d1", "delete", job, "", 3002};
    store.removeJob(job, &deletion);
    EXPECT_TRUE(store.jobs().empty());
    ASSERT_TRUE(store.controlRequest("d1"));
    EXPECT_EQ(store.controlRequest("d1")->jobId, job);
    EXPECT_EQ(store.removeControlRequestsBefore(3001), 1u);
    EXPECT_FALSE(store.controlRequest("r1"));
    EXPECT_TRUE(store.controlRequest("d1"));
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

TEST_F(JobStoreTest, ControlsAndEventLogsAreStoredAndGoWithTheirJob) {
    v1::JobDescription description;
    description.mutable_settings()->set_passes(3);
    uint64_t job = 0, worker = 0;
    v1::JobEventLog log;
    log.set_dropped(4);
    log.set_next_sequence(9);
    log.add_events()->set_message("submitted");
    {
        JobStore store(path());
        job = store.addJob(description, 8, 6, 0, 1000);
        store.setJobPaused(job, true);
        description.mutable_settings()->set_priority(-3);
        store.setJobDescription(job, description);
        store.saveJobLog(job, log);
        store.saveJobLog(job + 1, log);  // no such job: not stored
        store.setUnitAttempts(job, 1, 2, "lease expired");
        store.clearUnitAttempts(job);
        worker = store.addWorker(
            WorkerRow{0, "w", "0.1.0", "0123456789abcdef", 4, 1 << 20, false, ""}, 1000);
        store.setWorkerDraining(worker, true);
        store.setWorkerQuarantined(worker, "its render of unit 3 differs");
        store.setJobSuspect(job, "worker 2 was quarantined");
    }
    JobStore store(path());
    const JobRow row = store.jobs().at(0);
    EXPECT_TRUE(row.paused);
    EXPECT_EQ(row.description->settings().priority(), -3);
    EXPECT_EQ(row.description->job_id(), job);
    EXPECT_EQ(store.jobLog(job).SerializeAsString(), log.SerializeAsString());
    v1::JobEventLog older = log;
    older.set_next_sequence(8);
    older.clear_events();
    store.saveJobLog(job, older);
    EXPECT_EQ(store.jobLog(job).SerializeAsString(), log.SerializeAsString())
        << "an older log overwrote a newer one";
    EXPECT_EQ(store.jobLog(job + 1).events_size(), 0);
    EXPECT_TRUE(store.unitAttempts(job).empty());
    EXPECT_TRUE(store.workers().at(0).draining);
    EXPECT_EQ(store.workers().at(0).engineFingerprint, "0123456789abcdef");
    EXPECT_EQ(store.workers().at(0).quarantined, "its render of unit 3 differs");
    EXPECT_EQ(row.suspect, "worker 2 was quarantined");
    store.removeJob(job);
    EXPECT_EQ(store.jobLog(job).events_size(), 0) << "the log outlived its job";
}

// A database of a version without the control columns gets them, with nothing paused or drained
// and no submission id.
TEST_F(JobStoreTest, AnEarlierDatabaseGetsTheControlColumns) {
    {
        StateDatabase db(path());
        db.execute(
            "CREATE TABLE jobs(id INTEGER PRIMARY KEY AUTOINCREMENT, description BLOB NOT NULL, "
            "state INTEGER NOT NULL, error TEXT NOT NULL DEFAULT '', width INTEGER NOT NULL, "
            "height INTEGER NOT NULL, filter_border INTEGER NOT NULL, created_at REAL NOT NULL, "
            "finished_at REAL)");
        db.execute(
            "CREATE TABLE workers(id INTEGER PRIMARY KEY AUTOINCREMENT, name TEXT NOT NULL, "
            "cores INTEGER NOT NULL, memory_bytes INTEGER NOT NULL, version TEXT NOT NULL, "
            "registered_at REAL NOT NULL)");
        db.execute(
            "INSERT INTO jobs(description, state, width, height, filter_border, created_at) "
            "VALUES(x'', 1, 8, 6, 0, 1000)");
        db.execute(
            "INSERT INTO workers(name, cores, memory_bytes, version, registered_at) "
            "VALUES('w', 1, 1, '0.1.0', 1000)");
    }
    JobStore store(path());
    EXPECT_FALSE(store.jobs().at(0).paused);
    EXPECT_EQ(store.jobs().at(0).submissionId, "");
    EXPECT_FALSE(store.workers().at(0).draining);
    JobStore again(path());  // the columns are added once
    EXPECT_EQ(again.jobs().size(), 1u);
}

}  // namespace
}  // namespace alphorn::coordinator
