// alphorn_farm_probe: speaks the farm protocol directly, for the integration tests that need
// calls the CLI and the worker never make: wrong tokens on every RPC, hostile bundles, scenes
// naming files outside their bundle, broken uploads, a result delivered after its lease expired.
// Each subcommand exits 0 when the coordinator behaved as the contract says and prints what it
// checked.
#include "alphorn/v1/client_service.grpc.pb.h"
#include "alphorn/v1/worker_service.grpc.pb.h"
#include "common/farm/build_identity.h"
#include "common/farm/film_codec.h"
#include "common/farm/rpc.h"
#include "common/farm/sha256.h"
#include "common/scene/accel.h"

#include <iostream>
#include <thread>

using namespace alphorn;

namespace {

int failures = 0;

void expect(bool condition, const std::string& what) {
    std::cout << (condition ? "ok   " : "FAIL ") << what << std::endl;
    if (!condition) ++failures;
}

std::unique_ptr<grpc::ClientContext> contextWith(const std::string& token) {
    auto context = std::make_unique<grpc::ClientContext>();
    if (!token.empty()) farm::addBearer(*context, token);
    context->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(10));
    return context;
}

// Calls every RPC of both services with `token`; returns the status codes by RPC name.
std::map<std::string, grpc::StatusCode> callEverything(
    const std::shared_ptr<grpc::Channel>& channel, const std::string& token) {
    auto client = v1::ClientService::NewStub(channel);
    auto worker = v1::WorkerService::NewStub(channel);
    std::map<std::string, grpc::StatusCode> codes;
    {
        v1::HasBlobsResponse r;
        codes["HasBlobs"] = client->HasBlobs(contextWith(token).get(), {}, &r).error_code();
    }
    {
        v1::PutBlobsResponse r;
        auto context = contextWith(token);
        auto writer = client->PutBlobs(context.get(), &r);
        writer->WritesDone();
        codes["PutBlobs"] = writer->Finish().error_code();
    }
    {
        v1::SubmitJobResponse r;
        codes["SubmitJob"] = client->SubmitJob(contextWith(token).get(), {}, &r).error_code();
    }
    {
        v1::WatchJobRequest request;
        request.set_job_id(999999);
        auto context = contextWith(token);
        auto reader = client->WatchJob(context.get(), request);
        v1::JobStatus status;
        while (reader->Read(&status)) {
        }
        codes["WatchJob"] = reader->Finish().error_code();
    }
    {
        v1::GetImageRequest request;
        request.set_job_id(999999);
        auto context = contextWith(token);
        auto reader = client->GetImage(context.get(), request);
        v1::ImageChunk chunk;
        while (reader->Read(&chunk)) {
        }
        codes["GetImage"] = reader->Finish().error_code();
    }
    {
        v1::CancelJobRequest request;
        request.set_job_id(999999);
        v1::CancelJobResponse r;
        codes["CancelJob"] = client->CancelJob(contextWith(token).get(), request, &r).error_code();
    }
    {
        v1::ListJobsResponse r;
        codes["ListJobs"] = client->ListJobs(contextWith(token).get(), {}, &r).error_code();
    }
    {
        v1::ListWorkersResponse r;
        codes["ListWorkers"] = client->ListWorkers(contextWith(token).get(), {}, &r).error_code();
    }
    {
        v1::RegisterRequest request;
        farm::describeThisBuild(request);
        request.set_name("probe");
        v1::RegisterResponse r;
        codes["Register"] = worker->Register(contextWith(token).get(), request, &r).error_code();
    }
    {
        v1::AcquireWorkRequest request;
        request.set_worker_id(999999);
        v1::AcquireWorkResponse r;
        codes["AcquireWork"] =
            worker->AcquireWork(contextWith(token).get(), request, &r).error_code();
    }
    {
        v1::HeartbeatResponse r;
        codes["Heartbeat"] = worker->Heartbeat(contextWith(token).get(), {}, &r).error_code();
    }
    {
        v1::ReportResultResponse r;
        auto context = contextWith(token);
        auto writer = worker->ReportResult(context.get(), &r);
        writer->WritesDone();
        codes["ReportResult"] = writer->Finish().error_code();
    }
    {
        v1::GetBlobRequest request;
        request.set_sha256(farm::sha256Hex("nothing"));
        auto context = contextWith(token);
        auto reader = worker->GetBlob(context.get(), request);
        v1::GetBlobChunk chunk;
        while (reader->Read(&chunk)) {
        }
        codes["GetBlob"] = reader->Finish().error_code();
    }
    return codes;
}

const std::set<std::string> kClientRpcs = {"HasBlobs", "PutBlobs",  "SubmitJob", "WatchJob",
                                           "GetImage", "CancelJob", "ListJobs",  "ListWorkers"};

int authMatrix(const std::string& address, const std::string& clientToken,
               const std::string& workerToken) {
    auto channel = farm::makeChannel(address, "");
    const std::map<std::string, std::string> callers = {{"no token", ""},
                                                        {"wrong token", farm::generateToken()},
                                                        {"client token", clientToken},
                                                        {"worker token", workerToken}};
    for (const auto& [who, token] : callers) {
        for (const auto& [rpc, code] : callEverything(channel, token)) {
            const bool clientRpc = kClientRpcs.count(rpc) > 0;
            const bool entitled =
                (clientRpc && token == clientToken) || (!clientRpc && token == workerToken);
            if (entitled)
                expect(code != grpc::StatusCode::UNAUTHENTICATED &&
                           code != grpc::StatusCode::UNAVAILABLE,
                       rpc + " with the " + who + " is let through");
            else
                expect(code == grpc::StatusCode::UNAUTHENTICATED,
                       rpc + " with the " + who + " is refused");
        }
    }
    return failures ? 1 : 0;
}

grpc::Status putBlob(v1::ClientService::Stub& client, const std::string& token,
                     const std::string& claimedSha, const std::string& bytes) {
    v1::PutBlobsResponse response;
    auto context = contextWith(token);
    auto writer = client.PutBlobs(context.get(), &response);
    size_t offset = 0;
    do {
        v1::BlobChunk chunk;
        chunk.set_sha256(claimedSha);
        const size_t n = std::min<size_t>(64 * 1024, bytes.size() - offset);
        chunk.set_data(bytes.substr(offset, n));
        offset += n;
        chunk.set_last(offset == bytes.size());
        if (!writer->Write(chunk)) break;
    } while (offset < bytes.size());
    writer->WritesDone();
    return writer->Finish();
}

bool hasBlob(v1::ClientService::Stub& client, const std::string& token, const std::string& sha) {
    v1::HasBlobsRequest request;
    request.add_sha256(sha);
    v1::HasBlobsResponse response;
    client.HasBlobs(contextWith(token).get(), request, &response);
    return response.missing_size() == 0;
}

grpc::Status submitBundle(v1::ClientService::Stub& client, const std::string& token,
                          const std::vector<std::pair<std::string, std::string>>& files,
                          const std::string& scenePath) {
    v1::SubmitJobRequest request;
    for (const auto& [path, contents] : files) {
        putBlob(client, token, farm::sha256Hex(contents), contents);
        v1::BundleFile* file = request.mutable_bundle()->add_files();
        file->set_path(path);
        file->set_sha256(farm::sha256Hex(contents));
        file->set_size(contents.size());
    }
    request.mutable_bundle()->set_scene_path(scenePath);
    v1::SubmitJobResponse response;
    return client.SubmitJob(contextWith(token).get(), request, &response);
}

// Expects the coordinator to run with --max-blob-bytes below 100000.
int hostileInput(const std::string& address, const std::string& clientToken) {
    auto client = v1::ClientService::NewStub(farm::makeChannel(address, ""));
    const std::string scene =
        "<scene>\n  <integrator type=\"normals\"/>\n  <camera type=\"perspective\"/>\n</scene>\n";

    const std::string big(100000, 'x');
    grpc::Status status = putBlob(*client, clientToken, farm::sha256Hex(big), big);
    expect(status.error_code() == grpc::StatusCode::RESOURCE_EXHAUSTED,
           "an oversized blob is refused: " + status.error_message());
    expect(!hasBlob(*client, clientToken, farm::sha256Hex(big)),
           "the oversized blob is not stored");

    status = putBlob(*client, clientToken, farm::sha256Hex("the real content"), "forged content");
    expect(status.error_code() == grpc::StatusCode::INVALID_ARGUMENT &&
               status.error_message().find("hash mismatch") != std::string::npos,
           "a hash mismatch is refused: " + status.error_message());
    expect(!hasBlob(*client, clientToken, farm::sha256Hex("the real content")),
           "the mismatched blob is not stored");

    status = putBlob(*client, clientToken, farm::sha256Hex("fine"), "fine");
    expect(status.ok() && hasBlob(*client, clientToken, farm::sha256Hex("fine")),
           "a correct blob is stored");
    status = putBlob(*client, clientToken, farm::sha256Hex("fine"), "fine");
    expect(status.ok(), "uploading it again is accepted (deduplicated)");

    for (const std::string& path : {std::string("../escape.xml"), std::string("/etc/alphorn.xml"),
                                    std::string("a/../../escape.xml")}) {
        status = submitBundle(*client, clientToken, {{path, scene}}, path);
        expect(status.error_code() == grpc::StatusCode::INVALID_ARGUMENT,
               "bundle path \"" + path + "\" is refused: " + status.error_message());
    }

    const std::string broken =
        "<scene>\n  <integrator type=\"normals\"/>\n  <camera type=\"perspective\">\n"
        "    <float name=\"fov\" value=\"not a number\"/>\n  </camera>\n</scene>\n";
    status =
        submitBundle(*client, clientToken, {{"scenes/broken.xml", broken}}, "scenes/broken.xml");
    expect(status.error_code() == grpc::StatusCode::INVALID_ARGUMENT &&
               status.error_message().rfind("scenes/broken.xml:4", 0) == 0,
           "a malformed scene fails at submit with file:line: " + status.error_message());
    return failures ? 1 : 0;
}

// Submits bundles holding only a scene that names files outside the bundle: on the server
// `outsideFile` exists and `stateDirectory` is where the coordinator keeps everything. Each must
// be refused at submit naming the scene's file and line and the reference, with no server path
// in the message (and so no job).
int confinement(const std::string& address, const std::string& clientToken,
                const std::string& outsideFile, const std::string& stateDirectory) {
    auto client = v1::ClientService::NewStub(farm::makeChannel(address, ""));
    auto sceneNaming = [](const std::string& element) {
        return "<scene>\n  <integrator type=\"normals\"/>\n  <camera type=\"perspective\"/>\n" +
               element + "\n</scene>\n";
    };
    auto mesh = [](const std::string& filename) {
        return "  <mesh type=\"obj\"><string name=\"filename\" value=\"" + filename + "\"/></mesh>";
    };
    struct Case {
        std::string what, scene;
        std::vector<std::string> fragments;  // the message starts with the first
    };
    const std::string dotDots = "../../../../../../../../../../../../../../../..";
    const std::vector<Case> cases = {
        {"an absolute path to a server file",
         sceneNaming(mesh(outsideFile)),
         {"scene.xml:4:", "(mesh type=\"obj\"): \"" + outsideFile + "\" is an absolute path"}},
        {"/etc/shadow",
         sceneNaming(mesh("/etc/shadow")),
         {"scene.xml:4:", "\"/etc/shadow\" is an absolute path"}},
        {"a \"..\" escape to a server file",
         sceneNaming(mesh(dotDots + outsideFile)),
         {"scene.xml:4:",
          "\"" + dotDots + outsideFile + "\" leaves the scene bundle; paths must stay inside it"}},
        {"a \"..\" escape to a file beside the bundle",
         sceneNaming(mesh("../x.obj")),
         {"scene.xml:4:", "\"../x.obj\" leaves the scene bundle"}},
        {"a bitmap texture's absolute path",
         sceneNaming("  <mesh type=\"obj\"><string name=\"filename\" value=\"m.obj\"/>\n"
                     "    <bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"albedo\">"
                     "<string name=\"filename\" value=\"" +
                     outsideFile + "\"/></texture></bsdf></mesh>"),
         {"scene.xml:5:", "(texture type=\"bitmap\")", "is an absolute path"}},
        {"a missing file inside the bundle",
         sceneNaming(mesh("meshes/none.obj")),
         {"scene.xml:4:", "cannot open OBJ file \"meshes/none.obj\""}},
    };
    for (const Case& c : cases) {
        const grpc::Status status =
            submitBundle(*client, clientToken, {{"scene.xml", c.scene}}, "scene.xml");
        const std::string& message = status.error_message();
        bool ok = status.error_code() == grpc::StatusCode::INVALID_ARGUMENT &&
                  message.rfind(c.fragments.front(), 0) == 0;
        for (const std::string& fragment : c.fragments)
            ok = ok && message.find(fragment) != std::string::npos;
        expect(ok, c.what + " is refused at submit: " + message);
        expect(message.find(stateDirectory) == std::string::npos &&
                   message.find("no faces") == std::string::npos,
               c.what + ": the message shows no server path and nothing read from the file");
    }
    return failures ? 1 : 0;
}

// Acquires a unit as a fake worker, waits until its lease expired and the job was finished by
// real workers, then delivers a wrong film for it: the coordinator must drop it.
int lateResult(const std::string& address, const std::string& workerToken,
               const std::string& clientToken, uint64_t jobId) {
    auto channel = farm::makeChannel(address, "");
    auto worker = v1::WorkerService::NewStub(channel);
    auto client = v1::ClientService::NewStub(channel);
    v1::RegisterRequest registration;
    farm::describeThisBuild(registration);
    registration.set_name("late-probe");
    v1::RegisterResponse registered;
    expect(worker->Register(contextWith(workerToken).get(), registration, &registered).ok(),
           "registered");
    v1::AcquireWorkRequest acquire;
    acquire.set_worker_id(registered.worker_id());
    v1::AcquireWorkResponse lease;
    expect(worker->AcquireWork(contextWith(workerToken).get(), acquire, &lease).ok() &&
               lease.has_work(),
           "leased a unit");
    std::cout << "READY" << std::endl;  // the test starts the real workers now
    // Wait for the job to finish without us (our lease expires, the unit is reassigned).
    for (int i = 0; i < 600; ++i) {
        v1::ListJobsRequest request;
        request.set_job_id(jobId);
        v1::ListJobsResponse response;
        client->ListJobs(contextWith(clientToken).get(), request, &response);
        if (response.jobs_size() && response.jobs(0).state() == v1::JOB_STATE_DONE) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    v1::HeartbeatRequest heartbeat;
    heartbeat.set_worker_id(registered.worker_id());
    heartbeat.add_lease_ids(lease.lease_id());
    v1::HeartbeatResponse beat;
    worker->Heartbeat(contextWith(workerToken).get(), heartbeat, &beat);
    expect(beat.drop_lease_ids_size() == 1 && beat.drop_lease_ids(0) == lease.lease_id(),
           "a heartbeat for the expired lease tells the worker to drop the unit");

    // A film of the right shape full of wrong sums: merging it would change the image.
    const auto& unit = lease.unit();
    const int border = 2;
    v1::ResultChunk header;
    header.set_worker_id(registered.worker_id());
    header.set_lease_id(lease.lease_id());
    header.set_job_id(unit.job_id());
    header.set_unit_index(unit.unit_index());
    // The coordinator checks the block's shape; the probe tries the likely filter borders.
    v1::ReportResultResponse response;
    grpc::Status status;
    for (int b = 0; b <= 4; ++b) {
        FilmBlock block(unit.x0() - b, unit.y0() - b, unit.x1() - unit.x0() + 2 * b,
                        unit.y1() - unit.y0() + 2 * b);
        for (int y = block.y0(); y < block.y0() + block.height(); ++y)
            for (int x = block.x0(); x < block.x0() + block.width(); ++x) {
                block.at(x, y).rgb[0] = FixedPoint(12345) << 40;
                block.at(x, y).weight = FixedPoint(1) << 40;
            }
        const std::string compressed = farm::compressFilm(block);
        header.set_block_x0(block.x0());
        header.set_block_y0(block.y0());
        header.set_block_width(block.width());
        header.set_block_height(block.height());
        header.set_compressed_size(compressed.size());
        header.set_compressed_sha256(farm::sha256Hex(compressed));
        header.set_data(compressed);
        auto context = contextWith(workerToken);
        auto writer = worker->ReportResult(context.get(), &response);
        writer->Write(header);
        writer->WritesDone();
        status = writer->Finish();
        if (status.ok()) break;
    }
    (void)border;
    expect(status.ok() && response.disposition() == v1::RESULT_DISCARDED,
           "the late result is discarded: " + status.error_message());
    return failures ? 1 : 0;
}

}  // namespace

int main(int argc, char** argv) {
    const std::vector<std::string> args(argv + 1, argv + argc);
    if (args.size() == 4 && args[0] == "auth-matrix")
        return authMatrix(args[1], farm::readTokenFile(args[2]), farm::readTokenFile(args[3]));
    if (args.size() == 3 && args[0] == "hostile-input")
        return hostileInput(args[1], farm::readTokenFile(args[2]));
    if (args.size() == 5 && args[0] == "confinement")
        return confinement(args[1], farm::readTokenFile(args[2]), args[3], args[4]);
    if (args.size() == 5 && args[0] == "late-result")
        return lateResult(args[1], farm::readTokenFile(args[2]), farm::readTokenFile(args[3]),
                          std::stoull(args[4]));
    std::cerr
        << "usage: alphorn_farm_probe auth-matrix ADDR CLIENT_TOKEN_FILE WORKER_TOKEN_FILE\n"
           "       alphorn_farm_probe hostile-input ADDR CLIENT_TOKEN_FILE\n"
           "       alphorn_farm_probe confinement ADDR CLIENT_TOKEN_FILE OUTSIDE_FILE STATE_DIR\n"
           "       alphorn_farm_probe late-result ADDR WORKER_TOKEN_FILE CLIENT_TOKEN_FILE JOB\n";
    return 2;
}
