// pbrt-v4's roughness parameters of a GGX lobe, shared by the conductor, rough dielectric and
// coated BSDFs: `roughness` for both directions, or `uroughness` / `vroughness` for the shading
// frame's tangent (u) and bitangent (v) directions, each a float or a nested texture, and
// `remaproughness` (true: alpha = sqrt(roughness); false: the values are alphas). The names
// take a prefix for the coated conductor's two lobes ("interface.", "conductor."); as in pbrt-v4,
// one unprefixed `remaproughness` applies to both.
#pragma once

#include "common/bsdf/microfacet_distribution.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

class RoughnessParameters {
  public:
    RoughnessParameters() = default;
    RoughnessParameters(const PropertyList& props, const std::string& prefix)
        : m_prefix(prefix),
          m_roughness(props, prefix + "roughness", 0.0f),
          m_u(props, prefix + "uroughness", 0.0f),
          m_v(props, prefix + "vroughness", 0.0f),
          m_remap(props.getBoolean("remaproughness", true)) {
        m_hasU = props.has(prefix + "uroughness");
        m_hasV = props.has(prefix + "vroughness");
        m_roughnessGiven = props.has(prefix + "roughness");
        for (const TexturedFloat* p : {&m_roughness, &m_u, &m_v})
            if (props.has(p->name())) {
                const float value = props.getFloat(p->name());
                if (!(value >= 0.0f) || !std::isfinite(value))
                    props.fail("\"%s\" must be finite and >= 0, got %g", p->name(), value);
            }
    }

    // Takes a nested texture for one of the roughness names; returns whether it did.
    bool addChild(const std::shared_ptr<Object>& child, const std::string& name,
                  const Object& owner) {
        if (m_u.addChild(child, name, owner)) {
            m_hasU = true;
            return true;
        }
        if (m_v.addChild(child, name, owner)) {
            m_hasV = true;
            return true;
        }
        return m_roughness.addChild(child, name, owner);
    }

    // Call from activate(): textures must stay finite and non-negative, and a `roughness` that
    // both directions override would be silently ignored.
    void validate(const Object& owner) const {
        for (const TexturedFloat* p : {&m_roughness, &m_u, &m_v})
            if (!(p->lowerBound() >= 0.0f) || !std::isfinite(p->upperBound()))
                owner.fail("\"%s\" must stay finite and >= 0 (from %g to %g)", p->name(),
                           p->lowerBound(), p->upperBound());
        if (m_hasU && m_hasV && (m_roughness.isTextured() || m_roughnessGiven))
            owner.fail(
                "\"%sroughness\" is overridden by both \"%suroughness\" and "
                "\"%svroughness\"; give one or the other",
                m_prefix, m_prefix, m_prefix);
    }

    TrowbridgeReitz at(const Point2f& uv, const Point3f& p) const {
        const float u = (m_hasU ? m_u : m_roughness).eval(uv, p);
        const float v = (m_hasV ? m_v : m_roughness).eval(uv, p);
        return TrowbridgeReitz(alpha(u), alpha(v));
    }
    // Whether some point may be rough (not a delta lobe), judged from the texture bounds.
    bool mayBeRough() const {
        const float u = (m_hasU ? m_u : m_roughness).upperBound();
        const float v = (m_hasV ? m_v : m_roughness).upperBound();
        return std::max(alpha(u), alpha(v)) >= TrowbridgeReitz::kSmoothAlpha;
    }
    // Whether the lobe may differ along u and v, so that hits need a tangent frame.
    bool mayBeAnisotropic() const {
        if (!m_hasU && !m_hasV) return false;
        const TexturedFloat& u = m_hasU ? m_u : m_roughness;
        const TexturedFloat& v = m_hasV ? m_v : m_roughness;
        return u.isTextured() || v.isTextured() || u.value() != v.value();
    }
    std::string toString() const {
        std::string s = m_prefix + "roughness ";
        if (m_hasU || m_hasV)
            s += (m_hasU ? m_u : m_roughness).toString() + " x " +
                 (m_hasV ? m_v : m_roughness).toString();
        else
            s += m_roughness.toString();
        return s + (m_remap ? " (remapped)" : "");
    }

  private:
    float alpha(float roughness) const {
        return m_remap ? TrowbridgeReitz::roughnessToAlpha(roughness) : roughness;
    }

    std::string m_prefix;
    TexturedFloat m_roughness, m_u, m_v;
    bool m_remap = true, m_hasU = false, m_hasV = false, m_roughnessGiven = false;
};

}  // namespace alphorn
