// <bsdf type="diffuse">: a Lambertian reflector with `albedo` (Nori's default 0.5).
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/core/warp.h"

namespace alphorn {

class Diffuse : public BSDF {
public:
    explicit Diffuse(const PropertyList& props) {
        m_albedo = props.getNonNegativeColor("albedo", Color3f(0.5f));
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle || Frame::cosTheta(rec.wi) <= 0.0f ||
            Frame::cosTheta(rec.wo) <= 0.0f)
            return Color3f(0.0f);
        return m_albedo * InvPi;
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle || Frame::cosTheta(rec.wi) <= 0.0f ||
            Frame::cosTheta(rec.wo) <= 0.0f)
            return 0.0f;
        return InvPi * Frame::cosTheta(rec.wo);
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        if (Frame::cosTheta(rec.wi) <= 0.0f) return Color3f(0.0f);
        rec.measure = Measure::SolidAngle;
        rec.wo = warp::squareToCosineHemisphere(sample);
        rec.eta = 1.0f;
        // eval * cos / pdf = albedo for cosine-weighted sampling.
        return m_albedo;
    }

    bool isDiffuse() const override { return true; }
    std::string toString() const override { return "diffuse, albedo " + m_albedo.toString(); }

private:
    Color3f m_albedo;
};

ALPHORN_REGISTER(BSDF, "diffuse", Diffuse);

}  // namespace alphorn
