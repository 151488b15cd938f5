// <emitter type="directional">: parallel light from infinitely far away (the sun as a point in
// the sky; pbrt's "distant" light).
//   irradiance  colour: the irradiance on a surface facing the light (W/m^2), default 1
//   direction   vector: the direction the light travels, default (0, 0, -1) (straight down in a
//               +z-up scene); need not be unit length
//   toWorld     transform applied to `direction` (translation and scale do not matter)
// A delta light in direction: only next-event estimation reaches it, so a surface point with
// normal n receives irradiance * max(0, n . -direction), and a ray leaving the scene never sees it.
#include "common/emitter/infinite.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class DirectionalLight : public InfiniteEmitter {
  public:
    explicit DirectionalLight(const PropertyList& props) {
        m_irradiance = props.getNonNegativeColor("irradiance", Color3f(1.0f));
        const Vector3f direction = props.getVector("direction", Vector3f(0.0f, 0.0f, -1.0f));
        const Transform toWorld = props.getTransform("toWorld", Transform());
        const Vector3f world = toWorld.applyVector(direction);
        const float length = world.norm();
        if (!(length > 0.0f) || !std::isfinite(length) || !world.allFinite())
            props.fail(
                "\"direction\" (after toWorld) must be a finite non-zero vector, got (%g, %g, %g)",
                world.x(), world.y(), world.z());
        m_toLight = -world / length;
    }

    Color3f sample(EmitterQueryRecord& rec, const Point2f&) const override {
        aimAtDirection(rec, m_toLight);
        rec.pdf = 1.0f;  // a delta in solid angle: the sample is certain
        return m_irradiance;
    }
    Color3f eval(const EmitterQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const EmitterQueryRecord&) const override { return 0.0f; }
    bool isDelta() const override { return true; }

    // All the light that crosses the disk the scene's bounding sphere casts.
    Color3f power() const override { return diskArea() * m_irradiance; }

    Color3f samplePhoton(Ray3f& ray, const Point2f& positionSample, const Point2f&) const override {
        // Uniform over the disk (density 1 / area) in the one direction: flux E * area.
        ray = diskRay(m_toLight, positionSample);
        return power();
    }

    std::string toString() const override {
        return absl::StrFormat("directional light, irradiance %s, travelling along (%g, %g, %g)",
                               m_irradiance.toString(), -m_toLight.x(), -m_toLight.y(),
                               -m_toLight.z());
    }

  private:
    Color3f m_irradiance;
    Vector3f m_toLight;  // unit, world: towards the light, against the direction of travel
};

ALPHORN_REGISTER(Emitter, "directional", DirectionalLight);

}  // namespace alphorn
