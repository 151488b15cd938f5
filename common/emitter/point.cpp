// <emitter type="point">: an isotropic point light at `position` with total flux `power`, so its
// intensity is power / (4 pi). A delta light: it is reached only by explicit sampling.
#include "common/core/warp.h"
#include "common/emitter/delta_light.h"

namespace alphorn {

class PointLight : public DeltaPositionLight {
  public:
    explicit PointLight(const PropertyList& props) {
        m_position = props.getPoint("position", Point3f::Zero());
        m_power = props.getNonNegativeColor("power", Color3f(0.0f));
        if (!props.has("power"))
            props.fail("a point emitter needs a \"power\" colour (total flux)");
    }

    Color3f intensity(const Vector3f&) const override { return m_power * Inv4Pi; }

    Color3f power() const override { return m_power; }

    Color3f samplePhoton(Ray3f& ray, const Point2f&,
                         const Point2f& directionSample) const override {
        // Uniform direction (density 1/4pi) from intensity power/4pi: every photon carries power.
        ray = Ray3f(m_position, warp::squareToUniformSphere(directionSample));
        return m_power;
    }

    std::string toString() const override { return "point light, power " + m_power.toString(); }

  private:
    Color3f m_power;
};

ALPHORN_REGISTER(Emitter, "point", PointLight);

}  // namespace alphorn
