// The gRPC face of the coordinator: ClientService and WorkerService (proto/alphorn/v1). Each
// RPC first checks its role's bearer token, then calls Coordinator.
#pragma once

#include "alphorn/v1/client_service.grpc.pb.h"
#include "alphorn/v1/worker_service.grpc.pb.h"
#include "coordinator/coordinator.h"

namespace alphorn::coordinator {

// `message` as a client or worker may see it: every path under `stateDirectory` (as given, as
// an absolute path or resolved) made relative to it ("state.sqlite", "jobs/7/checkpoint"), and
// the directory itself, absolute, named "the state directory". Every status the services return
// passes through it; the coordinator's own log keeps the full paths.
std::string relativeToStateDirectory(const std::string& message, const std::string& stateDirectory);

class ClientServiceImpl final : public v1::ClientService::Service {
  public:
    ClientServiceImpl(Coordinator& coordinator, std::string token)
        : m_coordinator(coordinator), m_token(std::move(token)) {}

    grpc::Status HasBlobs(grpc::ServerContext*, const v1::HasBlobsRequest*,
                          v1::HasBlobsResponse*) override;
    grpc::Status PutBlobs(grpc::ServerContext*, grpc::ServerReader<v1::BlobChunk>*,
                          v1::PutBlobsResponse*) override;
    grpc::Status SubmitJob(grpc::ServerContext*, const v1::SubmitJobRequest*,
                           v1::SubmitJobResponse*) override;
    grpc::Status WatchJob(grpc::ServerContext*, const v1::WatchJobRequest*,
                          grpc::ServerWriter<v1::JobStatus>*) override;
    grpc::Status GetImage(grpc::ServerContext*, const v1::GetImageRequest*,
                          grpc::ServerWriter<v1::ImageChunk>*) override;
    grpc::Status CancelJob(grpc::ServerContext*, const v1::CancelJobRequest*,
                           v1::CancelJobResponse*) override;
    grpc::Status ListJobs(grpc::ServerContext*, const v1::ListJobsRequest*,
                          v1::ListJobsResponse*) override;
    grpc::Status ListWorkers(grpc::ServerContext*, const v1::ListWorkersRequest*,
                             v1::ListWorkersResponse*) override;
    grpc::Status RetryJob(grpc::ServerContext*, const v1::RetryJobRequest*,
                          v1::JobControlResponse*) override;
    grpc::Status SetJobPaused(grpc::ServerContext*, const v1::SetJobPausedRequest*,
                              v1::JobControlResponse*) override;
    grpc::Status SetJobPriority(grpc::ServerContext*, const v1::SetJobPriorityRequest*,
                                v1::JobControlResponse*) override;
    grpc::Status DeleteJob(grpc::ServerContext*, const v1::DeleteJobRequest*,
                           v1::DeleteJobResponse*) override;
    grpc::Status GetJobLog(grpc::ServerContext*, const v1::GetJobLogRequest*,
                           v1::GetJobLogResponse*) override;
    grpc::Status SetWorkerDraining(grpc::ServerContext*, const v1::SetWorkerDrainingRequest*,
                                   v1::SetWorkerDrainingResponse*) override;

  private:
    Coordinator& m_coordinator;
    std::string m_token;
};

class WorkerServiceImpl final : public v1::WorkerService::Service {
  public:
    WorkerServiceImpl(Coordinator& coordinator, std::string token)
        : m_coordinator(coordinator), m_token(std::move(token)) {}

    grpc::Status Register(grpc::ServerContext*, const v1::RegisterRequest*,
                          v1::RegisterResponse*) override;
    grpc::Status AcquireWork(grpc::ServerContext*, const v1::AcquireWorkRequest*,
                             v1::AcquireWorkResponse*) override;
    grpc::Status Heartbeat(grpc::ServerContext*, const v1::HeartbeatRequest*,
                           v1::HeartbeatResponse*) override;
    grpc::Status ReportResult(grpc::ServerContext*, grpc::ServerReader<v1::ResultChunk>*,
                              v1::ReportResultResponse*) override;
    grpc::Status GetBlob(grpc::ServerContext*, const v1::GetBlobRequest*,
                         grpc::ServerWriter<v1::GetBlobChunk>*) override;

  private:
    Coordinator& m_coordinator;
    std::string m_token;
};

}  // namespace alphorn::coordinator
