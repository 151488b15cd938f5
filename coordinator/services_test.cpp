// The gRPC face of the coordinator, called through an in-process channel (no socket): what the
// services check in a request before it reaches Coordinator.
#include "coordinator/services.h"

#include "common/farm/rpc.h"
#include "coordinator/coordinator_job_test.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

namespace alphorn::coordinator {
namespace {

class ClientService : public CoordinatorJobTest {};

TEST_F(ClientService, GetImageRefusesAnUnknownFormatAndAnExposureOutOfRange) {
    Coordinator coordinator(m_options);
    const uint64_t job = coordinator.submit(upload(coordinator)).job_id();
    const std::string token = farm::generateToken();
    ClientServiceImpl service(coordinator, token);
    grpc::ServerBuilder builder;
    builder.RegisterService(&service);
    const std::unique_ptr<grpc::Server> server = builder.BuildAndStart();
    ASSERT_TRUE(server);
    const auto stub = v1::ClientService::NewStub(server->InProcessChannel({}));
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
    server->Shutdown();
    coordinator.stop();
}

}  // namespace
}  // namespace alphorn::coordinator
