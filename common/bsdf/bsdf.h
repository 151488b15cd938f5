// The BSDF interface (Nori's). Directions are in the local shading frame (normal = +z), both
// pointing away from the surface; which is which is said at BSDFQueryRecord.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"

namespace alphorn {

enum class Measure { Unknown, SolidAngle, Discrete };

// Nori's convention: wi is the direction the light path arrives from on the camera side
// (towards the camera / previous vertex), wo is the sampled or queried outgoing direction
// (towards the light). Both in the local shading frame, pointing away from the surface.
struct BSDFQueryRecord {
    Vector3f wi;
    Vector3f wo = Vector3f::Zero();
    float eta = 1.0f;  // relative index of refraction in the sampled direction
    Measure measure = Measure::Unknown;
    Point2f uv = Point2f::Zero();  // surface uv, for textured parameters
    Point3f p = Point3f::Zero();   // world position, for 3D textures

    explicit BSDFQueryRecord(const Vector3f& wi) : wi(wi) {}
    BSDFQueryRecord(const Vector3f& wi, const Vector3f& wo, Measure measure)
        : wi(wi), wo(wo), measure(measure) {}
};

// One of the delta directions a BSDF's sample() chooses among: the direction, the relative index
// of refraction along it, and its weight, the chance sample() chooses it times the weight
// sample() then returns. The weights of all lobes sum to sample()'s expected weight.
struct DeltaLobe {
    Vector3f wo = Vector3f::Zero();
    float eta = 1.0f;
    Color3f weight = Color3f(0.0f);
};

class BSDF : public Object {
  public:
    static constexpr int kMaxDeltaLobes = 2;
    ObjectKind kind() const override { return ObjectKind::BSDF; }

    // Samples wo given wi; returns eval() * cos(theta_o) / pdf(), or 0 on failure.
    virtual Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const = 0;
    // The BSDF value times nothing (no cosine); zero for delta components.
    virtual Color3f eval(const BSDFQueryRecord& rec) const = 0;
    // Solid-angle density of sample() producing rec.wo; zero for delta components.
    virtual float pdf(const BSDFQueryRecord& rec) const = 0;
    // True when the BSDF has a non-delta part, so that lights can be sampled and photons stored
    // at its surface (Nori's isDiffuse, which is also true for microfacet).
    virtual bool isDiffuse() const { return false; }
    // True when light passes straight through without change (index-matched media boundary).
    virtual bool isNull() const { return false; }
    // True when the BSDF is not symmetric about the normal (a normal map's tangent-space data),
    // so that its hits need a shading frame whose tangent follows the texture's u direction. Every
    // other BSDF is isotropic: any frame about the normal gives the same distribution, and hits
    // get the cheaper one built from the normal alone.
    virtual bool needsTangentFrame() const { return false; }
    // For a BSDF whose sample() chooses at random among several delta directions (glass:
    // reflection or refraction, by the Fresnel reflectance): writes each direction it can take
    // for this rec.wi, with its weight, and returns how many (at most kMaxDeltaLobes). An
    // integrator may follow all of them instead of one sample (splitting), which removes the
    // choice's variance. Returns 0 for every other BSDF: use sample().
    virtual int deltaLobes(const BSDFQueryRecord& rec, DeltaLobe* lobes) const {
        (void)rec;
        (void)lobes;
        return 0;
    }
};

}  // namespace alphorn
