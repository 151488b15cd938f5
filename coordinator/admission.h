// Admission: what a submitted job must satisfy and the defaults it gets. The bundle's blobs must
// be uploaded with the sizes the manifest says; the scene must load (so a broken scene fails at
// submit with the loader's "file:line: problem"); the image, passes, tile and unit counts must be
// within the limits. Unset settings get their defaults (passes from the scene's sampler, the
// tile size, passes per unit, the name). Memory and storage are the coordinator's business.
#pragma once

#include "alphorn/v1/client_service.pb.h"
#include "alphorn/v1/worker_service.pb.h"
#include "common/farm/job_grid.h"
#include "coordinator/blob_store.h"

#include <string>

namespace alphorn::coordinator {

struct AdmissionLimits {
    uint64_t maxBundleBytes = uint64_t(2) << 30;
    uint64_t maxImagePixels = uint64_t(8192) * 8192;
    uint32_t maxPasses = 1u << 20;
    int defaultTileSize = 64;
    uint32_t defaultPassesPerUnit = 1;
    // The most memory the scene's meshes may take while the scene is loaded to be checked
    // (SceneLimits); 0: the machine's physical memory.
    uint64_t maxGeometryBytes = 0;
};

struct AdmittedJob {
    // Bundle, settings with defaults, radius schedule; no id, and none of the request's fields
    // this coordinator does not know.
    v1::JobDescription description;
    farm::JobGrid grid;
    int filterBorder = 0;
    // Whether the job's films keep the smaller radius's image (a progressive photon mapper's):
    // its grid's blocks do.
    SmallerRadius smallerRadius = SmallerRadius::None;
    // The materialized bundle (a directory holding bundle/), to become the job's directory.
    std::string stagingDirectory;
};

// Throws FarmError (InvalidArgument) unless `submissionId` (SubmitJobRequest.submission_id) is
// empty or at most 64 characters of [0-9A-Za-z_-]: it is stored, logged and compared, and a
// client sends a random hex string.
void checkSubmissionId(const std::string& submissionId);
// The same for RetryJobRequest.request_id and DeleteJobRequest.request_id.
void checkRequestId(const std::string& requestId);

// Checks and completes a submission; materializes its bundle under `stagingParent`. Throws
// FarmError (InvalidArgument, FailedPrecondition or ResourceExhausted) and then leaves nothing
// behind.
AdmittedJob admitJob(const v1::SubmitJobRequest& request, const BlobStore& blobs,
                     const AdmissionLimits& limits, const std::string& stagingParent);

}  // namespace alphorn::coordinator
