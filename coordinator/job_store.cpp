#include "coordinator/job_store.h"

#include "common/farm/sha256.h"

#include <absl/strings/str_format.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <openssl/rand.h>

namespace alphorn::coordinator {

namespace {

constexpr const char* kSchema[] = {
    R"sql(CREATE TABLE IF NOT EXISTS jobs(
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  description BLOB NOT NULL,   -- serialized alphorn.v1.JobDescription (bundle + settings)
  state INTEGER NOT NULL,      -- alphorn.v1.JobState
  error TEXT NOT NULL DEFAULT '',
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  filter_border INTEGER NOT NULL,
  created_at REAL NOT NULL,
  finished_at REAL))sql",
    R"sql(CREATE TABLE IF NOT EXISTS units(
  job_id INTEGER NOT NULL,
  unit_index INTEGER NOT NULL,
  attempts INTEGER NOT NULL,   -- failed attempts: worker errors and expired leases
  last_error TEXT NOT NULL,
  PRIMARY KEY(job_id, unit_index)))sql",
    R"sql(CREATE TABLE IF NOT EXISTS meta(
  key TEXT PRIMARY KEY,        -- 'epoch': starts of this state directory; 'lease_key': HMAC key
  value BLOB NOT NULL))sql",
    R"sql(CREATE TABLE IF NOT EXISTS workers(
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  name TEXT NOT NULL,
  cores INTEGER NOT NULL,
  memory_bytes INTEGER NOT NULL,
  version TEXT NOT NULL,
  registered_at REAL NOT NULL))sql",
    // Earlier versions recorded uploaded blobs here and never read them: the blob directory is
    // what counts (blob_store.h).
    "DROP TABLE IF EXISTS blobs",
    R"sql(CREATE TABLE IF NOT EXISTS job_logs(
  job_id INTEGER PRIMARY KEY,
  log BLOB NOT NULL,           -- serialized alphorn.v1.JobEventLog (bounded, see event_log.h)
  next_sequence INTEGER NOT NULL  -- the log's next_sequence: a newer log is never overwritten
))sql",
    // Retries and deletes sent with a request id, so that the same request sent again gets the
    // first answer (ControlRequestRow); no foreign key: a delete's record outlives its job.
    R"sql(CREATE TABLE IF NOT EXISTS control_requests(
  request_id TEXT PRIMARY KEY,  -- RetryJobRequest/DeleteJobRequest.request_id
  action TEXT NOT NULL,         -- 'retry' or 'delete'
  job_id INTEGER NOT NULL,
  answer BLOB NOT NULL,         -- the first answer, serialized; empty until recorded
  recorded_at REAL NOT NULL     -- wall clock; forgotten after a bounded time
))sql",
};

// Columns added after the first release, with their declarations: databases of earlier
// versions get them on open.
struct AddedColumn {
    const char *table, *column, *declaration;
};
constexpr AddedColumn kAddedColumns[] = {
    {"jobs", "paused", "INTEGER NOT NULL DEFAULT 0"},
    {"workers", "draining", "INTEGER NOT NULL DEFAULT 0"},
    {"jobs", "smaller_radius", "INTEGER NOT NULL DEFAULT 0"},
    // The client's id of the submission that created the job (SubmitJobRequest.submission_id);
    // empty for jobs submitted without one, and for those stored before it existed.
    {"jobs", "submission_id", "TEXT NOT NULL DEFAULT ''"},
    // JobStore::recordDigest() of the row at submission; empty for jobs stored before it existed,
    // which are resumed unchecked.
    {"jobs", "record_sha256", "TEXT NOT NULL DEFAULT ''"},
    // RegisterRequest.engine_fingerprint; empty for workers stored before it existed, which are
    // leased nothing until they register again.
    {"workers", "engine_fingerprint", "TEXT NOT NULL DEFAULT ''"},
    // Why the done job's image is suspect (a worker that rendered some of it was quarantined
    // later); empty when it is not. Not part of the record's digest: it changes after submit.
    {"jobs", "suspect", "TEXT NOT NULL DEFAULT ''"},
    // Why an audit quarantined the worker (no units until it registers again as a new worker);
    // empty when it is not quarantined.
    {"workers", "quarantined", "TEXT NOT NULL DEFAULT ''"},
};

using Value = StateDatabase::Value;
using Write = StateDatabase::Write;

// The write that records a control request with its change.
Write recordControlRequest(const ControlRequestRow& request) {
    return {
        "INSERT INTO control_requests(request_id, action, job_id, answer, recorded_at) "
        "VALUES(?, ?, ?, ?, ?)",
        {request.requestId, request.action, int64_t(request.jobId), request.answer,
         request.recordedAt}};
}

double real(const Value& value) {
    if (const double* number = std::get_if<double>(&value)) return *number;
    if (const int64_t* number = std::get_if<int64_t>(&value)) return double(*number);
    return 0;
}

}  // namespace

JobStore::JobStore(const std::string& path) : m_db(path) {
    for (const char* statement : kSchema) m_db.execute(statement);
    for (const AddedColumn& added : kAddedColumns) {
        bool present = false;
        for (const auto& row : m_db.query(std::string("PRAGMA table_info(") + added.table + ")"))
            present = present || StateDatabase::text(row.at(1)) == added.column;
        if (!present)
            m_db.execute(std::string("ALTER TABLE ") + added.table + " ADD COLUMN " + added.column +
                         " " + added.declaration);
    }
}

uint64_t JobStore::beginEpoch() {
    const auto rows = m_db.query("SELECT value FROM meta WHERE key = 'epoch'");
    const uint64_t epoch = rows.empty() ? 1 : uint64_t(StateDatabase::integer(rows[0][0])) + 1;
    m_db.execute("INSERT OR REPLACE INTO meta(key, value) VALUES('epoch', ?)", {int64_t(epoch)});
    return epoch;
}

std::string JobStore::leaseKey() {
    const auto rows = m_db.query("SELECT value FROM meta WHERE key = 'lease_key'");
    std::string key = rows.empty() ? std::string() : StateDatabase::text(rows[0][0]);
    if (key.size() != 32) {
        key.assign(32, '\0');
        if (RAND_bytes(reinterpret_cast<unsigned char*>(key.data()), 32) != 1)
            fail("cannot generate the lease key (OpenSSL)");
        m_db.execute("INSERT OR REPLACE INTO meta(key, value) VALUES('lease_key', ?)", {key});
    }
    return key;
}

std::string JobStore::recordDigest(const JobRow& row) {
    // The description without what may change (or is the row's id), serialized
    // deterministically: the same fields give the same bytes whichever process wrote them.
    v1::JobDescription fixed = row.description.value_or(v1::JobDescription());
    fixed.set_job_id(0);
    fixed.mutable_settings()->set_priority(0);
    std::string description;
    {
        google::protobuf::io::StringOutputStream stream(&description);
        google::protobuf::io::CodedOutputStream coded(&stream);
        coded.SetSerializationDeterministic(true);
        fixed.SerializeToCodedStream(&coded);
    }
    // Versioned and length-prefixed, so no two different rows hash the same text. The creation
    // time as its exact bits (%a): SQLite keeps a REAL's every bit.
    farm::Sha256 digest;
    digest.update(absl::StrFormat("alphorn job record 1\n%d %d %d %d %a\n%u:%s\n%u:", row.width,
                                  row.height, row.filterBorder, row.smallerRadius ? 1 : 0,
                                  row.createdAt, row.submissionId.size(), row.submissionId,
                                  description.size()));
    digest.update(description);
    return digest.finishHex();
}

uint64_t JobStore::addJob(const v1::JobDescription& description, int width, int height,
                          int filterBorder, double createdAt, bool smallerRadius,
                          const std::string& submissionId) {
    JobRow fixed;
    fixed.description = description;
    fixed.width = width;
    fixed.height = height;
    fixed.filterBorder = filterBorder;
    fixed.createdAt = createdAt;
    fixed.smallerRadius = smallerRadius;
    fixed.submissionId = submissionId;
    const auto rows = m_db.query(
        "INSERT INTO jobs(description, state, width, height, filter_border, created_at, "
        "smaller_radius, submission_id, record_sha256) VALUES(?, ?, ?, ?, ?, ?, ?, ?, ?) "
        "RETURNING id",
        {description.SerializeAsString(), int64_t(v1::JOB_STATE_RUNNING), int64_t(width),
         int64_t(height), int64_t(filterBorder), createdAt, int64_t(smallerRadius ? 1 : 0),
         submissionId, recordDigest(fixed)});
    const uint64_t id = uint64_t(StateDatabase::integer(rows.at(0).at(0)));
    // The stored description carries its id too, so workers told of a resumed job load that
    // job's scene and no other. (No transaction: the connection is shared between threads.)
    v1::JobDescription stored = description;
    stored.set_job_id(id);
    try {
        m_db.execute("UPDATE jobs SET description = ? WHERE id = ?",
                     {stored.SerializeAsString(), int64_t(id)});
    } catch (const StorageError&) {
        try {
            removeJob(id);
        } catch (const StorageError&) {
            // The row stays without its id; jobs() gives it back with the row's id all the same.
        }
        throw;
    }
    return id;
}

std::vector<JobRow> JobStore::jobs() {
    std::vector<JobRow> result;
    for (const auto& row : m_db.query("SELECT id, description, state, error, width, height, "
                                      "filter_border, created_at, finished_at, paused, "
                                      "smaller_radius, submission_id, record_sha256, suspect "
                                      "FROM jobs")) {
        JobRow job;
        job.id = uint64_t(StateDatabase::integer(row[0]));
        v1::JobDescription description;
        if (description.ParseFromString(StateDatabase::text(row[1]))) {
            // The id is the row's; descriptions stored before it was known carry 0.
            description.set_job_id(job.id);
            job.description = std::move(description);
        }
        job.state = StateDatabase::integer(row[2]);
        job.error = StateDatabase::text(row[3]);
        job.width = int(StateDatabase::integer(row[4]));
        job.height = int(StateDatabase::integer(row[5]));
        job.filterBorder = int(StateDatabase::integer(row[6]));
        job.createdAt = real(row[7]);
        job.finishedAt = real(row[8]);
        job.paused = StateDatabase::integer(row[9]) != 0;
        job.smallerRadius = StateDatabase::integer(row[10]) != 0;
        job.submissionId = StateDatabase::text(row[11]);
        job.recordSha256 = StateDatabase::text(row[12]);
        job.suspect = StateDatabase::text(row[13]);
        result.push_back(std::move(job));
    }
    return result;
}

void JobStore::setJobState(uint64_t jobId, v1::JobState state, const std::string& error,
                           double finishedAt) {
    m_db.execute("UPDATE jobs SET state = ?, error = ?, finished_at = ? WHERE id = ?",
                 {int64_t(state), error, finishedAt > 0 ? Value(finishedAt) : Value(nullptr),
                  int64_t(jobId)});
}

void JobStore::removeJob(uint64_t jobId, const ControlRequestRow* request) {
    std::vector<Write> writes = {{"DELETE FROM units WHERE job_id = ?", {int64_t(jobId)}},
                                 {"DELETE FROM job_logs WHERE job_id = ?", {int64_t(jobId)}},
                                 {"DELETE FROM jobs WHERE id = ?", {int64_t(jobId)}}};
    if (request) writes.push_back(recordControlRequest(*request));
    m_db.transaction(writes);
}

void JobStore::markJobRetried(uint64_t jobId, const ControlRequestRow* request) {
    std::vector<Write> writes = {
        {"DELETE FROM units WHERE job_id = ?", {int64_t(jobId)}},
        {"UPDATE jobs SET paused = 0, state = ?, error = '', finished_at = NULL WHERE id = ?",
         {int64_t(v1::JOB_STATE_RUNNING), int64_t(jobId)}}};
    if (request) writes.push_back(recordControlRequest(*request));
    m_db.transaction(writes);
}

std::optional<ControlRequestRow> JobStore::controlRequest(const std::string& requestId) {
    const auto rows = m_db.query(
        "SELECT action, job_id, answer, recorded_at FROM control_requests WHERE request_id = ?",
        {requestId});
    if (rows.empty()) return std::nullopt;
    ControlRequestRow request;
    request.requestId = requestId;
    request.action = StateDatabase::text(rows[0][0]);
    request.jobId = uint64_t(StateDatabase::integer(rows[0][1]));
    request.answer = StateDatabase::text(rows[0][2]);
    request.recordedAt = real(rows[0][3]);
    return request;
}

void JobStore::setControlRequestAnswer(const std::string& requestId, const std::string& answer) {
    m_db.execute("UPDATE control_requests SET answer = ? WHERE request_id = ?",
                 {answer, requestId});
}

uint64_t JobStore::removeControlRequestsBefore(double wallSeconds) {
    return uint64_t(
        m_db.query("DELETE FROM control_requests WHERE recorded_at < ? RETURNING request_id",
                   {wallSeconds})
            .size());
}

void JobStore::setJobDescription(uint64_t jobId, const v1::JobDescription& description) {
    v1::JobDescription stored = description;
    stored.set_job_id(jobId);
    m_db.execute("UPDATE jobs SET description = ? WHERE id = ?",
                 {stored.SerializeAsString(), int64_t(jobId)});
}

void JobStore::setJobSuspect(uint64_t jobId, const std::string& reason) {
    m_db.execute("UPDATE jobs SET suspect = ? WHERE id = ?", {reason, int64_t(jobId)});
}

void JobStore::setJobPaused(uint64_t jobId, bool paused) {
    m_db.execute("UPDATE jobs SET paused = ? WHERE id = ?", {int64_t(paused), int64_t(jobId)});
}

void JobStore::saveJobLog(uint64_t jobId, const v1::JobEventLog& log) {
    // Only for a job that exists (a log saved as its job is removed must not outlive it), and
    // never over a newer log (two threads may save one job's log at once).
    m_db.execute(
        "INSERT INTO job_logs(job_id, log, next_sequence) SELECT ?, ?, ? WHERE EXISTS (SELECT 1 "
        "FROM jobs WHERE id = ?) ON CONFLICT(job_id) DO UPDATE SET log = excluded.log, "
        "next_sequence = excluded.next_sequence WHERE excluded.next_sequence >= "
        "job_logs.next_sequence",
        {int64_t(jobId), log.SerializeAsString(), int64_t(log.next_sequence()), int64_t(jobId)});
}

v1::JobEventLog JobStore::jobLog(uint64_t jobId) {
    v1::JobEventLog log;
    const auto rows = m_db.query("SELECT log FROM job_logs WHERE job_id = ?", {int64_t(jobId)});
    if (!rows.empty() && !log.ParseFromString(StateDatabase::text(rows[0][0]))) log.Clear();
    return log;
}

void JobStore::setUnitAttempts(uint64_t jobId, uint32_t unitIndex, uint32_t attempts,
                               const std::string& lastError) {
    m_db.execute(
        "INSERT INTO units(job_id, unit_index, attempts, last_error) VALUES(?, ?, ?, ?) "
        "ON CONFLICT(job_id, unit_index) DO UPDATE SET attempts = excluded.attempts, "
        "last_error = excluded.last_error",
        {int64_t(jobId), int64_t(unitIndex), int64_t(attempts), lastError});
}

std::vector<UnitAttemptsRow> JobStore::unitAttempts(uint64_t jobId) {
    std::vector<UnitAttemptsRow> result;
    for (const auto& row :
         m_db.query("SELECT unit_index, attempts, last_error FROM units WHERE job_id = ?",
                    {int64_t(jobId)})) {
        const int64_t index = StateDatabase::integer(row[0]);
        if (index < 0 || index > int64_t(UINT32_MAX)) continue;
        result.push_back(UnitAttemptsRow{
            uint32_t(index),
            uint32_t(std::clamp<int64_t>(StateDatabase::integer(row[1]), 0, UINT32_MAX)),
            StateDatabase::text(row[2])});
    }
    return result;
}

void JobStore::clearUnitAttempts(uint64_t jobId) {
    m_db.execute("DELETE FROM units WHERE job_id = ?", {int64_t(jobId)});
}

uint64_t JobStore::addWorker(const WorkerRow& worker, double registeredAt) {
    const auto rows = m_db.query(
        "INSERT INTO workers(name, cores, memory_bytes, version, engine_fingerprint, "
        "registered_at) VALUES(?, ?, ?, ?, ?, ?) RETURNING id",
        {worker.name, int64_t(worker.cores), int64_t(worker.memoryBytes), worker.version,
         worker.engineFingerprint, registeredAt});
    return uint64_t(StateDatabase::integer(rows.at(0).at(0)));
}

std::vector<WorkerRow> JobStore::workers() {
    std::vector<WorkerRow> result;
    for (const auto& row : m_db.query("SELECT id, name, cores, memory_bytes, version, draining, "
                                      "engine_fingerprint, quarantined FROM workers")) {
        WorkerRow worker;
        worker.id = uint64_t(StateDatabase::integer(row[0]));
        worker.name = StateDatabase::text(row[1]);
        worker.cores = uint32_t(StateDatabase::integer(row[2]));
        worker.memoryBytes = uint64_t(StateDatabase::integer(row[3]));
        worker.version = StateDatabase::text(row[4]);
        worker.draining = StateDatabase::integer(row[5]) != 0;
        worker.engineFingerprint = StateDatabase::text(row[6]);
        worker.quarantined = StateDatabase::text(row[7]);
        result.push_back(std::move(worker));
    }
    return result;
}

void JobStore::removeWorker(uint64_t workerId) {
    m_db.execute("DELETE FROM workers WHERE id = ?", {int64_t(workerId)});
}

void JobStore::setWorkerQuarantined(uint64_t workerId, const std::string& reason) {
    m_db.execute("UPDATE workers SET quarantined = ? WHERE id = ?", {reason, int64_t(workerId)});
}

void JobStore::setWorkerDraining(uint64_t workerId, bool draining) {
    m_db.execute("UPDATE workers SET draining = ? WHERE id = ?",
                 {int64_t(draining), int64_t(workerId)});
}

}  // namespace alphorn::coordinator
