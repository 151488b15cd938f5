// <bsdf type="microfacet">: Nori's rough dielectric-coated diffuse BRDF. A Lambertian base `kd`
// plus a Cook-Torrance lobe with the Beckmann distribution (roughness `alpha`), the rational
// approximation of Smith's G1 (Walter et al. 2007, as in Nori and PBRT) and the dielectric
// Fresnel term of `intIOR`/`extIOR`. The specular weight is ks = 1 - max(kd) so that the sum
// never reflects more than it receives. `kd` and `alpha` may be nested textures.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

class Microfacet : public BSDF {
  public:
    explicit Microfacet(const PropertyList& props)
        : m_alpha(props, "alpha", 0.1f), m_kd(props, "kd", Color3f(0.5f)) {
        // Validate the plain values here so errors name the XML line; textures in activate().
        // Any positive roughness renders down to where float ends (tiny ones as a mirror-like
        // lobe); 0 itself is a perfectly smooth surface, whose distribution is a delta.
        const float alpha = props.getFloat("alpha", 0.1f);
        if (alpha == 0.0f)
            props.fail(
                "alpha 0 is a perfectly smooth surface: the Beckmann distribution is then a "
                "delta, which this BSDF cannot evaluate or sample; use a mirror or a dielectric, "
                "or an alpha of at least %g",
                kMinAlpha);
        props.getPositiveFloat("alpha", 0.1f);
        if (alpha < kMinAlpha)
            props.fail(
                "alpha %g is too small to render in float precision: alpha^2 is below the "
                "smallest normal float, where the Beckmann distribution's peak 1 / (pi alpha^2) "
                "is lost (at least %g)",
                alpha, kMinAlpha);
        const Color3f kd = props.getNonNegativeColor("kd", Color3f(0.5f));
        if (kd.maxCoeff() > 1.0f)
            props.fail(
                "kd must not exceed 1 in any channel (got %s): ks = 1 - max(kd) would be "
                "negative",
                kd.toString());
        m_intIOR = props.getPositiveFloat("intIOR", 1.5046f);
        m_extIOR = props.getPositiveFloat("extIOR", 1.000277f);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_kd.addChild(child, name, *this) || m_alpha.addChild(child, name, *this)) return;
        if (child->kind() == ObjectKind::Texture)
            fail("microfacet has no texture parameter \"%s\" (textures: kd, alpha)", name);
        BSDF::addChild(child, name);
    }

    void activate() override {
        // Texture bounds are exact, so a texture that could leave the valid range is rejected
        // up front instead of being clamped while shading.
        if (!(m_alpha.lowerBound() >= kMinAlpha) || !std::isfinite(m_alpha.upperBound()))
            fail("the alpha texture must stay within [%g, inf) (bounds %g to %g)", kMinAlpha,
                 m_alpha.lowerBound(), m_alpha.upperBound());
        if (m_kd.lowerBound().minCoeff() < 0.0f || m_kd.upperBound().maxCoeff() > 1.0f)
            fail("the kd texture must stay within [0, 1] (bounds %s to %s)",
                 m_kd.lowerBound().toString(), m_kd.upperBound().toString());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        const float cosI = Frame::cosTheta(rec.wi), cosO = Frame::cosTheta(rec.wo);
        if (rec.measure != Measure::SolidAngle || cosI <= 0.0f || cosO <= 0.0f)
            return Color3f(0.0f);
        const Params params = at(rec);
        // Both directions are in the upper hemisphere, so wi + wo is never zero.
        const Vector3f wh = (rec.wi + rec.wo).normalized();
        // The warp's density is D(wh) cos(theta_h); Cook-Torrance needs D itself.
        const float D = warp::squareToBeckmannPdf(wh, params.alpha) / Frame::cosTheta(wh);
        const float F = fresnelDielectric(wh.dot(rec.wi), m_extIOR, m_intIOR);
        const float G = smithG1(rec.wi, wh, params.alpha) * smithG1(rec.wo, wh, params.alpha);
        const float specular = params.ks * D * F * G / (4.0f * cosI * cosO);
        return params.kd * InvPi + Color3f(specular);
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        const float cosI = Frame::cosTheta(rec.wi), cosO = Frame::cosTheta(rec.wo);
        if (rec.measure != Measure::SolidAngle || cosI <= 0.0f || cosO <= 0.0f) return 0.0f;
        const Params params = at(rec);
        const Vector3f wh = (rec.wi + rec.wo).normalized();
        // Jacobian of the half-vector reflection wo = 2 (wi.wh) wh - wi: 1 / (4 wo.wh).
        const float jacobian = 1.0f / (4.0f * std::abs(wh.dot(rec.wo)));
        return params.ks * warp::squareToBeckmannPdf(wh, params.alpha) * jacobian +
               (1.0f - params.ks) * cosO * InvPi;
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        if (Frame::cosTheta(rec.wi) <= 0.0f) return Color3f(0.0f);
        const Params params = at(rec);
        Point2f u = sample;
        if (u.x() < params.ks) {
            // Reuse the lobe-selection number, rescaled to [0, 1), for the half vector.
            u.x() = std::min(u.x() / params.ks, 0.99999994f);
            const Vector3f wh = warp::squareToBeckmann(u, params.alpha);
            rec.wo = 2.0f * wh.dot(rec.wi) * wh - rec.wi;
        } else {
            u.x() = std::min((u.x() - params.ks) / (1.0f - params.ks), 0.99999994f);
            rec.wo = warp::squareToCosineHemisphere(u);
        }
        rec.measure = Measure::SolidAngle;
        rec.eta = 1.0f;
        // A half vector can reflect wi below the surface: that sample is lost (weight 0), and
        // pdf() integrates to the probability of success, as the chi-square test expects.
        if (Frame::cosTheta(rec.wo) <= 0.0f) return Color3f(0.0f);
        const float density = pdf(rec);
        if (!(density > 0.0f) || !std::isfinite(density)) return Color3f(0.0f);
        return eval(rec) * Frame::cosTheta(rec.wo) / density;
    }

    bool isDiffuse() const override { return true; }

    std::string toString() const override {
        return "microfacet, intIOR " + std::to_string(m_intIOR) + ", extIOR " +
               std::to_string(m_extIOR) + ", kd " + m_kd.toString();
    }

  private:
    struct Params {
        Color3f kd;
        float ks, alpha;
    };

    // The (possibly textured) parameters at the query point; ks = 1 - max(kd) point by point.
    Params at(const BSDFQueryRecord& rec) const {
        const Color3f kd = m_kd.eval(rec.uv, rec.p);
        return Params{kd, 1.0f - kd.maxCoeff(), m_alpha.eval(rec.uv, rec.p)};
    }

    // Smith's shadowing for Beckmann, rational approximation; zero for back-facing microfacets.
    static float smithG1(const Vector3f& wv, const Vector3f& wh, float alpha) {
        const float cosV = Frame::cosTheta(wv);
        if (cosV == 0.0f || wv.dot(wh) / cosV <= 0.0f) return 0.0f;
        const float tanTheta = Frame::tanTheta(wv);
        if (tanTheta == 0.0f) return 1.0f;  // normal incidence: no shadowing
        const float b = 1.0f / (alpha * std::abs(tanTheta));
        if (b >= 1.6f) return 1.0f;
        const float b2 = b * b;
        return (3.535f * b + 2.181f * b2) / (1.0f + 2.276f * b + 2.577f * b2);
    }

    // The smallest roughness whose square is a normal float (sqrt(FLT_MIN)). Below it alpha^2
    // loses its precision and D = exp(-tan^2 / alpha^2) / (pi alpha^2 cos^3) turns NaN or 0
    // (alpha 5e-20 gave NaN at 80 degrees, 3e-20 a black surface). Above it, down to 1e-8 and
    // beyond, BSDF sampling renders the lobe as a mirror weighted by Fresnel, as it should.
    static constexpr float kMinAlpha = 1.0842022e-19f;
    TexturedFloat m_alpha;
    TexturedColor m_kd;
    float m_intIOR, m_extIOR;
};

ALPHORN_REGISTER(BSDF, "microfacet", Microfacet);

}  // namespace alphorn
