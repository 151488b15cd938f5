// <emitter type="point">: an isotropic point light at `position` with total flux `power`, so its
// intensity is power / (4 pi). A delta light: it is reached only by explicit sampling.
#include "common/core/warp.h"
#include "common/emitter/emitter.h"

namespace alphorn {

class PointLight : public Emitter {
  public:
    explicit PointLight(const PropertyList& props) {
        m_position = props.getPoint("position", Point3f::Zero());
        m_power = props.getNonNegativeColor("power", Color3f(0.0f));
        if (!props.has("power"))
            props.fail("a point emitter needs a \"power\" colour (total flux)");
    }

    Color3f sample(EmitterQueryRecord& rec, const Point2f&) const override {
        rec = EmitterQueryRecord(rec.ref, m_position, Normal3f::Zero());
        const float dist2 = (m_position - rec.ref).squaredNorm();
        // A receiver at the light itself would see infinite irradiance: treat it as no sample.
        if (!(dist2 > 0.0f) || rec.wi.isZero()) {
            rec.pdf = 0.0f;
            return Color3f(0.0f);
        }
        rec.pdf = 1.0f;  // a delta in solid angle: the sample is certain
        const Color3f result = m_power * Inv4Pi / dist2;
        return result.isValid() ? result : Color3f(0.0f);
    }

    // A ray never hits a point, and no other strategy can produce its direction.
    Color3f eval(const EmitterQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const EmitterQueryRecord&) const override { return 0.0f; }

    Color3f power() const override { return m_power; }

    Color3f samplePhoton(Ray3f& ray, const Point2f&,
                         const Point2f& directionSample) const override {
        // Uniform direction (density 1/4pi) from intensity power/4pi: every photon carries power.
        ray = Ray3f(m_position, warp::squareToUniformSphere(directionSample));
        return m_power;
    }

    bool isDelta() const override { return true; }

    std::string toString() const override { return "point light, power " + m_power.toString(); }

  private:
    Point3f m_position;
    Color3f m_power;
};

ALPHORN_REGISTER(Emitter, "point", PointLight);

}  // namespace alphorn
