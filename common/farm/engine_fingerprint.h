// The engine fingerprint: 16 hex digits of a digest, made at build time, of everything that
// decides the bytes of a rendered unit (the renderer's sources, the result encoding, the
// compiler and its flags, the versions of Embree and the other libraries the renderer calls).
// Two builds with the same fingerprint render every unit to the same bytes; the farm leases a
// job's units only to workers whose fingerprint is the job's (docs/architecture.md).
#pragma once

#include <string>

namespace alphorn::farm {

std::string engineFingerprint();

}  // namespace alphorn::farm
