// What pbrt-v4's two coated materials share: the dielectric coat (index, roughness), the medium
// between coat and base (`thickness`, `albedo`, `g`), the walk's `maxdepth` and `nsamples`, and
// the BSDF interface around the random-walk estimators of layered.h. Each plugin adds its base.
#pragma once

#include "common/bsdf/bsdf.h"
#include "common/bsdf/layered.h"
#include "common/bsdf/roughness.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

template <typename Base>
class Coated : public BSDF {
  public:
    // roughnessPrefix and etaName: the coat's parameter names ("" and "eta" for coateddiffuse,
    // "interface." and "interface.eta" for coatedconductor).
    Coated(const PropertyList& props, const std::string& roughnessPrefix,
           const std::string& etaName)
        : m_interface(props, roughnessPrefix),
          m_thickness(props, "thickness", 0.01f),
          m_albedo(props, "albedo", Color3f(0.0f)) {
        m_eta = props.getPositiveFloat(etaName, 1.5f);
        if (!std::isfinite(m_eta)) props.fail("\"%s\" must be finite, got %g", etaName, m_eta);
        const float thickness = props.getPositiveFloat("thickness", 0.01f);
        if (!std::isfinite(thickness))
            props.fail("\"thickness\" must be finite, got %g", thickness);
        const Color3f albedo = props.getNonNegativeColor("albedo", Color3f(0.0f));
        if (albedo.maxCoeff() > 1.0f)
            props.fail("\"albedo\" must not exceed 1 in any channel (got %s)", albedo.toString());
        const float g = props.getFloat("g", 0.0f);
        if (!(std::abs(g) < 1.0f))
            props.fail("\"g\" must be in the open interval (-1, 1), got %g", g);
        // Each bounce costs a few lobe evaluations; beyond these the walk's tail is invisible.
        m_maxDepth = props.getPositiveInteger("maxdepth", 10);
        if (m_maxDepth > 1000)
            props.fail("\"maxdepth\" %d is too large (at most 1000)", m_maxDepth);
        m_samples = props.getPositiveInteger("nsamples", 1);
        if (m_samples > 256) props.fail("\"nsamples\" %d is too large (at most 256)", m_samples);
        PropertyList phaseProps;
        phaseProps.setFloat("g", g);
        m_phase = std::static_pointer_cast<PhaseFunction>(
            ObjectFactory::create(ObjectKind::PhaseFunction, "hg", phaseProps));
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_interface.addChild(child, name, *this) || m_thickness.addChild(child, name, *this) ||
            m_albedo.addChild(child, name, *this))
            return;
        if (child->kind() == ObjectKind::Texture)
            fail("%s has no texture parameter \"%s\" (textures: %s)", typeName(), name,
                 textureNames());
        BSDF::addChild(child, name);
    }

    void activate() override {
        m_interface.validate(*this);
        if (!(m_thickness.lowerBound() > 0.0f) || !std::isfinite(m_thickness.upperBound()))
            fail("the \"thickness\" texture must stay finite and > 0 (from %g to %g)",
                 m_thickness.lowerBound(), m_thickness.upperBound());
        if (!(m_albedo.lowerBound().minCoeff() >= 0.0f) ||
            !(m_albedo.upperBound().maxCoeff() <= 1.0f))
            fail("the \"albedo\" texture must stay within [0, 1] (from %s to %s)",
                 m_albedo.lowerBound().toString(), m_albedo.upperBound().toString());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle) return Color3f(0.0f);
        const Color3f f = layered(rec).f(rec.wi, rec.wo, seed(rec));
        return f.allFinite() ? f : Color3f(0.0f);
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        if (rec.measure != Measure::SolidAngle) return 0.0f;
        const auto walk = layered(rec);
        if (walk.allSpecular()) return 0.0f;
        const float p = walk.pdf(rec.wi, rec.wo, seed(rec));
        return std::isfinite(p) ? p : 0.0f;
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        // The coat's reflect-or-enter choice needs a third number (see lobes::hashToUnit).
        const auto s = layered(rec).sample(rec.wi, lobes::hashToUnit(sample), sample, seed(rec));
        if (!s || !(s->pdf > 0.0f)) return Color3f(0.0f);
        return lobes::recordSample(rec, *s, 1.0f);
    }

    // Lights are sampled unless every part is a delta (a smooth coat on a smooth conductor with
    // no scattering medium): then, as for a mirror, only sample() carries light.
    bool isDiffuse() const override {
        return m_interface.mayBeRough() || baseMayBeRough() || m_albedo.isTextured() ||
               !m_albedo.value().isBlack();
    }
    bool needsTangentFrame() const override {
        return m_interface.mayBeAnisotropic() || baseNeedsTangentFrame();
    }

    std::string toString() const override {
        return "coat eta " + std::to_string(m_eta) + ", interface " + m_interface.toString() +
               ", thickness " + m_thickness.toString() + ", albedo " + m_albedo.toString() +
               ", maxdepth " + std::to_string(m_maxDepth) + ", nsamples " +
               std::to_string(m_samples);
    }

  protected:
    virtual Base base(const BSDFQueryRecord& rec) const = 0;
    float coatEta() const { return m_eta; }
    virtual bool baseMayBeRough() const = 0;
    virtual bool baseNeedsTangentFrame() const { return false; }
    virtual const char* textureNames() const = 0;
    virtual const char* typeName() const = 0;

    lobes::Layered<Base> layered(const BSDFQueryRecord& rec) const {
        lobes::Dielectric top;
        top.eta = m_eta;
        top.distribution = m_interface.at(rec.uv, rec.p);
        lobes::LayeredConfig config;
        config.thickness = m_thickness.eval(rec.uv, rec.p);
        config.albedo = m_albedo.eval(rec.uv, rec.p);
        config.phase = m_phase.get();
        config.maxDepth = m_maxDepth;
        config.samples = m_samples;
        return lobes::Layered<Base>(top, base(rec), config);
    }

    // The walks' seed: the query's uv (its directions are hashed by the walks themselves).
    static uint64_t seed(const BSDFQueryRecord& rec) { return lobes::hashBits(0x1a7e, rec.uv); }

  private:
    RoughnessParameters m_interface;
    TexturedFloat m_thickness;
    TexturedColor m_albedo;
    float m_eta;
    int m_maxDepth, m_samples;
    std::shared_ptr<PhaseFunction> m_phase;
};

}  // namespace alphorn
