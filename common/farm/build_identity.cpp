#include "common/farm/build_identity.h"

#include "common/core/error.h"
#include "common/farm/engine_fingerprint.h"
#include "common/scene/accel.h"

namespace alphorn::farm {

void describeThisBuild(v1::RegisterRequest& registration) {
    registration.set_version(ALPHORN_VERSION);
    registration.set_platform(renderPlatform());
    registration.set_engine_fingerprint(engineFingerprint());
}

void checkEngineFingerprint(const std::string& fingerprint, bool mayBeEmpty) {
    if (fingerprint.empty() && mayBeEmpty) return;
    bool valid = fingerprint.size() == 16;
    for (char c : fingerprint) valid = valid && ((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'));
    if (!valid)
        fail(
            "\"%s\" is not an engine fingerprint (16 lowercase hex digits, as `alphorn --version` "
            "or `alphorn workers` shows them)",
            fingerprint.substr(0, 64));
}

}  // namespace alphorn::farm
