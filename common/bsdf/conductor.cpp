// <bsdf type="conductor">: pbrt-v4's metal. A complex index `eta` + i `k` (default copper) or,
// instead, an artist-friendly normal-incidence `reflectance`; a smooth surface (roughness 0) is
// a delta reflection weighted by the conductor Fresnel term, a rough one the GGX microfacet
// BRDF with visible-normal sampling. Like pbrt-v4's, it reflects the same on both sides.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/lobes.h"
#include "common/bsdf/roughness.h"
#include "common/core/spectrum.h"

namespace alphorn {

namespace {
Color3f copper(const char* name) {
    return namedSpectrumRgb(name, SpectrumUse::Unbounded).value();
}
}  // namespace

class Conductor : public BSDF {
  public:
    explicit Conductor(const PropertyList& props)
        : m_eta(props, "eta", copper("metal-Cu-eta")),
          m_k(props, "k", copper("metal-Cu-k")),
          m_reflectance(props, "reflectance", Color3f(0.0f)),
          m_roughness(props, "") {
        m_reflectanceMode = props.has("reflectance");
        if (m_reflectanceMode && (props.has("eta") || props.has("k")))
            props.fail("give either \"reflectance\" or \"eta\"/\"k\", not both");
        if (props.has("eta")) positiveColor(props, "eta");
        if (props.has("k")) props.getNonNegativeColor("k", Color3f(0.0f));
        if (m_reflectanceMode) {
            const Color3f r = props.getNonNegativeColor("reflectance", Color3f(0.0f));
            if (r.maxCoeff() > 1.0f)
                props.fail("\"reflectance\" must not exceed 1 in any channel (got %s)",
                           r.toString());
        }
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_eta.addChild(child, name, *this) || m_k.addChild(child, name, *this) ||
            m_roughness.addChild(child, name, *this))
            return;
        if (m_reflectance.addChild(child, name, *this)) {
            m_reflectanceMode = true;
            return;
        }
        if (child->kind() == ObjectKind::Texture)
            fail(
                "conductor has no texture parameter \"%s\" (textures: eta, k, reflectance, "
                "roughness, uroughness, vroughness)",
                name);
        BSDF::addChild(child, name);
    }

    void activate() override {
        m_roughness.validate(*this);
        if (m_reflectanceMode && (m_eta.isTextured() || m_k.isTextured()))
            fail("give either \"reflectance\" or \"eta\"/\"k\", not both");
        if (!(m_eta.lowerBound().minCoeff() > 0.0f) || !m_eta.upperBound().allFinite())
            fail("the \"eta\" texture must stay finite and > 0 (from %s to %s)",
                 m_eta.lowerBound().toString(), m_eta.upperBound().toString());
        if (!(m_k.lowerBound().minCoeff() >= 0.0f) || !m_k.upperBound().allFinite())
            fail("the \"k\" texture must stay finite and >= 0 (from %s to %s)",
                 m_k.lowerBound().toString(), m_k.upperBound().toString());
        if (m_reflectanceMode && (!(m_reflectance.lowerBound().minCoeff() >= 0.0f) ||
                                  !(m_reflectance.upperBound().maxCoeff() <= 1.0f)))
            fail("the \"reflectance\" texture must stay within [0, 1] (from %s to %s)",
                 m_reflectance.lowerBound().toString(), m_reflectance.upperBound().toString());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle) return Color3f(0.0f);
        return lobe(rec).f(rec.wi, rec.wo);
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle) return 0.0f;
        return lobe(rec).pdf(rec.wi, rec.wo);
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        const lobes::Conductor conductor = lobe(rec);
        const auto s = conductor.sample(rec.wi, 0.0f, sample);
        if (!s || !(s->pdf > 0.0f)) return Color3f(0.0f);
        return lobes::recordSample(rec, *s, 1.0f);
    }

    bool isDiffuse() const override { return m_roughness.mayBeRough(); }
    bool needsTangentFrame() const override { return m_roughness.mayBeAnisotropic(); }

    std::string toString() const override {
        return "conductor, " +
               (m_reflectanceMode ? "reflectance " + m_reflectance.toString()
                                  : "eta " + m_eta.toString() + ", k " + m_k.toString()) +
               ", " + m_roughness.toString();
    }

  private:
    static void positiveColor(const PropertyList& props, const std::string& name) {
        const Color3f c = props.getColor(name);
        if (!(c.minCoeff() > 0.0f) || !c.allFinite())
            props.fail("\"%s\" must be finite and > 0 in every channel (got %s)", name,
                       c.toString());
    }

    lobes::Conductor lobe(const BSDFQueryRecord& rec) const {
        lobes::Conductor c;
        c.distribution = m_roughness.at(rec.uv, rec.p);
        if (m_reflectanceMode) {
            // pbrt-v4's artist mode: eta = 1 and the k whose normal-incidence reflectance
            // k^2 / (4 + k^2) is the given one, i.e. k = 2 sqrt(r / (1 - r)); r is kept below 1
            // so that k stays finite.
            const Color3f r = m_reflectance.eval(rec.uv, rec.p).min(0.9999f).max(0.0f);
            c.eta = Color3f(1.0f);
            c.k = 2.0f * r.sqrt() / (1.0f - r).sqrt();
        } else {
            c.eta = m_eta.eval(rec.uv, rec.p);
            c.k = m_k.eval(rec.uv, rec.p);
        }
        return c;
    }

    TexturedColor m_eta, m_k, m_reflectance;
    RoughnessParameters m_roughness;
    bool m_reflectanceMode = false;
};

ALPHORN_REGISTER(BSDF, "conductor", Conductor);

}  // namespace alphorn
