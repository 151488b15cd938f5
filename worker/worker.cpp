#include "worker/worker.h"

#include "common/core/error.h"
#include "common/core/system_memory.h"
#include "common/farm/build_identity.h"
#include "common/farm/bundle.h"
#include "common/farm/chunks.h"
#include "common/farm/convert.h"
#include "common/farm/error_reason.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/job_scene.h"
#include "common/farm/log.h"
#include "common/farm/metrics.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "common/integrator/photon_pass.h"
#include "common/scene/accel.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>
#include <absl/strings/str_replace.h>
#include <google/protobuf/io/coded_stream.h>
#include <google/protobuf/io/zero_copy_stream_impl_lite.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>

namespace alphorn::worker {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

using farm::field;
using farm::logError;
using farm::logInfo;
using farm::logWarning;

namespace {

// Whether a refusal means the coordinator does not know this worker's id. A coordinator of this
// version says so with a typed reason; an older one sent NOT_FOUND without a reason from
// AcquireWork, whose only NOT_FOUND is an unknown worker (`notFoundMeansUnknown`).
bool unknownWorker(const grpc::Status& status, bool notFoundMeansUnknown) {
    switch (farm::reasonOf(status)) {
        case v1::ERROR_REASON_UNKNOWN_WORKER:
            return true;
        case v1::ERROR_REASON_UNSPECIFIED:
            return notFoundMeansUnknown && status.error_code() == grpc::StatusCode::NOT_FOUND;
        default:
            return false;
    }
}

// Test hook (documented in docs/operations.md): ALPHORN_TEST_CRASH_UNIT="NAME:INDEX" makes the
// worker abort, like a crash in the renderer, whenever it starts unit INDEX of a job named NAME.
// The integration tests use it to create a poison unit; nothing else sets it.
void crashIfTestHookMatches(const v1::AcquireWorkResponse& lease) {
    const char* hook = std::getenv("ALPHORN_TEST_CRASH_UNIT");
    if (!hook) return;
    const std::string spec = hook;
    const size_t colon = spec.rfind(':');
    if (colon == std::string::npos) return;
    if (lease.job().settings().name() == spec.substr(0, colon) &&
        std::to_string(lease.unit().unit_index()) == spec.substr(colon + 1)) {
        logWarning("test_hook.crash", {field("hook", "ALPHORN_TEST_CRASH_UNIT"),
                                       field("unit", spec), field("action", "abort")});
        std::abort();
    }
}

// Test hook (documented in docs/operations.md): ALPHORN_TEST_UNIT_DELAY_MS=N makes every unit
// take N ms longer, so integration tests can kill processes mid-job without heavy scenes.
void delayIfTestHookSet() {
    if (const char* delay = std::getenv("ALPHORN_TEST_UNIT_DELAY_MS"))
        std::this_thread::sleep_for(std::chrono::milliseconds(std::atoi(delay)));
}

// Test hook (documented in docs/operations.md): ALPHORN_TEST_PERTURB_RESULTS=1 stands for a
// renderer that is wrong (a bad build, a damaged scene file, faulty memory): every unit's film
// gets one unit of fixed point more red in its middle pixel. The audit tests use it; nothing
// else sets it.
void perturbIfTestHookSet(FilmBlock& block) {
    const char* hook = std::getenv("ALPHORN_TEST_PERTURB_RESULTS");
    if (!hook || std::string(hook) != "1" || block.width() == 0 || block.height() == 0) return;
    block.at(block.x0() + block.width() / 2, block.y0() + block.height() / 2).rgb[0] += 1;
}

using Delivery = farm::WorkerMetrics::Delivery;

Delivery deliveryOf(v1::ResultDisposition disposition) {
    switch (disposition) {
        case v1::RESULT_MERGED:
            return Delivery::Merged;
        case v1::RESULT_DISCARDED:
            return Delivery::Discarded;
        case v1::RESULT_HELD:
            return Delivery::Held;
        default:
            return Delivery::Recorded;  // a failure or a hand-back
    }
}

// Photon paths traced for one pass's data: those of a photon mapper's pass (the volumetric one
// traces surface and volume photons along the same paths), 0 for other integrators.
uint64_t photonsTraced(const PassData* pass) {
    const auto* photons = dynamic_cast<const PhotonPassData*>(pass);
    return photons ? std::max(photons->emitted, photons->volumeEmitted) : 0;
}

// The host id kept in the cache directory (made on first use): 16 hex digits.
std::string hostIdOf(const std::string& cacheDirectory) {
    const std::string path = (fs::path(cacheDirectory) / "host-id").string();
    try {
        const std::string stored = farm::readFile(path);
        if (stored.size() == 16 &&
            stored.find_first_not_of("0123456789abcdef") == std::string::npos)
            return stored;
    } catch (const Error&) {
        // Missing or unreadable: made anew below.
    }
    const std::string made = farm::generateToken().substr(0, 16);
    try {
        farm::writeFileAtomically(path, made);
    } catch (const Error&) {
        // A cache that cannot be written is refused by run(), saying so; this id lasts a run.
    }
    return made;
}

// Everything the scene a unit is rendered with depends on, as one comparable string.
std::string jobIdentity(const v1::JobDescription& job) {
    v1::JobDescription identity;
    identity.set_job_id(job.job_id());
    *identity.mutable_bundle() = job.bundle();
    identity.mutable_settings()->set_seed(job.settings().seed());
    identity.mutable_settings()->set_integrator_override(job.settings().integrator_override());
    std::string bytes;
    {
        google::protobuf::io::StringOutputStream stream(&bytes);
        google::protobuf::io::CodedOutputStream coded(&stream);
        coded.SetSerializationDeterministic(true);
        identity.SerializeToCodedStream(&coded);
    }  // the coded stream writes its last bytes when it goes
    return bytes;
}

}  // namespace

Worker::Worker(WorkerOptions options)
    : m_options(std::move(options)),
      m_cacheLock(m_options.cacheDirectory, {"cache directory", "worker", "--cache-dir"}),
      m_hostId(hostIdOf(m_options.cacheDirectory)),
      m_channel(farm::makeChannel(m_options.coordinator, m_options.tlsCaPath)),
      m_stub(v1::WorkerService::NewStub(m_channel)),
      m_cache((fs::path(m_options.cacheDirectory) / "blobs").string(), m_options.cacheBytes),
      m_retrySeed(m_options.retrySeed != 0
                      ? m_options.retrySeed
                      : (uint64_t(std::random_device{}()) << 32) | std::random_device{}()) {
    if (m_options.name.empty()) {
        char host[256] = {};
        ::gethostname(host, sizeof host - 1);
        m_options.name = std::string(host) + ":" + std::to_string(::getpid());
    }
}

Worker::~Worker() {
    {
        std::lock_guard lock(m_leaseMutex);
        m_finished = true;
    }
    m_leaseWake.notify_all();
    if (m_heartbeat.joinable()) m_heartbeat.join();
}

std::unique_ptr<grpc::ClientContext> Worker::context(std::chrono::milliseconds timeout) const {
    return farm::makeContext(m_options.token, timeout);
}

void Worker::requestStop() {
    const int requests = ++m_stopRequests;
    if (requests >= 2) m_cancelRender = true;  // abandon the unit; it is handed back
    {
        // Do not wait out the long poll; a unit leased in this very moment expires and is
        // requeued by the coordinator.
        std::lock_guard lock(m_leaseMutex);
        if (m_acquireContext) m_acquireContext->TryCancel();
    }
    m_leaseWake.notify_all();
}

farm::RetryPolicy Worker::makeRetryPolicy() {
    // One seeded stream per policy (per retry loop), all derived from the worker's seed.
    const uint64_t index = m_retryPolicies++;
    return farm::RetryPolicy(m_options.retry, m_retrySeed + index * 0x9e3779b97f4a7c15ULL);
}

void Worker::sleepBackoff(farm::RetryPolicy& policy) {
    // The default cap stays short (1 s) because the calls themselves wait for an unreachable
    // coordinator (makeContext), and nothing drives a reconnection while this thread sleeps: a
    // longer pause would only delay finding the coordinator back.
    const std::chrono::milliseconds delay = policy.nextDelay();
    if (m_options.onBackoff) m_options.onBackoff(delay);
    std::unique_lock lock(m_leaseMutex);
    m_leaseWake.wait_for(lock, delay, [&] { return m_stopRequests >= 2; });
}

void Worker::registerWithCoordinator() {
    farm::RetryPolicy retry = makeRetryPolicy();
    for (;;) {
        v1::RegisterRequest request;
        request.set_name(m_options.name);
        request.set_cores(m_options.threads > 0 ? m_options.threads
                                                : std::thread::hardware_concurrency());
        request.set_memory_bytes(physicalMemoryBytes());
        farm::describeThisBuild(request);
        request.set_host_id(m_hostId);
        v1::RegisterResponse response;
        auto ctx = context(m_options.registerTimeout);
        grpc::Status status = m_stub->Register(ctx.get(), request, &response);
        if (status.ok()) {
            m_workerId = response.worker_id();
            m_heartbeatSeconds = std::max(0.05, response.heartbeat_interval_seconds());
            m_mustRegister = false;
            logInfo("worker.registered",
                    {field("worker", response.worker_id()), field("name", m_options.name),
                     field("coordinator", m_options.coordinator)});
            return;
        }
        if (!farm::isTransient(status))
            fail("the coordinator refused registration: %s", status.error_message());
        if (m_stopRequests > 0) fail("stopping before the coordinator could be reached");
        if (retry.failures() == 0) {
            logWarning("coordinator.unavailable",
                       {field("rpc", "Register"), field("error", status.error_message()),
                        field("action", "retrying with backoff")});
            const std::string hint = farm::protocolMismatchHint(
                m_options.coordinator, !m_options.tlsCaPath.empty(), "--tls-ca");
            if (!hint.empty()) logWarning("coordinator.protocol_mismatch", {field("hint", hint)});
        }
        sleepBackoff(retry);
    }
}

void Worker::heartbeatLoop() {
    std::unique_lock lock(m_leaseMutex);
    while (!m_finished) {
        m_leaseWake.wait_for(lock, std::chrono::duration<double>(m_heartbeatSeconds.load()));
        if (m_finished) break;
        if (m_mustRegister) continue;
        v1::HeartbeatRequest request;
        request.set_worker_id(m_workerId);
        // So `alphorn workers` shows this worker draining from the moment it was told to stop.
        request.set_draining(m_stopRequests > 0);
        for (const auto& [lease, unit] : m_activeLeases) {
            request.add_lease_ids(lease);
            *request.add_held_units() = unit;
        }
        lock.unlock();
        v1::HeartbeatResponse response;
        auto ctx = context(std::chrono::milliseconds(
            static_cast<int>(1000 * std::max(1.0, m_heartbeatSeconds.load()))));
        grpc::Status status = m_stub->Heartbeat(ctx.get(), request, &response);
        lock.lock();
        if (!status.ok()) continue;  // the coordinator is away: keep working, keep the result
        // unknown_worker is the same news from a coordinator that predates error_reason.
        if (response.error_reason() == v1::ERROR_REASON_UNKNOWN_WORKER || response.unknown_worker())
            m_mustRegister = true;
        for (uint64_t lease : response.drop_lease_ids()) {
            // Fenced: our lease expired and the unit went to someone else, or it is done.
            if (!m_activeLeases.count(lease)) continue;
            m_fencedLeases.insert(lease);
            if (lease == m_renderingLease) m_cancelRender = true;
        }
    }
}

namespace {

// A failure of this machine's storage, not of the job: see Worker::m_cacheFailure.
class CacheUnusable : public Error {
  public:
    using Error::Error;
};

}  // namespace

Worker::JobContext& Worker::prepareJob(const v1::JobDescription& job) {
    // The cached scene is reused only for the very same job: same id, bundle (content hashes),
    // seed and integrator override. An id alone is not enough: ids of different jobs have been
    // seen equal (descriptions stored without their id), and a worker must never render a unit
    // with another job's scene.
    const std::string identity = jobIdentity(job);
    if (m_job && m_job->identity == identity) return *m_job;
    // One job's scene at a time: the previous one is released, so memory stays flat.
    m_job.reset();
    const fs::path jobsDirectory = fs::path(m_options.cacheDirectory) / "jobs";
    std::error_code ignored;
    fs::remove_all(jobsDirectory, ignored);
    auto context = std::make_unique<JobContext>();
    context->jobId = job.job_id();
    context->identity = identity;
    context->seed = job.settings().seed();
    const farm::Bundle bundle = farm::fromProto(job.bundle());
    for (const auto& file : bundle.files) context->blobs.insert(file.sha256);
    const std::string directory = (jobsDirectory / std::to_string(job.job_id())).string();
    std::string scenePath;
    try {
        scenePath = materializeJobBundle(bundle, directory);
    } catch (const CacheUnusable&) {
        throw;
    } catch (const Error& e) {
        // Whether the cache itself is at fault: then no job could be prepared here.
        const std::string problem = farm::directoryWriteProblem(m_options.cacheDirectory);
        if (!problem.empty()) throw CacheUnusable(std::string(e.what()) + " (" + problem + ")");
        throw;
    }
    m_cache.trim(context->blobs);
    context->scene = farm::loadJobScene(directory, scenePath, job.settings().integrator_override());
    logInfo("job.loaded", {field("job", job.job_id()), field("scene", bundle.scenePath),
                           field("description", context->scene->toString())});
    m_job = std::move(context);
    return *m_job;
}

void Worker::unloadIdleJob(double idleSeconds) {
    const uint64_t jobId = m_job->jobId;
    const uint64_t residentBefore = residentMemoryBytes();
    m_job.reset();
    returnFreeMemoryToSystem();
    logInfo("job.unloaded",
            {field("job", jobId), field("idle_seconds", absl::StrFormat("%.1f", idleSeconds)),
             field("resident_before", formatBytes(residentBefore)),
             field("resident_after", formatBytes(residentMemoryBytes()))});
}

std::string Worker::materializeJobBundle(const farm::Bundle& bundle, const std::string& directory) {
    return farm::materializeBundle(bundle, directory, [&](const std::string& sha) {
        return m_cache.get(sha, [&](const std::string& hash, const std::string& temporary) {
            farm::RetryPolicy retry = makeRetryPolicy();
            for (;;) {
                std::ofstream file(temporary, std::ios::binary | std::ios::trunc);
                v1::GetBlobRequest request;
                request.set_sha256(hash);
                auto ctx = this->context(600s);
                auto reader = m_stub->GetBlob(ctx.get(), request);
                v1::GetBlobChunk chunk;
                while (reader->Read(&chunk))
                    file.write(chunk.data().data(), std::streamsize(chunk.data().size()));
                grpc::Status status = reader->Finish();
                file.flush();
                if (status.ok() && !file)
                    throw CacheUnusable(
                        absl::StrFormat("cannot write blob %s into the worker cache: %s", hash,
                                        std::strerror(errno ? errno : EIO)));
                if (status.ok()) return;
                if (!farm::isTransient(status) || m_stopRequests >= 2)
                    fail("cannot fetch blob %s: %s", hash, status.error_message());
                sleepBackoff(retry);
            }
        });
    });
}

const std::vector<std::shared_ptr<const PassData>>& Worker::passDataFor(JobContext& context,
                                                                        uint32_t begin,
                                                                        uint32_t end, bool& built) {
    const auto key = std::make_pair(begin, end);
    auto it = context.passes.find(key);
    built = it == context.passes.end();
    if (!built) return it->second;
    // Units of the same passes usually follow each other (all tiles of a chunk come first);
    // keep a few ranges so photon maps are built once per range, but never grow without bound.
    while (context.passes.size() >= 4) context.passes.erase(context.passes.begin());
    // A photon mapper without progressive radii keeps one map for every pass: count each pass
    // data once, not once per pass range (the ranges kept hold it, so its address is not reused).
    std::set<const PassData*> counted;
    for (const auto& [range, data] : context.passes)
        for (const auto& pass : data) counted.insert(pass.get());
    auto& passes = context.passes[key] = preparePasses(*context.scene, context.seed, begin, end);
    for (const auto& pass : passes)
        if (pass && counted.insert(pass.get()).second)
            farm::WorkerMetrics::passDataBuilt(photonsTraced(pass.get()));
    return passes;
}

std::optional<Worker::Result> Worker::renderLease(const v1::AcquireWorkResponse& lease) {
    crashIfTestHookMatches(lease);
    delayIfTestHookSet();
    if (m_options.beforeRender) m_options.beforeRender(lease);
    Result result;
    v1::ResultChunk& header = result.header;
    header.set_worker_id(m_workerId);
    header.set_lease_id(lease.lease_id());
    header.set_job_id(lease.unit().job_id());
    header.set_unit_index(lease.unit().unit_index());
    try {
        JobContext& job = prepareJob(lease.job());
        const RenderUnit unit = farm::fromProto(lease.unit());
        bool built = false;
        const auto& passData = passDataFor(job, unit.passBegin, unit.passEnd, built);
        header.set_built_pass_data(built);
        // The block's layout is the job's (the lease says), not what this build would choose
        // for the scene.
        FilmBlock block =
            unitBlock(unit.tile, filterBorder(*job.scene),
                      lease.unit().smaller_radius() ? SmallerRadius::Kept : SmallerRadius::None);
        const auto start = std::chrono::steady_clock::now();
        RenderCounters counters;
        const bool complete =
            renderUnit(*job.scene, job.seed, unit, passData, block, &counters, &m_cancelRender);
        if (!complete) {
            std::lock_guard lock(m_leaseMutex);
            if (m_fencedLeases.count(lease.lease_id())) {
                logInfo("unit.dropped",
                        {field("job", job.jobId), field("unit", lease.unit().unit_index()),
                         field("lease", lease.lease_id()), field("reason", "fenced")});
                return std::nullopt;
            }
            header.set_handed_back(true);  // stopping: give the unit back unrendered
            return result;
        }
        perturbIfTestHookSet(block);
        header.set_block_x0(block.x0());
        header.set_block_y0(block.y0());
        header.set_block_width(block.width());
        header.set_block_height(block.height());
        header.set_invalid_samples(block.invalidSamples);
        result.compressed = farm::compressFilm(block);
        header.set_compressed_size(result.compressed.size());
        header.set_compressed_sha256(farm::sha256Hex(result.compressed));
        const double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        header.set_rays(counters.rays);
        header.set_render_seconds(seconds);
        farm::WorkerMetrics::unitRendered(seconds, counters.samples, counters.rays);
        logInfo("unit.rendered", {field("job", job.jobId), field("unit", lease.unit().unit_index()),
                                  field("seconds", seconds)});
    } catch (const CacheUnusable& e) {
        logError("cache.unusable",
                 {field("job", lease.unit().job_id()), field("unit", lease.unit().unit_index()),
                  field("cache", m_options.cacheDirectory), field("error", e.what()),
                  field("action", "handing back")});
        m_cacheFailure = e.what();
        header.set_handed_back(true);
    } catch (const std::exception& e) {
        farm::WorkerMetrics::unitFailed();
        logWarning("unit.failed",
                   {field("job", lease.unit().job_id()), field("unit", lease.unit().unit_index()),
                    field("error", e.what())});
        // The error reaches the job's owner: it names files by bundle path, never this
        // machine's directories.
        const std::string cache =
            fs::absolute(m_options.cacheDirectory).lexically_normal().string();
        header.set_error(
            absl::StrReplaceAll(e.what(), {{cache + "/", "<worker cache>/"},
                                           {m_options.cacheDirectory + "/", "<worker cache>/"}}));
    }
    return result;
}

bool Worker::deliver(Result& result) {
    farm::RetryPolicy retry = makeRetryPolicy();
    const farm::Stopwatch delivering;
    const auto firstTry = std::chrono::steady_clock::now();
    const auto giveUpAt =
        firstTry + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                       std::chrono::duration<double>(m_options.drainSeconds));
    for (;;) {
        {
            std::lock_guard lock(m_leaseMutex);
            if (m_fencedLeases.count(result.header.lease_id()))
                return true;  // nobody wants it any more
        }
        if (m_mustRegister) {
            try {
                registerWithCoordinator();
            } catch (const Error& e) {
                logWarning("result.abandoned",
                           {field("job", result.header.job_id()),
                            field("unit", result.header.unit_index()), field("error", e.what())});
                farm::WorkerMetrics::resultDelivered(Delivery::Abandoned, delivering.seconds());
                return false;
            }
            result.header.set_worker_id(m_workerId);
        }
        // The call waits for a coordinator that is away (restarting) and goes out the moment it
        // is back; when stopping, no longer than the drain time left.
        // A second stop request wants the worker gone: one attempt of at most a second.
        auto timeout = m_options.deliverTimeout;
        if (m_stopRequests > 1)
            timeout = std::min(std::chrono::milliseconds(1000), timeout);
        else if (m_stopRequests > 0)
            timeout = std::clamp(std::chrono::duration_cast<std::chrono::milliseconds>(
                                     giveUpAt - std::chrono::steady_clock::now()),
                                 std::min(std::chrono::milliseconds(1000), timeout), timeout);
        auto ctx = context(timeout);
        v1::ReportResultResponse response;
        auto writer = m_stub->ReportResult(ctx.get(), &response);
        const bool written = farm::sendChunks(
            result.compressed,
            [&](std::string_view data, bool first, bool) {
                v1::ResultChunk chunk;
                if (first) chunk = result.header;
                chunk.set_data(std::string(data));
                return writer->Write(chunk);
            },
            farm::kChunkBytes);
        if (written) writer->WritesDone();
        grpc::Status status = writer->Finish();
        if (status.ok()) {
            farm::WorkerMetrics::resultDelivered(deliveryOf(response.disposition()),
                                                 delivering.seconds());
            if (retry.failures() > 0)
                logInfo("result.delivered_late",
                        {field("job", result.header.job_id()),
                         field("unit", result.header.unit_index()),
                         field("failed_attempts", retry.failures()),
                         field("seconds", std::chrono::duration<double>(
                                              std::chrono::steady_clock::now() - firstTry)
                                              .count())});
            if (response.disposition() == v1::RESULT_DISCARDED)
                logInfo("result.discarded", {field("job", result.header.job_id()),
                                             field("unit", result.header.unit_index()),
                                             field("reason", "merged already or reassigned")});
            return true;
        }
        if (unknownWorker(status, false)) {
            m_mustRegister = true;
            continue;
        }
        if (!farm::isTransient(status)) {
            // UNKNOWN_JOB (removed after it ended) and any other refusal: nobody wants it.
            logWarning("result.refused", {field("job", result.header.job_id()),
                                          field("unit", result.header.unit_index()),
                                          field("error", status.error_message())});
            farm::WorkerMetrics::resultDelivered(Delivery::Refused, delivering.seconds());
            return true;
        }
        if (m_stopRequests > 1 ||
            (m_stopRequests > 0 && std::chrono::steady_clock::now() > giveUpAt)) {
            farm::WorkerMetrics::resultDelivered(Delivery::Abandoned, delivering.seconds());
            return false;
        }
        if (retry.failures() == 0)
            logWarning("result.undelivered", {field("job", result.header.job_id()),
                                              field("unit", result.header.unit_index()),
                                              field("error", status.error_message()),
                                              field("action", "keeping it and retrying")});
        sleepBackoff(retry);
    }
}

void Worker::sayGoodbye() {
    if (m_mustRegister) return;
    // The coordinator lists the worker as gone at once instead of after its silence; should
    // the call fail, that is what happens.
    v1::HeartbeatRequest request;
    request.set_worker_id(m_workerId);
    request.set_draining(true);
    request.set_exiting(true);
    v1::HeartbeatResponse response;
    auto ctx = context(std::chrono::milliseconds(1000));
    m_stub->Heartbeat(ctx.get(), request, &response);
}

int Worker::run() {
    // A cache that went read-only or full since it was made would fail every unit given here.
    if (const std::string problem = farm::directoryWriteProblem(m_options.cacheDirectory);
        !problem.empty())
        fail("the worker cache %s cannot be written: %s", m_options.cacheDirectory, problem);
    registerWithCoordinator();
    m_heartbeat = std::thread([this] { heartbeatLoop(); });
    farm::RetryPolicy retry = makeRetryPolicy();
    bool drainedByClient = false;
    std::string idleReason;  // why the coordinator gives this worker no unit, as it last said
    farm::Stopwatch askingForWork;
    while (m_stopRequests == 0) {
        if (m_mustRegister) {
            registerWithCoordinator();
            continue;
        }
        v1::AcquireWorkRequest request;
        request.set_worker_id(m_workerId);
        v1::AcquireWorkResponse lease;
        auto ctx = context(m_options.acquireTimeout);
        {
            std::lock_guard lock(m_leaseMutex);
            if (m_stopRequests > 0) break;
            m_acquireContext = ctx.get();
        }
        grpc::Status status = m_stub->AcquireWork(ctx.get(), request, &lease);
        {
            std::lock_guard lock(m_leaseMutex);
            m_acquireContext = nullptr;
        }
        if (m_stopRequests > 0 && status.error_code() == grpc::StatusCode::CANCELLED) break;
        if (!status.ok()) {
            if (unknownWorker(status, true)) {
                m_mustRegister = true;
                continue;
            }
            if (!farm::isTransient(status))
                fail("the coordinator refused AcquireWork: %s", status.error_message());
            if (retry.failures() == 0)
                logWarning("coordinator.unavailable",
                           {field("rpc", "AcquireWork"), field("error", status.error_message()),
                            field("action", "retrying with backoff")});
            sleepBackoff(retry);
            continue;
        }
        if (retry.failures() > 0)
            logInfo("coordinator.back", {field("failed_attempts", retry.failures())});
        retry.reset();
        if (lease.draining() != drainedByClient) {
            drainedByClient = lease.draining();
            logInfo(drainedByClient ? "worker.drain_requested" : "worker.undrained",
                    {field("worker", m_workerId.load()), field("by", "client")});
        }
        if (lease.idle_reason() != idleReason) {
            // Said once each time it changes: a worker of another build waits beside the farm.
            idleReason = lease.idle_reason();
            if (idleReason.empty())
                logInfo("worker.eligible", {field("worker", m_workerId.load())});
            else
                logWarning("worker.ineligible",
                           {field("worker", m_workerId.load()), field("reason", idleReason)});
        }
        if (!lease.has_work()) {
            // askingForWork runs from the end of the last unit.
            if (m_job && askingForWork.seconds() * 1000.0 >= double(m_options.unloadAfter.count()))
                unloadIdleJob(askingForWork.seconds());
            continue;
        }
        farm::WorkerMetrics::leaseWaited(askingForWork.seconds());
        {
            std::lock_guard lock(m_leaseMutex);
            v1::HeldUnit held;
            held.set_job_id(lease.unit().job_id());
            held.set_unit_index(lease.unit().unit_index());
            held.set_lease_token(lease.lease_token());
            m_activeLeases[lease.lease_id()] = held;
            m_renderingLease = lease.lease_id();
            m_cancelRender = m_stopRequests >= 2;
        }
        std::optional<Result> result = renderLease(lease);
        {
            std::lock_guard lock(m_leaseMutex);
            m_renderingLease = 0;
        }
        if (result) deliver(*result);
        std::lock_guard lock(m_leaseMutex);
        m_activeLeases.erase(lease.lease_id());
        m_fencedLeases.erase(lease.lease_id());
        askingForWork = farm::Stopwatch();
        if (!m_cacheFailure.empty()) break;
    }
    // No heartbeat may follow the goodbye: it would list the worker alive again.
    {
        std::lock_guard lock(m_leaseMutex);
        m_finished = true;
    }
    m_leaseWake.notify_all();
    if (m_heartbeat.joinable()) m_heartbeat.join();
    sayGoodbye();
    if (!m_cacheFailure.empty())
        fail(
            "the worker cache %s cannot be written: %s; the unit went back to the coordinator "
            "for another worker. Free space in it or make it writable, then start the worker "
            "again",
            m_options.cacheDirectory, m_cacheFailure);
    logInfo("worker.drained", {field("worker", m_workerId.load())});
    return 0;
}

}  // namespace alphorn::worker
