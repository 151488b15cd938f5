// A closest-hit query for raw rtcIntersect1, the baseline several benchmarks measure against.
#pragma once

#include "common/core/common.h"

#include <embree3/rtcore.h>

namespace alphorn::bench {

// The ray o + t d for t in [Epsilon, Infinity), with no hit yet.
inline RTCRayHit makeRayHit(const Point3f& o, const Vector3f& d) {
    RTCRayHit rh;
    rh.ray.org_x = o.x(), rh.ray.org_y = o.y(), rh.ray.org_z = o.z();
    rh.ray.dir_x = d.x(), rh.ray.dir_y = d.y(), rh.ray.dir_z = d.z();
    rh.ray.tnear = Epsilon;
    rh.ray.tfar = Infinity;
    rh.ray.time = 0.0f;
    rh.ray.mask = 0xffffffffu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    return rh;
}

}  // namespace alphorn::bench
