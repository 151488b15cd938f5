// <bsdf type="dielectric">: a smooth interface between two dielectrics (Nori's), e.g. glass in
// air. The normal points to the exterior (`extIOR`); reflection and refraction are both deltas,
// chosen in proportion to the Fresnel reflectance so that sample() weights are 1 or 1/eta^2.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/core/frame.h"

namespace alphorn {

class Dielectric : public BSDF {
  public:
    explicit Dielectric(const PropertyList& props) {
        // Nori's defaults: BK7 glass inside, air outside.
        m_intIOR = props.getPositiveFloat("intIOR", 1.5046f);
        m_extIOR = props.getPositiveFloat("extIOR", 1.000277f);
    }

    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const BSDFQueryRecord&) const override { return 0.0f; }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        const float cosThetaI = Frame::cosTheta(rec.wi);
        const float reflectance = fresnelDielectric(cosThetaI, m_extIOR, m_intIOR);
        rec.measure = Measure::Discrete;
        if (sample.x() < reflectance) {
            // Reflection is chosen with probability F, so the F in the weight cancels.
            rec.wo = reflect(rec.wi);
            rec.eta = 1.0f;
            return Color3f(1.0f);
        }
        return refract(rec);
    }

    int deltaLobes(const BSDFQueryRecord& rec, DeltaLobe* lobes) const override {
        const float reflectance = fresnelDielectric(Frame::cosTheta(rec.wi), m_extIOR, m_intIOR);
        int count = 0;
        if (reflectance > 0.0f) lobes[count++] = {reflect(rec.wi), 1.0f, Color3f(reflectance)};
        if (reflectance < 1.0f) {
            BSDFQueryRecord refracted = rec;
            const Color3f weight = refract(refracted);
            if (!weight.isBlack())
                lobes[count++] = {refracted.wo, refracted.eta, weight * (1.0f - reflectance)};
        }
        return count;
    }

    // Equal indices refract nothing and reflect nothing (Fresnel is 0): an index-matched medium
    // boundary written as a dielectric. Volumetric integrators then cross it like <bsdf
    // type="null">.
    bool isNull() const override { return m_intIOR == m_extIOR; }

    std::string toString() const override {
        return "dielectric, intIOR " + std::to_string(m_intIOR) + ", extIOR " +
               std::to_string(m_extIOR);
    }

  private:
    static Vector3f reflect(const Vector3f& wi) { return Vector3f(-wi.x(), -wi.y(), wi.z()); }

    // Refraction of rec.wi: sets wo and eta and returns the weight, 1/eta^2, or 0 where the
    // direction would not exist.
    Color3f refract(BSDFQueryRecord& rec) const {
        const float cosThetaI = Frame::cosTheta(rec.wi);
        // eta is the index on the transmitted side over the incident side.
        const bool entering = cosThetaI > 0.0f;
        const float eta = entering ? m_intIOR / m_extIOR : m_extIOR / m_intIOR;
        const float invEta = 1.0f / eta;
        const float cosI = std::abs(cosThetaI);
        const float sinThetaTSqr = invEta * invEta * std::max(0.0f, 1.0f - cosI * cosI);
        // fresnelDielectric returned 1 under total internal reflection, so we cannot get here
        // with sinThetaTSqr >= 1 unless rounding differs; refuse rather than produce NaN.
        if (sinThetaTSqr >= 1.0f) return Color3f(0.0f);
        const float cosThetaT = std::sqrt(1.0f - sinThetaTSqr);
        rec.wo =
            Vector3f(-invEta * rec.wi.x(), -invEta * rec.wi.y(), entering ? -cosThetaT : cosThetaT);
        rec.eta = eta;
        // Radiance L/n^2 is invariant across the interface, so a camera path gains 1/eta^2.
        return Color3f(invEta * invEta);
    }

    float m_intIOR, m_extIOR;
};

ALPHORN_REGISTER(BSDF, "dielectric", Dielectric);

}  // namespace alphorn
