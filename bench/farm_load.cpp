// Coordinator capacity: many simulated workers (threads that lease units and return empty,
// correctly shaped results without rendering) against a real alphorn-coordinator. Prints
// completed units per second and lease (AcquireWork) latency percentiles.
// With CLIENT_CALLS_PER_SECOND > 0 a client thread meanwhile takes turns fetching the job's
// preview film (GetImage, as a dashboard or `alphorn fetch --preview` does) and changing its
// priority (SetJobPriority, a store write), the client calls that take the coordinator's lock for
// longer than a lease does; their latencies are printed too.
//
//   bench_farm_load ADDR CLIENT_TOKEN_FILE WORKER_TOKEN_FILE SCENE.xml WORKERS PASSES
//                   [CLIENT_CALLS_PER_SECOND]
#include "alphorn/v1/client_service.grpc.pb.h"
#include "alphorn/v1/worker_service.grpc.pb.h"
#include "common/farm/build_identity.h"
#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/film_codec.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "common/render/unit.h"
#include "common/scene/accel.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <iostream>
#include <map>
#include <mutex>
#include <thread>

using namespace alphorn;
using Clock = std::chrono::steady_clock;

int main(int argc, char** argv) {
    if (argc < 7 || argc > 10) {
        std::cerr << "usage: bench_farm_load ADDR CLIENT_TOKEN_FILE WORKER_TOKEN_FILE SCENE.xml "
                     "WORKERS PASSES [CLIENT_CALLS_PER_SECOND [TILE_SIZE [film|png]]]\n";
        return 2;
    }
    const std::string address = argv[1];
    const std::string clientToken = farm::readTokenFile(argv[2]),
                      workerToken = farm::readTokenFile(argv[3]);
    const std::string scenePath = argv[4];
    const int workers = std::stoi(argv[5]);
    const uint32_t passes = static_cast<uint32_t>(std::stoul(argv[6]));
    const double clientCallsPerSecond = argc >= 8 ? std::stod(argv[7]) : 0.0;
    // 1-pixel tiles by default: the most units, the smallest results. Larger tiles on a large
    // image make a large film with few units (what a preview of a real job copies).
    const int tileSize = argc >= 9 ? std::stoi(argv[8]) : 1;
    // The previews' format: the raw film (default), or a PNG, whose transfer costs less CPU
    // beside the coordinator on a small machine than a large film's.
    const v1::ImageFormat previewFormat =
        argc == 10 && std::string(argv[9]) == "png" ? v1::IMAGE_FORMAT_PNG : v1::IMAGE_FORMAT_FILM;

    // The result every unit returns: an empty block of the unit's shape, made once per shape.
    auto scene = loadScene(scenePath);
    struct EmptyResult {
        FilmBlock block;
        std::string compressed, sha256;
    };
    std::mutex resultsMutex;
    std::map<std::pair<int, int>, EmptyResult> emptyResults;
    auto emptyResult = [&](const v1::UnitSpec& unit) -> const EmptyResult& {
        std::lock_guard lock(resultsMutex);
        const Tile tile{unit.x0(), unit.y0(), unit.x1(), unit.y1()};
        auto [it, added] = emptyResults.try_emplace({tile.width(), tile.height()}, EmptyResult{});
        if (added) {
            it->second.block = makeUnitBlock(*scene, Tile{0, 0, tile.width(), tile.height()});
            it->second.compressed = farm::compressFilm(it->second.block);
            it->second.sha256 = farm::sha256Hex(it->second.compressed);
        }
        return it->second;
    };
    const int border = -makeUnitBlock(*scene, Tile{0, 0, 1, 1}).x0();

    std::vector<std::shared_ptr<grpc::Channel>> channels;
    for (int i = 0; i < 4; ++i) {
        grpc::ChannelArguments arguments;
        arguments.SetInt("grpc.channel_id", i);  // distinct channels, distinct connections
        channels.push_back(
            grpc::CreateCustomChannel(address, grpc::InsecureChannelCredentials(), arguments));
    }
    auto client = v1::ClientService::NewStub(channels[0]);
    const farm::Bundle bundle = farm::gatherBundle(scenePath);
    for (const auto& file : bundle.files) {
        std::ifstream in(file.sourcePath, std::ios::binary);
        std::string bytes((std::istreambuf_iterator<char>(in)), {});
        auto context = farm::makeContext(clientToken, std::chrono::seconds(30));
        v1::PutBlobsResponse response;
        auto writer = client->PutBlobs(context.get(), &response);
        v1::BlobChunk chunk;
        chunk.set_sha256(file.sha256);
        chunk.set_data(bytes);
        chunk.set_last(true);
        writer->Write(chunk);
        writer->WritesDone();
        if (!writer->Finish().ok()) return 1;
    }
    v1::SubmitJobRequest submit;
    *submit.mutable_bundle() = farm::toProto(bundle);
    submit.mutable_settings()->set_passes(passes);
    submit.mutable_settings()->set_tile_size(tileSize);
    submit.mutable_settings()->set_name("farm-load");
    v1::SubmitJobResponse submitted;
    grpc::Status status = client->SubmitJob(
        farm::makeContext(clientToken, std::chrono::seconds(30)).get(), submit, &submitted);
    if (!status.ok()) {
        std::cerr << "submit: " << status.error_message() << "\n";
        return 1;
    }
    const uint32_t units = submitted.status().units_total();

    std::mutex latencyMutex;
    std::vector<double> acquireMs, reportMs;
    std::atomic<uint64_t> merged{0};
    std::atomic<bool> done{false};
    const auto start = Clock::now();
    std::vector<std::thread> threads;
    for (int w = 0; w < workers; ++w) {
        threads.emplace_back([&, w] {
            auto stub = v1::WorkerService::NewStub(channels[w % channels.size()]);
            v1::RegisterRequest registration;
            farm::describeThisBuild(registration);
            registration.set_name(absl::StrFormat("sim-%d", w));
            v1::RegisterResponse registered;
            if (!stub->Register(farm::makeContext(workerToken, std::chrono::seconds(30)).get(),
                                registration, &registered)
                     .ok())
                return;
            std::vector<double> myAcquire, myReport;
            while (!done) {
                v1::AcquireWorkRequest request;
                request.set_worker_id(registered.worker_id());
                v1::AcquireWorkResponse lease;
                auto t0 = Clock::now();
                if (!stub->AcquireWork(
                             farm::makeContext(workerToken, std::chrono::seconds(30)).get(),
                             request, &lease)
                         .ok())
                    break;
                auto t1 = Clock::now();
                if (!lease.has_work()) break;  // the job is fully leased
                myAcquire.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
                v1::ResultChunk chunk;
                chunk.set_worker_id(registered.worker_id());
                chunk.set_lease_id(lease.lease_id());
                chunk.set_job_id(lease.unit().job_id());
                chunk.set_unit_index(lease.unit().unit_index());
                chunk.set_block_x0(lease.unit().x0() - border);
                chunk.set_block_y0(lease.unit().y0() - border);
                const EmptyResult& result = emptyResult(lease.unit());
                chunk.set_block_width(result.block.width());
                chunk.set_block_height(result.block.height());
                chunk.set_compressed_size(result.compressed.size());
                chunk.set_compressed_sha256(result.sha256);
                chunk.set_data(result.compressed);
                auto context = farm::makeContext(workerToken, std::chrono::seconds(30));
                v1::ReportResultResponse response;
                auto writer = stub->ReportResult(context.get(), &response);
                writer->Write(chunk);
                writer->WritesDone();
                if (writer->Finish().ok() && response.disposition() == v1::RESULT_MERGED) ++merged;
                myReport.push_back(
                    std::chrono::duration<double, std::milli>(Clock::now() - t1).count());
                if (merged >= units) done = true;
            }
            std::lock_guard lock(latencyMutex);
            acquireMs.insert(acquireMs.end(), myAcquire.begin(), myAcquire.end());
            reportMs.insert(reportMs.end(), myReport.begin(), myReport.end());
        });
    }
    std::vector<double> previewMs, priorityMs;
    std::thread clientCalls;
    if (clientCallsPerSecond > 0) {
        clientCalls = std::thread([&] {
            const uint64_t jobId = submitted.status().job_id();
            const auto interval = std::chrono::duration<double>(1.0 / clientCallsPerSecond);
            for (int call = 0; !done; ++call) {
                const auto t0 = Clock::now();
                if (call % 2 == 0) {
                    v1::GetImageRequest request;
                    request.set_job_id(jobId);
                    request.set_preview(true);
                    request.set_format(previewFormat);
                    auto context = farm::makeContext(clientToken, std::chrono::seconds(30));
                    auto reader = client->GetImage(context.get(), request);
                    v1::ImageChunk chunk;
                    while (reader->Read(&chunk)) {
                    }
                    if (!reader->Finish().ok()) break;  // the job ended meanwhile
                    previewMs.push_back(
                        std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
                } else {
                    v1::SetJobPriorityRequest request;
                    request.set_job_id(jobId);
                    request.set_priority(call % 4 == 1 ? 1 : 0);
                    v1::JobControlResponse response;
                    if (!client
                             ->SetJobPriority(
                                 farm::makeContext(clientToken, std::chrono::seconds(30)).get(),
                                 request, &response)
                             .ok())
                        break;  // the job ended meanwhile
                    priorityMs.push_back(
                        std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
                }
                std::this_thread::sleep_until(t0 + interval);
            }
        });
    }
    for (auto& thread : threads) thread.join();
    if (clientCalls.joinable()) clientCalls.join();
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    auto percentile = [](std::vector<double> values, double p) {
        if (values.empty()) return 0.0;
        std::sort(values.begin(), values.end());
        return values[std::min(values.size() - 1, static_cast<size_t>(p * values.size()))];
    };
    std::cout << absl::StrFormat(
        "simulated workers %d, units %u, merged %u in %.2f s: %.0f units/s; lease latency p50 %.2f "
        "ms, p99 %.2f ms; "
        "result latency p50 %.2f ms, p99 %.2f ms\n",
        workers, units, merged.load(), seconds, merged / seconds, percentile(acquireMs, 0.5),
        percentile(acquireMs, 0.99), percentile(reportMs, 0.5), percentile(reportMs, 0.99));
    if (clientCallsPerSecond > 0)
        std::cout << absl::StrFormat(
            "client calls: %u previews p50 %.2f ms, p99 %.2f ms; %u priority changes p50 %.2f "
            "ms, p99 %.2f ms\n",
            previewMs.size(), percentile(previewMs, 0.5), percentile(previewMs, 0.99),
            priorityMs.size(), percentile(priorityMs, 0.5), percentile(priorityMs, 0.99));
    return merged == units ? 0 : 1;
}
