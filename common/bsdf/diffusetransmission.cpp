// <bsdf type="diffusetransmission">: pbrt-v4's Lambertian reflector and transmitter (leaves,
// paper, lamp shades): `reflectance` / pi on the side light arrives from, `transmittance` / pi on
// the other, both times `scale`. Sampling picks the side in proportion to the larger channel of
// each, then a cosine-weighted direction on it.
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

class DiffuseTransmission : public BSDF {
  public:
    explicit DiffuseTransmission(const PropertyList& props)
        : m_reflectance(props, "reflectance", Color3f(0.25f)),
          m_transmittance(props, "transmittance", Color3f(0.25f)) {
        props.getNonNegativeColor("reflectance", Color3f(0.25f));
        props.getNonNegativeColor("transmittance", Color3f(0.25f));
        m_scale = props.getNonNegativeFloat("scale", 1.0f);
        if (!std::isfinite(m_scale)) props.fail("\"scale\" must be finite, got %g", m_scale);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_reflectance.addChild(child, name, *this) ||
            m_transmittance.addChild(child, name, *this))
            return;
        if (child->kind() == ObjectKind::Texture)
            fail(
                "diffusetransmission has no texture parameter \"%s\" (textures: reflectance, "
                "transmittance)",
                name);
        BSDF::addChild(child, name);
    }

    void activate() override {
        for (const TexturedColor* c : {&m_reflectance, &m_transmittance})
            if (!(c->lowerBound().minCoeff() >= 0.0f) || !c->upperBound().allFinite())
                fail("the \"%s\" texture must stay finite and >= 0 (from %s to %s)", c->name(),
                     c->lowerBound().toString(), c->upperBound().toString());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle || rec.wi.z() == 0.0f || rec.wo.z() == 0.0f)
            return Color3f(0.0f);
        const TexturedColor& side =
            rec.wi.z() * rec.wo.z() > 0.0f ? m_reflectance : m_transmittance;
        return side.eval(rec.uv, rec.p) * (m_scale * InvPi);
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle || rec.wi.z() == 0.0f || rec.wo.z() == 0.0f)
            return 0.0f;
        const Choice c = choice(rec);
        if (c.reflect < 0.0f) return 0.0f;
        const float p = rec.wi.z() * rec.wo.z() > 0.0f ? c.reflect : 1.0f - c.reflect;
        return p * std::abs(rec.wo.z()) * InvPi;
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        if (rec.wi.z() == 0.0f) return Color3f(0.0f);
        const Choice c = choice(rec);
        if (c.reflect < 0.0f) return Color3f(0.0f);
        Point2f u = sample;
        const bool reflect = u.x() < c.reflect;
        // The side-choosing number, rescaled to [0, 1), then places the direction.
        u.x() = reflect ? u.x() / c.reflect : (u.x() - c.reflect) / (1.0f - c.reflect);
        u.x() = std::min(u.x(), 0.99999994f);
        rec.wo = warp::squareToCosineHemisphere(u);
        if ((rec.wi.z() < 0.0f) == reflect) rec.wo.z() = -rec.wo.z();
        rec.measure = Measure::SolidAngle;
        rec.eta = 1.0f;
        if (rec.wo.z() == 0.0f) return Color3f(0.0f);
        // eval * cos / pdf: the cosines cancel, leaving the side's colour over its chance.
        return reflect ? c.r / c.reflect : c.t / (1.0f - c.reflect);
    }

    bool isDiffuse() const override { return true; }

    std::string toString() const override {
        return "diffusetransmission, reflectance " + m_reflectance.toString() + ", transmittance " +
               m_transmittance.toString() + ", scale " + std::to_string(m_scale);
    }

  private:
    struct Choice {
        Color3f r, t;
        float reflect;  // the chance of sampling the reflection side; < 0 if nothing scatters
    };
    Choice choice(const BSDFQueryRecord& rec) const {
        Choice c;
        c.r = m_reflectance.eval(rec.uv, rec.p) * m_scale;
        c.t = m_transmittance.eval(rec.uv, rec.p) * m_scale;
        const float pr = c.r.maxCoeff(), pt = c.t.maxCoeff();
        c.reflect = pr + pt > 0.0f ? pr / (pr + pt) : -1.0f;
        return c;
    }

    TexturedColor m_reflectance, m_transmittance;
    float m_scale;
};

ALPHORN_REGISTER(BSDF, "diffusetransmission", DiffuseTransmission);

}  // namespace alphorn
