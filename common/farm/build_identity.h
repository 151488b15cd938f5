// What a worker tells the coordinator of the build it runs, and what decides whether its units
// may be merged into a job: the version, the platform (CPU kind of the ray-tracing kernels) and
// the engine fingerprint (engine_fingerprint.h).
#pragma once

#include "alphorn/v1/worker_service.pb.h"

namespace alphorn::farm {

// Sets the registration's version, platform and engine fingerprint to this build's.
void describeThisBuild(v1::RegisterRequest& registration);
// Throws Error unless `fingerprint` has the form of an engine fingerprint (16 lowercase hex
// digits), or is empty and `mayBeEmpty`.
void checkEngineFingerprint(const std::string& fingerprint, bool mayBeEmpty);

}  // namespace alphorn::farm
