// Phase functions: the angular distribution of light scattered inside a medium. They are the
// media's counterpart of BSDFs, with two differences that keep them cheap: they are scalar
// (colour lives in the medium's sigmaS) and they work in world space (a medium point has no
// surface frame).
//
// Convention, the same as BSDFQueryRecord's: `wi` points from the scattering point back towards
// the previous vertex (the camera side), `wo` is the sampled or queried direction onward (towards
// the light); both point away from the scattering point. Light that keeps going straight has
// wo == -wi, so "forward" scattering means dot(-wi, wo) > 0 — that is the angle a positive
// Henyey–Greenstein g favours. Photon tracing uses the same functions with the roles reversed,
// which is fine because every phase function here is reciprocal: p(wi, wo) == p(wo, wi).
#pragma once

#include "common/core/object.h"

namespace alphorn {

class PhaseFunction : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::PhaseFunction; }

    // Samples wo given wi (unit vectors); returns the sampling weight eval / pdf, which is 1 for
    // every phase function here (they are sampled exactly), or 0 when sampling failed.
    virtual float sample(const Vector3f& wi, Vector3f& wo, const Point2f& sample) const = 0;
    // The phase function value, a density over the sphere of wo that integrates to 1.
    virtual float eval(const Vector3f& wi, const Vector3f& wo) const = 0;
    // Solid-angle density of sample() producing wo.
    virtual float pdf(const Vector3f& wi, const Vector3f& wo) const = 0;
};

}  // namespace alphorn
