// The BSDF query at a surface hit, shared by camera paths (common/integrator/) and photon paths
// (common/photon/).
#pragma once

#include "common/bsdf/bsdf.h"
#include "common/scene/mesh.h"

namespace alphorn {

// A BSDF query at a hit, with the texture coordinates filled in.
inline BSDFQueryRecord makeBSDFQuery(const Intersection& its, const Vector3f& wiLocal) {
    BSDFQueryRecord rec(wiLocal);
    rec.uv = its.uv;
    rec.p = its.p;
    return rec;
}

}  // namespace alphorn
