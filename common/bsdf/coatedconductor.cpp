// <bsdf type="coatedconductor">: pbrt-v4's coated conductor material, a conductor base (complex
// index `conductor.eta` + i `conductor.k`, default copper, or an artist-friendly `reflectance`;
// roughness `conductor.roughness` / `conductor.uroughness` / `conductor.vroughness`) under a
// dielectric coat of index `interface.eta` (roughness `interface.roughness` /
// `interface.uroughness` / `interface.vroughness`), with an optional scattering medium of
// `albedo` and `g` and `thickness` between them (car paint, lacquered metal). `remaproughness`
// applies to both lobes. The random-walk estimators are in layered.h.
#include "common/bsdf/coated.h"
#include "common/core/spectrum.h"

namespace alphorn {

class CoatedConductor : public Coated<lobes::Conductor> {
  public:
    explicit CoatedConductor(const PropertyList& props)
        : Coated(props, "interface.", "interface.eta"),
          m_eta(props, "conductor.eta", metal("metal-Cu-eta")),
          m_k(props, "conductor.k", metal("metal-Cu-k")),
          m_reflectance(props, "reflectance", Color3f(0.0f)),
          m_roughness(props, "conductor.") {
        m_reflectanceMode = props.has("reflectance");
        if (m_reflectanceMode && (props.has("conductor.eta") || props.has("conductor.k")))
            props.fail(
                "give either \"reflectance\" or \"conductor.eta\"/\"conductor.k\", not both");
        if (props.has("conductor.eta")) {
            const Color3f eta = props.getColor("conductor.eta");
            if (!(eta.minCoeff() > 0.0f) || !eta.allFinite())
                props.fail("\"conductor.eta\" must be finite and > 0 in every channel (got %s)",
                           eta.toString());
        }
        if (props.has("conductor.k")) {
            const Color3f k = props.getNonNegativeColor("conductor.k", Color3f(0.0f));
            if (!k.allFinite()) props.fail("\"conductor.k\" must be finite (got %s)", k.toString());
        }
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
        Coated::addChild(child, name);
    }

    void activate() override {
        Coated::activate();
        m_roughness.validate(*this);
        if (m_reflectanceMode && (m_eta.isTextured() || m_k.isTextured()))
            fail("give either \"reflectance\" or \"conductor.eta\"/\"conductor.k\", not both");
        if (!(m_eta.lowerBound().minCoeff() > 0.0f) || !m_eta.upperBound().allFinite())
            fail("the \"conductor.eta\" texture must stay finite and > 0 (from %s to %s)",
                 m_eta.lowerBound().toString(), m_eta.upperBound().toString());
        if (!(m_k.lowerBound().minCoeff() >= 0.0f) || !m_k.upperBound().allFinite())
            fail("the \"conductor.k\" texture must stay finite and >= 0 (from %s to %s)",
                 m_k.lowerBound().toString(), m_k.upperBound().toString());
        if (m_reflectanceMode && (!(m_reflectance.lowerBound().minCoeff() >= 0.0f) ||
                                  !(m_reflectance.upperBound().maxCoeff() <= 1.0f)))
            fail("the \"reflectance\" texture must stay within [0, 1] (from %s to %s)",
                 m_reflectance.lowerBound().toString(), m_reflectance.upperBound().toString());
    }

    std::string toString() const override {
        return "coatedconductor, " +
               (m_reflectanceMode
                    ? "reflectance " + m_reflectance.toString()
                    : "conductor.eta " + m_eta.toString() + ", conductor.k " + m_k.toString()) +
               ", " + m_roughness.toString() + ", " + Coated::toString();
    }

  protected:
    lobes::Conductor base(const BSDFQueryRecord& rec) const override {
        lobes::Conductor c;
        c.distribution = m_roughness.at(rec.uv, rec.p);
        if (m_reflectanceMode) {
            // pbrt-v4's artist mode, as for <bsdf type="conductor">: eta 1 and the k whose
            // normal-incidence reflectance is the given one (r kept below 1 for a finite k).
            const Color3f r = m_reflectance.eval(rec.uv, rec.p).min(0.9999f).max(0.0f);
            c.eta = Color3f(1.0f);
            c.k = 2.0f * r.sqrt() / (1.0f - r).sqrt();
        } else {
            c.eta = m_eta.eval(rec.uv, rec.p);
            c.k = m_k.eval(rec.uv, rec.p);
        }
        // The base sits under the coat, so its index is relative to the coat's (pbrt-v4 does
        // the same in both modes: `reflectance` is then what the bare metal would reflect in
        // air, and the coated one reflects less).
        c.eta /= coatEta();
        c.k /= coatEta();
        return c;
    }
    bool baseMayBeRough() const override { return m_roughness.mayBeRough(); }
    bool baseNeedsTangentFrame() const override { return m_roughness.mayBeAnisotropic(); }
    const char* textureNames() const override {
        return "conductor.eta, conductor.k, reflectance, conductor.roughness, "
               "conductor.uroughness, conductor.vroughness, interface.roughness, "
               "interface.uroughness, interface.vroughness, thickness, albedo";
    }
    const char* typeName() const override { return "coatedconductor"; }

  private:
    static Color3f metal(const char* name) {
        return namedSpectrumRgb(name, SpectrumUse::Unbounded).value();
    }

    TexturedColor m_eta, m_k, m_reflectance;
    RoughnessParameters m_roughness;
    bool m_reflectanceMode = false;
};

ALPHORN_REGISTER(BSDF, "coatedconductor", CoatedConductor);

}  // namespace alphorn
