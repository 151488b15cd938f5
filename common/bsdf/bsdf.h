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

class BSDF : public Object {
  public:
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
};

}  // namespace alphorn
