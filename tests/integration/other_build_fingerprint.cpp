// Linked into alphorn_worker_other_build in place of the build's generated fingerprint: the same
// worker, announcing the engine fingerprint of another build, as a worker built from another
// revision would. The farm's tests of fingerprints run it beside the real workers.
#include "common/farm/engine_fingerprint.h"

namespace alphorn::farm {

std::string engineFingerprint() {
    return "00000000000b0110";
}

}  // namespace alphorn::farm
