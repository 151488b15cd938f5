#include "coordinator/services.h"

#include "common/core/image.h"
#include "common/farm/chunks.h"
#include "common/farm/error_reason.h"
#include "common/farm/film_codec.h"
#include "common/farm/metrics.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "coordinator/log.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_split.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>
#include <vector>

namespace alphorn::coordinator {

namespace fs = std::filesystem;

std::string relativeToStateDirectory(const std::string& message,
                                     const std::string& stateDirectory) {
    // The directory as given and as resolved, without trailing slashes, longest first: a
    // message may name it either way (SQLite names the file it was opened with, the file
    // system's errors the path they were handed).
    // No path without a '/': most messages (and every event of a healthy job) need no work, in
    // particular not the file system calls that resolve the directory below.
    if (message.find('/') == std::string::npos) return message;
    std::vector<std::string> spellings;
    const auto addSpelling = [&](std::string spelling) {
        while (spelling.size() > 1 && spelling.back() == '/') spelling.pop_back();
        if (spelling.empty() || spelling == "/" || spelling == ".") return;
        if (std::find(spellings.begin(), spellings.end(), spelling) == spellings.end())
            spellings.push_back(spelling);
    };
    addSpelling(stateDirectory);
    std::error_code error;
    addSpelling(fs::absolute(stateDirectory, error).lexically_normal().string());
    addSpelling(fs::weakly_canonical(stateDirectory, error).string());
    std::sort(spellings.begin(), spellings.end(),
              [](const std::string& a, const std::string& b) { return a.size() > b.size(); });
    // A spelling counts where it starts a path: at the start of the message or after a
    // character that cannot be part of one (so "/x/state" is left alone). Followed by '/' and
    // a name, it goes with its slashes; an absolute spelling that ends a path names the
    // directory itself. A relative spelling alone is left, since it may be a word ("its state").
    const auto pathCharacter = [](char c) {
        return absl::ascii_isalnum(static_cast<unsigned char>(c)) || c == '/' || c == '.' ||
               c == '_' || c == '-' || c == '~';
    };
    std::string out;
    for (size_t i = 0; i < message.size();) {
        bool replaced = false;
        if (i == 0 || !pathCharacter(message[i - 1])) {
            for (const std::string& spelling : spellings) {
                if (message.compare(i, spelling.size(), spelling) != 0) continue;
                size_t end = i + spelling.size();
                while (end < message.size() && message[end] == '/') ++end;
                const bool endsPath = end == message.size() || !pathCharacter(message[end]);
                if (!endsPath && end == i + spelling.size()) continue;  // "/x/state2"
                if (endsPath) {
                    if (spelling.front() != '/') continue;
                    out += "the state directory";
                }
                i = end;
                replaced = true;
                break;
            }
        }
        if (!replaced) out += message[i++];
    }
    return out;
}

namespace {

grpc::Status toStatus(const std::exception& e) {
    if (auto* farmError = dynamic_cast<const FarmError*>(&e)) {
        switch (farmError->kind) {
            case FarmError::Kind::InvalidArgument:
                return {grpc::StatusCode::INVALID_ARGUMENT, e.what()};
            case FarmError::Kind::NotFound:
                return farm::statusWithReason(grpc::StatusCode::NOT_FOUND, e.what(),
                                              v1::ERROR_REASON_UNKNOWN_JOB);
            case FarmError::Kind::UnknownWorker:
                return farm::statusWithReason(grpc::StatusCode::NOT_FOUND, e.what(),
                                              v1::ERROR_REASON_UNKNOWN_WORKER);
            case FarmError::Kind::FailedPrecondition:
                return {grpc::StatusCode::FAILED_PRECONDITION, e.what()};
            case FarmError::Kind::ResourceExhausted:
                return {grpc::StatusCode::RESOURCE_EXHAUSTED, e.what()};
            case FarmError::Kind::Unavailable:
                return {grpc::StatusCode::UNAVAILABLE, e.what()};
            case FarmError::Kind::CallerGone:
                return {grpc::StatusCode::CANCELLED, e.what()};
        }
    }
    if (dynamic_cast<const StorageError*>(&e)) {
        logWarning("rpc.storage_error", {field("error", e.what())});
        return {grpc::StatusCode::UNAVAILABLE,
                std::string("the coordinator cannot write its state (retry later): ") + e.what()};
    }
    if (dynamic_cast<const Error*>(&e)) return {grpc::StatusCode::INVALID_ARGUMENT, e.what()};
    logWarning("rpc.internal_error", {field("error", e.what())});
    return {grpc::StatusCode::INTERNAL, e.what()};
}

// Waits up to `delay` ms (a decimal number) or until the call is cancelled (its deadline
// passed, the client went away, the server stopping).
void waitUnlessCancelled(grpc::ServerContext& context, const char* delay) {
    const auto until =
        std::chrono::steady_clock::now() + std::chrono::milliseconds(std::atoi(delay));
    while (std::chrono::steady_clock::now() < until && !context.IsCancelled())
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
}

// Test hook (documented in docs/operations.md): ALPHORN_TEST_SUBMIT_ANSWER_DELAY_MS=N makes
// the SubmitJob call that created a job wait up to N ms between creating it and answering, or
// until the call is cancelled (its deadline passed, the server stopping), so integration tests
// can restart the coordinator, or let the client's time limit pass, while the answer of a
// created job is due. A call sent again that gets the job is answered at once. Nothing else
// sets it.
void delayAnswerIfTestHookSet(grpc::ServerContext& context, uint64_t jobId) {
    const char* delay = std::getenv("ALPHORN_TEST_SUBMIT_ANSWER_DELAY_MS");
    if (!delay) return;
    static std::mutex mutex;
    static std::set<uint64_t> delayed;
    {
        std::lock_guard lock(mutex);
        if (!delayed.insert(jobId).second) return;
    }
    logWarning("test_hook.submit_answer_delay",
               {field("hook", "ALPHORN_TEST_SUBMIT_ANSWER_DELAY_MS"), field("job", jobId),
                field("ms", delay)});
    waitUnlessCancelled(context, delay);
}

// Test hook (documented in docs/operations.md): ALPHORN_TEST_ANSWER_DELAY_MS=N with
// ALPHORN_TEST_ANSWER_DELAY_RPCS=NAME,NAME,... makes those client calls wait up to N ms after
// doing their work and before answering (a streaming call: before its status), or until the
// call is cancelled, so integration tests can restart the coordinator while their answer is
// due. Nothing else sets them.
void delayRpcAnswerIfTestHookSet(grpc::ServerContext& context, const char* rpc) {
    const char* delay = std::getenv("ALPHORN_TEST_ANSWER_DELAY_MS");
    const char* rpcs = std::getenv("ALPHORN_TEST_ANSWER_DELAY_RPCS");
    if (!delay || !rpcs) return;
    const std::vector<std::string> names = absl::StrSplit(rpcs, ',');
    if (std::find(names.begin(), names.end(), rpc) == names.end()) return;
    logWarning("test_hook.answer_delay", {field("hook", "ALPHORN_TEST_ANSWER_DELAY_MS"),
                                          field("rpc", rpc), field("ms", delay)});
    waitUnlessCancelled(context, delay);
}

// A status as the caller sees it: the coordinator's own paths are none of a client's or
// worker's business, so every name under the state directory is given relative to it
// ("state.sqlite", "jobs/7/checkpoint") and the directory itself as "the state directory". The
// coordinator's log keeps the full paths.
grpc::Status withoutStatePaths(const grpc::Status& status, const std::string& stateDirectory) {
    if (status.ok()) return status;
    return {status.error_code(), relativeToStateDirectory(status.error_message(), stateDirectory),
            status.error_details()};
}

// Runs `body` after the token check, turning exceptions into statuses.
template <typename Body>
grpc::Status guarded(grpc::ServerContext* context, const Coordinator& coordinator,
                     const std::string& token, const char* rpc, Body&& body) {
    grpc::Status auth = farm::checkBearer(*context, token);
    if (!auth.ok()) {
        logWarning("rpc.refused", {field("rpc", rpc), field("peer", context->peer()),
                                   field("reason", auth.error_message())});
        return auth;
    }
    const std::string& stateDirectory = coordinator.options().stateDirectory;
    try {
        grpc::Status status = body();
        if (status.ok()) delayRpcAnswerIfTestHookSet(*context, rpc);
        return withoutStatePaths(status, stateDirectory);
    } catch (const std::exception& e) {
        return withoutStatePaths(toStatus(e), stateDirectory);
    }
}

template <typename Chunk>
bool streamBytes(grpc::ServerWriter<Chunk>* writer, const std::string& bytes,
                 const std::function<void(Chunk&)>& first) {
    return farm::sendChunks(
        bytes,
        [&](std::string_view data, bool isFirst, bool) {
            Chunk chunk;
            if (isFirst) first(chunk);
            chunk.set_data(std::string(data));
            return writer->Write(chunk);
        },
        farm::kChunkBytes);
}

}  // namespace

// ---- client ------------------------------------------------------------------------------------

grpc::Status ClientServiceImpl::HasBlobs(grpc::ServerContext* context,
                                         const v1::HasBlobsRequest* request,
                                         v1::HasBlobsResponse* response) {
    return guarded(context, m_coordinator, m_token, "HasBlobs", [&] {
        std::vector<std::string> present;
        for (const std::string& sha : request->sha256())
            if (m_coordinator.blobs().has(sha))
                present.push_back(sha);
            else
                response->add_missing(sha);
        // A client asks before it submits: keep these blobs until then.
        m_coordinator.touchBlobs(present);
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::PutBlobs(grpc::ServerContext* context,
                                         grpc::ServerReader<v1::BlobChunk>* reader,
                                         v1::PutBlobsResponse* response) {
    return guarded(context, m_coordinator, m_token, "PutBlobs", [&] {
        std::unique_ptr<BlobStore::Upload> upload;
        std::string current;
        v1::BlobChunk chunk;
        while (reader->Read(&chunk)) {
            if (current.empty()) {
                current = chunk.sha256();
                try {
                    upload = std::make_unique<BlobStore::Upload>(m_coordinator.blobs(), current);
                } catch (const Error& e) {
                    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what());
                }
            } else if (!chunk.sha256().empty() && chunk.sha256() != current) {
                return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                    "a new blob started before the last chunk of " + current);
            }
            try {
                upload->append(chunk.data());
            } catch (const Error& e) {
                logWarning("blob.refused", {field("sha256", current), field("reason", e.what())});
                return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED, e.what());
            }
            if (chunk.last()) {
                try {
                    if (upload->commit()) {
                        m_coordinator.touchBlobs({current});
                        response->set_stored(response->stored() + 1);
                    } else {
                        response->set_already_present(response->already_present() + 1);
                    }
                } catch (const Error& e) {
                    logWarning("blob.refused",
                               {field("sha256", current), field("reason", e.what())});
                    return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, e.what());
                }
                upload.reset();
                current.clear();
            }
        }
        if (!current.empty())
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                "the stream ended inside blob " + current);
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::SubmitJob(grpc::ServerContext* context,
                                          const v1::SubmitJobRequest* request,
                                          v1::SubmitJobResponse* response) {
    return guarded(context, m_coordinator, m_token, "SubmitJob", [&] {
        try {
            *response->mutable_status() =
                m_coordinator.submit(*request, [context] { return context->IsCancelled(); });
            delayAnswerIfTestHookSet(*context, response->status().job_id());
        } catch (const FarmError& e) {
            logWarning("job.refused", {field("reason", e.what())});
            throw;
        }
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::WatchJob(grpc::ServerContext* context,
                                         const v1::WatchJobRequest* request,
                                         grpc::ServerWriter<v1::JobStatus>* writer) {
    using SteadyClock = std::chrono::steady_clock;
    // A status unchanged but for its times and rates is sent again after kKeepAlive (the
    // client's ETA and throughput stay fresh); changes within kGather of the last status sent
    // go out together, so a job merging thousands of units a second sends a few statuses a
    // second, while its end goes out at once. The synchronous gRPC API gives no callback when
    // the client goes away, so that is checked every kCancelCheck of a quiet wait.
    constexpr auto kKeepAlive = std::chrono::seconds(2);
    constexpr auto kGather = std::chrono::milliseconds(200);
    constexpr auto kCancelCheck = std::chrono::milliseconds(100);
    return guarded(context, m_coordinator, m_token, "WatchJob", [&] {
        if (request->job_id() == 0)
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                "WatchJob needs a job id (job ids start at 1)");
        const std::shared_ptr<const ChangeSignal> changes =
            m_coordinator.changeSignal(request->job_id());
        // A closed signal: the job was deleted (listJobs throws NotFound) or the coordinator
        // is stopping (the client reconnects to the next process).
        const auto closed = [&] {
            m_coordinator.listJobs(request->job_id());
            return grpc::Status(grpc::StatusCode::UNAVAILABLE, "the coordinator is stopping");
        };
        std::string last;
        SteadyClock::time_point lastSent;
        for (;;) {
            // The version is read before the status, so a change in between wakes the wait.
            const ChangeSignal::Seen seen = changes->current();
            if (seen.closed) return closed();
            const v1::JobStatus status = m_coordinator.listJobs(request->job_id()).at(0);
            v1::JobStatus comparable = status;
            comparable.clear_elapsed_seconds();
            comparable.clear_eta_seconds();
            comparable.clear_samples_per_second();
            comparable.clear_rays_per_second();
            std::string serialized = comparable.SerializeAsString();
            if (serialized != last || SteadyClock::now() - lastSent >= kKeepAlive) {
                if (!writer->Write(status)) return grpc::Status::OK;
                last = std::move(serialized);
                lastSent = SteadyClock::now();
            }
            if (status.state() != v1::JOB_STATE_RUNNING) return grpc::Status::OK;
            // Wait for a change (then out the gathering time, unless the job ends), the
            // keep-alive, the client's cancel or the coordinator's stop.
            bool changed = false;
            for (;;) {
                if (context->IsCancelled()) return grpc::Status::CANCELLED;
                const auto now = SteadyClock::now();
                const auto keepAliveAt = lastSent + kKeepAlive;
                if (now >= keepAliveAt || (changed && now >= lastSent + kGather)) break;
                const auto until = std::min(keepAliveAt, now + kCancelCheck);
                const ChangeSignal::Seen next =
                    changed ? changes->waitForEnd(std::min(until, lastSent + kGather))
                            : changes->waitForChange(seen.version, until);
                if (next.closed) return closed();
                if (next.ended) break;
                changed = changed || next.version != seen.version;
            }
        }
    });
}

grpc::Status ClientServiceImpl::GetImage(grpc::ServerContext* context,
                                         const v1::GetImageRequest* request,
                                         grpc::ServerWriter<v1::ImageChunk>* writer) {
    return guarded(context, m_coordinator, m_token, "GetImage", [&] {
        // An unknown format would otherwise be served as an EXR and an absurd exposure as a
        // black or white PNG: a client's mistake must be told, not answered with an image.
        if (!v1::ImageFormat_IsValid(request->format()))
            return grpc::Status(
                grpc::StatusCode::INVALID_ARGUMENT,
                absl::StrFormat("format %d is not an alphorn.v1.ImageFormat (EXR %d, PNG %d, FILM "
                                "%d; %d means EXR)",
                                int(request->format()), int(v1::IMAGE_FORMAT_EXR),
                                int(v1::IMAGE_FORMAT_PNG), int(v1::IMAGE_FORMAT_FILM),
                                int(v1::IMAGE_FORMAT_UNSPECIFIED)));
        if (!(std::abs(request->exposure()) <= kMaxPngExposureStops))
            return grpc::Status(
                grpc::StatusCode::INVALID_ARGUMENT,
                absl::StrFormat("exposure must be a number of stops from -%g to "
                                "%g (got %g)",
                                kMaxPngExposureStops, kMaxPngExposureStops, request->exposure()));
        Coordinator::ImageSnapshot snapshot =
            m_coordinator.snapshot(request->job_id(), request->preview());
        const v1::JobStatus& status = snapshot.status;
        std::string bytes;
        if (request->format() == v1::IMAGE_FORMAT_FILM) {
            bytes = farm::compressFilm(snapshot.film);
        } else {
            // The very same bytes as writeEXR(resolveImage(film)) in `alphorn render`, encoded in
            // memory: an image can be fetched while the state directory's disk is full or
            // read-only.
            const Image image =
                resolveImage(snapshot.film, int(status.width()), int(status.height()));
            if (request->format() == v1::IMAGE_FORMAT_PNG)
                bytes = encodePNG(image, request->exposure());
            else
                bytes = encodeEXR(image);
        }
        streamBytes<v1::ImageChunk>(writer, bytes, [&](v1::ImageChunk& chunk) {
            chunk.set_total_size(bytes.size());
            chunk.set_width(status.width());
            chunk.set_height(status.height());
            chunk.set_passes_done(status.passes_done());
            chunk.set_state(status.state());
        });
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::CancelJob(grpc::ServerContext* context,
                                          const v1::CancelJobRequest* request,
                                          v1::CancelJobResponse* response) {
    return guarded(context, m_coordinator, m_token, "CancelJob", [&] {
        *response->mutable_status() = m_coordinator.cancel(request->job_id());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::ListJobs(grpc::ServerContext* context,
                                         const v1::ListJobsRequest* request,
                                         v1::ListJobsResponse* response) {
    return guarded(context, m_coordinator, m_token, "ListJobs", [&] {
        for (auto& status : m_coordinator.listJobs(request->job_id()))
            *response->add_jobs() = std::move(status);
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::ListWorkers(grpc::ServerContext* context,
                                            const v1::ListWorkersRequest* request,
                                            v1::ListWorkersResponse* response) {
    return guarded(context, m_coordinator, m_token, "ListWorkers", [&] {
        for (auto& worker : m_coordinator.listWorkers(request->include_dead()))
            *response->add_workers() = std::move(worker);
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::RetryJob(grpc::ServerContext* context,
                                         const v1::RetryJobRequest* request,
                                         v1::JobControlResponse* response) {
    return guarded(context, m_coordinator, m_token, "RetryJob", [&] {
        *response->mutable_status() = m_coordinator.retry(request->job_id(), request->request_id());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::SetJobPaused(grpc::ServerContext* context,
                                             const v1::SetJobPausedRequest* request,
                                             v1::JobControlResponse* response) {
    return guarded(context, m_coordinator, m_token, "SetJobPaused", [&] {
        *response->mutable_status() = m_coordinator.setPaused(request->job_id(), request->paused());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::SetJobPriority(grpc::ServerContext* context,
                                               const v1::SetJobPriorityRequest* request,
                                               v1::JobControlResponse* response) {
    return guarded(context, m_coordinator, m_token, "SetJobPriority", [&] {
        *response->mutable_status() =
            m_coordinator.setPriority(request->job_id(), request->priority());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::DeleteJob(grpc::ServerContext* context,
                                          const v1::DeleteJobRequest* request,
                                          v1::DeleteJobResponse* response) {
    return guarded(context, m_coordinator, m_token, "DeleteJob", [&] {
        *response = m_coordinator.deleteJob(request->job_id(), request->cancel_running(),
                                            request->request_id());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::GetJobLog(grpc::ServerContext* context,
                                          const v1::GetJobLogRequest* request,
                                          v1::GetJobLogResponse* response) {
    return guarded(context, m_coordinator, m_token, "GetJobLog", [&] {
        *response = m_coordinator.jobLog(request->job_id(), request->after_sequence());
        return grpc::Status::OK;
    });
}

grpc::Status ClientServiceImpl::SetWorkerDraining(grpc::ServerContext* context,
                                                  const v1::SetWorkerDrainingRequest* request,
                                                  v1::SetWorkerDrainingResponse* response) {
    return guarded(context, m_coordinator, m_token, "SetWorkerDraining", [&] {
        *response->mutable_worker() =
            m_coordinator.setWorkerDraining(request->worker_id(), request->draining());
        return grpc::Status::OK;
    });
}

// ---- workers -----------------------------------------------------------------------------------

grpc::Status WorkerServiceImpl::Register(grpc::ServerContext* context,
                                         const v1::RegisterRequest* request,
                                         v1::RegisterResponse* response) {
    return guarded(context, m_coordinator, m_token, "Register", [&] {
        response->set_worker_id(m_coordinator.registerWorker(*request));
        response->set_heartbeat_interval_seconds(m_coordinator.heartbeatIntervalSeconds());
        return grpc::Status::OK;
    });
}

grpc::Status WorkerServiceImpl::AcquireWork(grpc::ServerContext* context,
                                            const v1::AcquireWorkRequest* request,
                                            v1::AcquireWorkResponse* response) {
    return guarded(context, m_coordinator, m_token, "AcquireWork", [&] {
        const farm::Stopwatch call;
        // Long poll: wait up to 2 s for work, so idle workers neither spin nor lag behind a submit.
        auto until = std::chrono::steady_clock::now() + std::chrono::seconds(2);
        *response = m_coordinator.acquire(request->worker_id(), until);
        if (response->has_work()) farm::CoordinatorMetrics::leaseWaited(call.seconds());
        if (response->has_work())
            logInfo("unit.leased",
                    {field("job", response->unit().job_id()),
                     field("unit", response->unit().unit_index()),
                     field("worker", request->worker_id()), field("lease", response->lease_id())});
        return grpc::Status::OK;
    });
}

grpc::Status WorkerServiceImpl::Heartbeat(grpc::ServerContext* context,
                                          const v1::HeartbeatRequest* request,
                                          v1::HeartbeatResponse* response) {
    return guarded(context, m_coordinator, m_token, "Heartbeat", [&] {
        *response = m_coordinator.heartbeat(*request);
        if (response->unknown_worker()) response->set_error_reason(v1::ERROR_REASON_UNKNOWN_WORKER);
        return grpc::Status::OK;
    });
}

grpc::Status WorkerServiceImpl::ReportResult(grpc::ServerContext* context,
                                             grpc::ServerReader<v1::ResultChunk>* reader,
                                             v1::ReportResultResponse* response) {
    return guarded(context, m_coordinator, m_token, "ReportResult", [&] {
        const farm::Stopwatch call;
        v1::ResultChunk header;
        if (!reader->Read(&header))
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, "empty result stream");
        std::string data = header.data();
        header.clear_data();
        const uint64_t limit = m_coordinator.maxResultBytes(header.job_id());
        if (limit == 0)
            return farm::statusWithReason(grpc::StatusCode::NOT_FOUND, "no such job",
                                          v1::ERROR_REASON_UNKNOWN_JOB);
        if (header.error().empty() && !header.handed_back() && header.compressed_size() > limit)
            return grpc::Status(grpc::StatusCode::RESOURCE_EXHAUSTED,
                                "the result is larger than any unit of the job");
        const bool withinSize =
            farm::receiveChunks<grpc::ServerReader<v1::ResultChunk>, v1::ResultChunk>(
                *reader, data, [&](const v1::ResultChunk& chunk) {
                    return data.size() + chunk.data().size() <= header.compressed_size();
                });
        if (!withinSize)
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                "more result bytes than announced");
        if (data.size() != header.compressed_size())
            return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT,
                                "the result stream ended early");
        const v1::ResultDisposition disposition = m_coordinator.report(header, data);
        response->set_disposition(disposition);
        if (disposition == v1::RESULT_MERGED)
            farm::CoordinatorMetrics::resultMerged(call.seconds());
        return grpc::Status::OK;
    });
}

grpc::Status WorkerServiceImpl::GetBlob(grpc::ServerContext* context,
                                        const v1::GetBlobRequest* request,
                                        grpc::ServerWriter<v1::GetBlobChunk>* writer) {
    return guarded(context, m_coordinator, m_token, "GetBlob", [&] {
        if (!m_coordinator.blobs().has(request->sha256()))
            return grpc::Status(
                grpc::StatusCode::NOT_FOUND,
                absl::StrFormat("the coordinator has no blob %s (a copy found damaged on its disk "
                                "is removed): submit the scene again to upload it",
                                request->sha256()));
        // A stored blob is checked before it is served: one damaged on the coordinator's disk
        // would otherwise fail every unit of every job that uses it as "arrived corrupt", and,
        // still listed as stored, would never be uploaded again. It is removed, so the next
        // submission of the scene uploads it anew.
        const std::string path = m_coordinator.blobs().pathOf(request->sha256());
        const std::string actual = farm::sha256OfFile(path);
        if (actual != request->sha256()) {
            m_coordinator.blobs().remove(request->sha256());
            logError("blob.damaged", {field("blob", request->sha256()), field("hashes_to", actual),
                                      field("action", "removed")});
            return grpc::Status(
                grpc::StatusCode::DATA_LOSS,
                absl::StrFormat("the coordinator's copy of blob %s was damaged on its disk (it "
                                "hashes to %s) and has been removed: submit the scene again to "
                                "upload it",
                                request->sha256(), actual));
        }
        std::ifstream file(path, std::ios::binary);
        const uint64_t total = m_coordinator.blobs().size(request->sha256());
        farm::sendChunks(
            file,
            [&](std::string_view data, bool first, bool) {
                v1::GetBlobChunk chunk;
                if (first) chunk.set_total_size(total);
                chunk.set_data(std::string(data));
                return writer->Write(chunk);
            },
            farm::kChunkBytes);
        return grpc::Status::OK;
    });
}

}  // namespace alphorn::coordinator
