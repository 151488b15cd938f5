// <bsdf type="thindielectric">: pbrt-v4's thin sheet of glass (a window pane, a soap bubble) of
// index `eta`. Light reflects specularly or passes straight through, unbent: the sheet's two
// parallel faces undo each other's refraction. Inside the sheet light bounces back and forth;
// summing the geometric series of those bounces (single-interface reflectance R, T = 1 - R)
// gives the total reflectance R' = R + T^2 R / (1 - R^2) and transmittance 1 - R'.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/core/frame.h"

namespace alphorn {

class ThinDielectric : public BSDF {
  public:
    explicit ThinDielectric(const PropertyList& props) {
        m_eta = props.getPositiveFloat("eta", 1.5f);
        if (!std::isfinite(m_eta)) props.fail("\"eta\" must be finite, got %g", m_eta);
    }

    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const BSDFQueryRecord&) const override { return 0.0f; }

    // Total reflectance of the sheet for incidence cosine cosTheta (either side).
    float reflectance(float cosTheta) const {
        const float R = fresnelDielectric(std::abs(cosTheta), 1.0f, m_eta);
        if (R >= 1.0f) return 1.0f;
        const float T = 1.0f - R;
        return R + T * T * R / (1.0f - R * R);
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        if (rec.wi.z() == 0.0f) return Color3f(0.0f);
        const float R = reflectance(rec.wi.z());
        rec.measure = Measure::Discrete;
        rec.eta = 1.0f;
        // Each branch is chosen with its own probability, so its weight is 1.
        rec.wo =
            sample.x() < R ? Vector3f(-rec.wi.x(), -rec.wi.y(), rec.wi.z()) : Vector3f(-rec.wi);
        return Color3f(1.0f);
    }

    int deltaLobes(const BSDFQueryRecord& rec, DeltaLobe* lobes) const override {
        if (rec.wi.z() == 0.0f) return 0;
        const float R = reflectance(rec.wi.z());
        int count = 0;
        if (R > 0.0f)
            lobes[count++] = {Vector3f(-rec.wi.x(), -rec.wi.y(), rec.wi.z()), 1.0f, Color3f(R)};
        if (R < 1.0f) lobes[count++] = {Vector3f(-rec.wi), 1.0f, Color3f(1.0f - R)};
        return count;
    }

    // An index of 1 is no sheet at all.
    bool isNull() const override { return m_eta == 1.0f; }

    std::string toString() const override { return "thindielectric, eta " + std::to_string(m_eta); }

  private:
    float m_eta;
};

ALPHORN_REGISTER(BSDF, "thindielectric", ThinDielectric);

}  // namespace alphorn
