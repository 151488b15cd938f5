// <bsdf type="diffuse">: a Lambertian reflector with `albedo` (Nori's default 0.5), which may be
// a nested <texture name="albedo">, evaluated at the query's uv and position.
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

class Diffuse : public BSDF {
  public:
    explicit Diffuse(const PropertyList& props) : m_albedo(props, "albedo", Color3f(0.5f)) {
        props.getNonNegativeColor("albedo", Color3f(0.5f));  // validates a plain value
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_albedo.addChild(child, name, *this)) return;
        if (child->kind() == ObjectKind::Texture)
            fail("diffuse has no texture parameter \"%s\" (textures: albedo)", name);
        BSDF::addChild(child, name);
    }

    // A textured albedo is held to what a plain one is: texture bounds are exact, so a texture
    // that can go negative or infinite is refused here, at its element, rather than showing up
    // as negative samples while rendering.
    void activate() override {
        if (!m_albedo.isTextured()) return;
        const Color3f lower = m_albedo.lowerBound(), upper = m_albedo.upperBound();
        if (!(lower.minCoeff() >= 0.0f) || !upper.allFinite())
            m_albedo.texture()->fail(
                "the diffuse \"albedo\" must stay finite and >= 0 in every channel; this "
                "texture ranges from %s to %s",
                lower.toString(), upper.toString());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle || Frame::cosTheta(rec.wi) <= 0.0f ||
            Frame::cosTheta(rec.wo) <= 0.0f)
            return Color3f(0.0f);
        return m_albedo.eval(rec.uv, rec.p) * InvPi;
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
        return m_albedo.eval(rec.uv, rec.p);
    }

    bool isDiffuse() const override { return true; }
    std::string toString() const override { return "diffuse, albedo " + m_albedo.toString(); }

  private:
    TexturedColor m_albedo;
};

ALPHORN_REGISTER(BSDF, "diffuse", Diffuse);

}  // namespace alphorn
