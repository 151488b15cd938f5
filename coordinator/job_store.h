// The coordinator's durable records in SQLite, behind typed rows: jobs (description, shape,
// state), failed unit attempts, each job's event log, registered workers, and the lease epoch
// and key. The schema lives here and nowhere else; film sums are not here but in each job's
// checkpoint (job_film.h).
// Every method throws StorageError when the database cannot be written or read.
#pragma once

#include "alphorn/v1/client_service.pb.h"
#include "alphorn/v1/worker_service.pb.h"
#include "coordinator/state_db.h"

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace alphorn::coordinator {

struct JobRow {
    uint64_t id = 0;
    // The stored description with the row's id set in it (a resumed job is the same job for
    // workers, who cache scenes by it); nullopt when the stored bytes do not parse.
    std::optional<v1::JobDescription> description;
    int64_t state = 0;  // an alphorn.v1.JobState, unchecked
    std::string error;
    int width = 0, height = 0, filterBorder = 0;
    // The job's films keep the smaller radius's image (false for jobs stored before it existed).
    bool smallerRadius = false;
    double createdAt = 0;
    double finishedAt = 0;  // 0 while running
    bool paused = false;    // a client paused it (no new leases)
    // The client's SubmitJobRequest.submission_id; empty when it sent none.
    std::string submissionId;
    // JobStore::recordDigest() of the row as it was submitted; empty for rows stored before
    // the digest existed (or whose submission failed to store it), which are not checked.
    std::string recordSha256;
    std::string suspect;  // why the done job's image is suspect; empty when it is not
};

// A client's retry or delete that carried a request id (RetryJobRequest.request_id,
// DeleteJobRequest.request_id), recorded in the transaction that makes its change, so that the
// same request sent again (after a coordinator restart lost the answer) is recognised and gets
// the first answer instead of being refused for the change it made. Kept for a bounded time
// (Coordinator::kControlRequestKeepSeconds); a delete's outlives the job's row.
struct ControlRequestRow {
    std::string requestId;
    std::string action;  // "retry" or "delete"
    uint64_t jobId = 0;
    // The first call's answer, serialized (a JobControlResponse or a DeleteJobResponse); empty
    // when the coordinator stopped between the change and recording its answer.
    std::string answer;
    double recordedAt = 0;  // wall clock
};

struct UnitAttemptsRow {
    uint32_t unitIndex = 0;
    uint32_t attempts = 0;  // failed attempts: worker errors and expired leases
    std::string lastError;
};

struct WorkerRow {
    uint64_t id = 0;
    std::string name, version, engineFingerprint;
    uint32_t cores = 0;
    uint64_t memoryBytes = 0;
    bool draining = false;    // a client drained it (no new units)
    std::string quarantined;  // why an audit quarantined it; empty when it is not
};

class JobStore {
  public:
    // Opens (creating if needed) the database at `path`.
    explicit JobStore(const std::string& path);

    // Counts one more start of the state directory and returns that number (1 for the first).
    uint64_t beginEpoch();
    // The key lease tokens are signed with, created on first use (32 random bytes).
    std::string leaseKey();

    // Stores a new running job and returns its id; the stored description carries the id.
    uint64_t addJob(const v1::JobDescription& description, int width, int height, int filterBorder,
                    double createdAt, bool smallerRadius = false,
                    const std::string& submissionId = "");
    std::vector<JobRow> jobs();
    // A digest (SHA-256, hex) of what a job's row holds that never changes after submission:
    // the description (scene bundle, settings but the priority, photon radius schedule), the
    // image size, filter border, smaller radius, creation time and submission id. What a
    // client may change (priority, pause) and the job's state are left out. Stored by addJob();
    // a row whose digest differs from the one stored with it was changed outside the
    // coordinator. Needs the row's description (nullopt: empty).
    static std::string recordDigest(const JobRow& row);
    // Records that a job ended (or, with JOB_STATE_RUNNING and finishedAt 0, runs again).
    void setJobState(uint64_t jobId, v1::JobState state, const std::string& error,
                     double finishedAt);
    // Deletes the job, its unit records and its event log, all or nothing; records `request`
    // with them when given.
    void removeJob(uint64_t jobId, const ControlRequestRow* request = nullptr);
    // A retried job runs again: forgets its failed attempts, clears its pause and marks it
    // running, all or nothing; records `request` with them when given.
    void markJobRetried(uint64_t jobId, const ControlRequestRow* request = nullptr);
    // The recorded request with this id, if any.
    std::optional<ControlRequestRow> controlRequest(const std::string& requestId);
    // Records the first answer of a request recorded with its change.
    void setControlRequestAnswer(const std::string& requestId, const std::string& answer);
    // Forgets the requests recorded before `wallSeconds`; returns how many.
    uint64_t removeControlRequestsBefore(double wallSeconds);
    // Replaces the stored description (a new priority); the id stays the row's.
    void setJobDescription(uint64_t jobId, const v1::JobDescription& description);
    void setJobPaused(uint64_t jobId, bool paused);
    // Records why the done job's image is suspect (a worker that rendered some of it was
    // quarantined).
    void setJobSuspect(uint64_t jobId, const std::string& reason);
    // The job's event log (a serialized alphorn.v1.JobEventLog), written whole each time; not
    // stored for a job the store does not have (removed meanwhile), nor over a log with a
    // higher next_sequence (a newer one).
    void saveJobLog(uint64_t jobId, const v1::JobEventLog& log);
    // The stored log; empty when there is none or it does not parse.
    v1::JobEventLog jobLog(uint64_t jobId);

    void setUnitAttempts(uint64_t jobId, uint32_t unitIndex, uint32_t attempts,
                         const std::string& lastError);
    std::vector<UnitAttemptsRow> unitAttempts(uint64_t jobId);
    // Forgets every failed attempt of the job (it runs again).
    void clearUnitAttempts(uint64_t jobId);

    uint64_t addWorker(const WorkerRow& worker, double registeredAt);
    std::vector<WorkerRow> workers();
    void removeWorker(uint64_t workerId);
    void setWorkerDraining(uint64_t workerId, bool draining);
    // Records (or, with "", clears) why an audit quarantined the worker.
    void setWorkerQuarantined(uint64_t workerId, const std::string& reason);

    // The SQL connection, for tests that damage records on purpose.
    StateDatabase& database() { return m_db; }

  private:
    StateDatabase m_db;
};

}  // namespace alphorn::coordinator
