// <bsdf type="dielectric">: a smooth interface between two dielectrics (Nori's), e.g. glass in
// air. The normal points to the exterior (`extIOR`); reflection and refraction are both deltas,
// chosen in proportion to the Fresnel reflectance so that sample() weights are 1 or 1/eta^2.
//
// With pbrt-v4's `roughness` (or `uroughness`/`vroughness`, `remaproughness`) it is pbrt-v4's
// rough dielectric instead: GGX microfacet reflection and transmission (Walter et al. 2007) with
// visible-normal sampling, transmission scaled by 1/eta^2 for radiance as the smooth one is.
// pbrt-v4's `eta` is accepted for intIOR (with extIOR 1) when neither intIOR nor extIOR is given.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/bsdf/lobes.h"
#include "common/bsdf/roughness.h"
#include "common/core/frame.h"

namespace alphorn {

class Dielectric : public BSDF {
  public:
    explicit Dielectric(const PropertyList& props) : m_roughness(props, "") {
        if (props.has("eta")) {
            if (props.has("intIOR") || props.has("extIOR"))
                props.fail("give either \"eta\" or \"intIOR\"/\"extIOR\", not both");
            m_intIOR = props.getPositiveFloat("eta", 1.5f);
            m_extIOR = 1.0f;
        } else {
            // Nori's defaults: BK7 glass inside, air outside.
            m_intIOR = props.getPositiveFloat("intIOR", 1.5046f);
            m_extIOR = props.getPositiveFloat("extIOR", 1.000277f);
        }
        if (!std::isfinite(m_intIOR) || !std::isfinite(m_extIOR))
            props.fail("the indices of refraction must be finite");
        m_rough = props.has("roughness") || props.has("uroughness") || props.has("vroughness");
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_roughness.addChild(child, name, *this)) {
            m_rough = true;
            return;
        }
        if (child->kind() == ObjectKind::Texture)
            fail(
                "dielectric has no texture parameter \"%s\" (textures: roughness, uroughness, "
                "vroughness)",
                name);
        BSDF::addChild(child, name);
    }

    void activate() override {
        m_roughness.validate(*this);
        // A roughness that is 0 everywhere is the smooth interface, rendered by the smooth code.
        m_rough = m_rough && m_roughness.mayBeRough();
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (!m_rough || rec.measure != Measure::SolidAngle) return Color3f(0.0f);
        return lobe(rec).f(rec.wi, rec.wo, lobes::Transport::Radiance);
    }
    float pdf(const BSDFQueryRecord& rec) const override {
        if (!m_rough || rec.measure != Measure::SolidAngle) return 0.0f;
        return lobe(rec).pdf(rec.wi, rec.wo);
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        if (m_rough) return sampleRough(rec, sample);
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
        if (m_rough) return 0;
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
    bool isDiffuse() const override { return m_rough && !isNull(); }
    bool needsTangentFrame() const override { return m_rough && m_roughness.mayBeAnisotropic(); }

    std::string toString() const override {
        return "dielectric, intIOR " + std::to_string(m_intIOR) + ", extIOR " +
               std::to_string(m_extIOR) + (m_rough ? ", " + m_roughness.toString() : "");
    }

  private:
    lobes::Dielectric lobe(const BSDFQueryRecord& rec) const {
        lobes::Dielectric d;
        d.eta = m_intIOR / m_extIOR;
        d.distribution = m_roughness.at(rec.uv, rec.p);
        return d;
    }

    // The rough interface (or, where a roughness texture is 0, the smooth one through the same
    // model): one number chooses reflection or transmission by the microfacet's Fresnel term.
    Color3f sampleRough(BSDFQueryRecord& rec, const Point2f& sample) const {
        const lobes::Dielectric d = lobe(rec);
        // The 2D sample places the microfacet normal, and the choice, which depends on that
        // normal, needs a third number: a hash of the sample's bits, uniform and (being
        // discontinuous everywhere) independent of the normal for all practical purposes, and
        // deterministic, so the same sample gives the same path on every thread.
        const float uc = lobes::hashToUnit(sample);
        const auto s = d.sample(rec.wi, uc, sample, lobes::Transport::Radiance);
        if (!s || !(s->pdf > 0.0f)) return Color3f(0.0f);
        return lobes::recordSample(rec, *s, s->reflection ? 1.0f : s->eta);
    }

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
    RoughnessParameters m_roughness;
    bool m_rough = false;
};

ALPHORN_REGISTER(BSDF, "dielectric", Dielectric);

}  // namespace alphorn
