// Per-thread counts of the rays Accel traces, by kind (raysTracedByThisThread(), in accel.h,
// counts both kinds).
#pragma once

#include <cstdint>

namespace alphorn {

// Shadow rays (Accel::occluded: Embree's any-hit query, which may stop at the first hit it finds
// and so costs less than a closest hit) traced by the calling thread since it started. The
// throughput benchmark matches its raw Embree baseline's mix of the two kinds to the renderer's.
uint64_t shadowRaysTracedByThisThread();

}  // namespace alphorn
