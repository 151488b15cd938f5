// The gRPC face of the coordinator, called through an in-process channel (no socket): what the
// services check in a request before it reaches Coordinator.
#include "coordinator/services.h"

#include "common/farm/rpc.h"
#include "coordinator/coordinator_job_test.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <filesystem>
#include <limits>

namespace alphorn::coordinator {
namespace {

class ClientService : public CoordinatorJobTest {
  protected:
    // The coordinator's client service on an in-process channel, called as a client calls it.
    struct InProcess {
        ClientServiceImpl service;
        std::unique_ptr<grpc::Server> server;
        std::unique_ptr<v1::ClientService::Stub> stub;
        InProcess(Coordinator& coordinator, const std::string& token)
            : service(coordinator, token) {
            grpc::ServerBuilder builder;
            builder.RegisterService(&service);
            server = builder.BuildAndStart();
            if (server) stub = v1::ClientService::NewStub(server->InProcessChannel({}));
        }
    };
};

TEST_F(ClientService, GetImageRefusesAnUnknownFormatAndAnExposureOutOfRange) {
    Coordinator coordinator(m_options);
    const uint64_t job = coordinator.submit(upload(coordinator)).job_id();
    const std::string token = farm::generateToken();
    InProcess client(coordinator, token);
    ASSERT_TRUE(client.server);
    const auto& stub = client.stub;
    const auto getImage = [&](int format, float exposure) {
        v1::GetImageRequest request;
        request.set_job_id(job);
        request.set_format(static_cast<v1::ImageFormat>(format));
        request.set_preview(true);
        request.set_exposure(exposure);
        const auto context = farm::makeContext(token, std::chrono::seconds(60));
        const auto reader = stub->GetImage(context.get(), request);
        v1::ImageChunk chunk;
        while (reader->Read(&chunk)) {
        }
        return reader->Finish();
    };

    EXPECT_TRUE(getImage(v1::IMAGE_FORMAT_UNSPECIFIED, 0).ok());
    EXPECT_TRUE(getImage(v1::IMAGE_FORMAT_PNG, -kMaxPngExposureStops).ok());
    EXPECT_TRUE(getImage(v1::IMAGE_FORMAT_PNG, kMaxPngExposureStops).ok());

    const grpc::Status unknown = getImage(77, 0);
    EXPECT_EQ(unknown.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(unknown.error_message().find("format 77"), std::string::npos)
        << unknown.error_message();

    const float infinity = std::numeric_limits<float>::infinity();
    for (const float exposure : {std::nanf(""), infinity, -infinity, 1e30f, -1e30f, 20.5f}) {
        const grpc::Status refused = getImage(v1::IMAGE_FORMAT_PNG, exposure);
        EXPECT_EQ(refused.error_code(), grpc::StatusCode::INVALID_ARGUMENT)
            << "exposure " << exposure;
        EXPECT_NE(refused.error_message().find("exposure"), std::string::npos)
            << refused.error_message();
    }
    client.server->Shutdown();
    coordinator.stop();
}

TEST(StatePaths, NamesUnderTheStateDirectoryAreMadeRelativeToIt) {
    const std::string state = "/srv/alphorn/state";
    EXPECT_EQ(
        relativeToStateDirectory(
            "/srv/alphorn/state/state.sqlite: SQL error in \"COMMIT\": disk I/O error", state),
        "state.sqlite: SQL error in \"COMMIT\": disk I/O error");
    EXPECT_EQ(relativeToStateDirectory("cannot write (/srv/alphorn/state//jobs/7/checkpoint: EIO)",
                                       state + "/"),
              "cannot write (jobs/7/checkpoint: EIO)");
    EXPECT_EQ(relativeToStateDirectory("/srv/alphorn/state: cannot lock", state),
              "the state directory: cannot lock");
    // Other paths, and paths that only begin or end alike, are left alone.
    for (const std::string other :
         {"/srv/alphorn/state2/x", "/x/srv/alphorn/state/x", "/etc/passwd: no", ""})
        EXPECT_EQ(relativeToStateDirectory(other, state), other);
    // A relative state directory: its files lose it, and a word that spells it stays.
    EXPECT_EQ(relativeToStateDirectory("the coordinator cannot write its state (retry later): "
                                       "state/state.sqlite: disk I/O error",
                                       "state"),
              "the coordinator cannot write its state (retry later): state.sqlite: disk I/O error");
}

TEST(StatePaths, TheStateDirectoryIsRecognisedAbsoluteAndResolved) {
    const fs::path root =
        fs::temp_directory_path() / ("alphorn_state_paths_" + std::to_string(::getpid()));
    fs::remove_all(root);
    fs::create_directories(root / "real");
    fs::create_directory_symlink(root / "real", root / "link");
    const std::string viaLink = (root / "link").string();
    EXPECT_EQ(relativeToStateDirectory((root / "real/state.sqlite").string() + ": locked", viaLink),
              "state.sqlite: locked");
    EXPECT_EQ(relativeToStateDirectory(viaLink + "/tmp/abc: EROFS", viaLink), "tmp/abc: EROFS");
    const fs::path before = fs::current_path();
    fs::current_path(root);
    EXPECT_EQ(relativeToStateDirectory((root / "link/state.sqlite").string() + ": locked", "link"),
              "state.sqlite: locked");
    fs::current_path(before);
    fs::remove_all(root);
}

// A storage error reaches the client without the server's path to its database: another
// connection holds the database's write lock, so the coordinator's write fails once SQLite's
// busy timeout (5 s) passes.
TEST_F(ClientService, StorageErrorsNameTheDatabaseRelativeToTheStateDirectory) {
    Coordinator coordinator(m_options);
    const uint64_t job = coordinator.submit(upload(coordinator)).job_id();
    const std::string token = farm::generateToken();
    InProcess client(coordinator, token);
    ASSERT_TRUE(client.server);
    const auto& stub = client.stub;

    sqlite3* blocker = nullptr;
    ASSERT_EQ(sqlite3_open((fs::path(m_options.stateDirectory) / "state.sqlite").c_str(), &blocker),
              SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(blocker, "BEGIN EXCLUSIVE", nullptr, nullptr, nullptr), SQLITE_OK);
    v1::SetJobPriorityRequest request;
    request.set_job_id(job);
    request.set_priority(5);
    v1::JobControlResponse response;
    const auto context = farm::makeContext(token, std::chrono::seconds(60));
    const grpc::Status status = stub->SetJobPriority(context.get(), request, &response);
    sqlite3_exec(blocker, "ROLLBACK", nullptr, nullptr, nullptr);
    sqlite3_close(blocker);

    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
    EXPECT_NE(status.error_message().find("cannot write its state"), std::string::npos)
        << status.error_message();
    EXPECT_NE(status.error_message().find("state.sqlite"), std::string::npos)
        << status.error_message();
    EXPECT_EQ(status.error_message().find(m_dir.string()), std::string::npos)
        << status.error_message();
    client.server->Shutdown();
    coordinator.stop();
}

}  // namespace
}  // namespace alphorn::coordinator
