// <texture type="exponential3d">: a colour ramp by exponential falloff along the local +z axis
// of the texture space placed by `toWorld`:
//
//     h = max(0, z_local),   value = color1 + (color0 - color1) * exp(-falloff * h)
//
// so the value is color0 on and below the plane z_local = 0 and tends to color1 far along +z.
// With color1 = 0 it is the density s0 exp(-k z) of an exponential atmosphere.
// Holding the value constant below z = 0 keeps it bounded (a majorant must exist for media).
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

namespace alphorn {

class Exponential3D : public Texture {
  public:
    explicit Exponential3D(const PropertyList& props) : m_mapping(props) {
        m_color0 = props.getColor("color0", Color3f(1.0f));
        m_color1 = props.getColor("color1", Color3f(0.0f));
        m_falloff = props.getNonNegativeFloat("falloff", 1.0f);
        if (!m_color0.allFinite() || !m_color1.allFinite()) props.fail("colours must be finite");
        if (!std::isfinite(m_falloff)) props.fail("falloff must be finite");
    }

    Color3f eval(const Point2f&, const Point3f& p) const override {
        const float h = std::max(0.0f, m_mapping.map(p).z());
        const Color3f value = m_color1 + (m_color0 - m_color1) * std::exp(-m_falloff * h);
        // Rounding could step an ulp past the end colours; the clamp keeps the bounds true.
        return value.max(lowerBound()).min(upperBound());
    }
    bool is3D() const override { return true; }
    // The value moves monotonically from color0 towards color1, so both bound it.
    Color3f lowerBound() const override { return m_color0.min(m_color1); }
    Color3f upperBound() const override { return m_color0.max(m_color1); }
    std::string toString() const override { return "exponential3d"; }

  private:
    SpaceMapping m_mapping;
    Color3f m_color0, m_color1;
    float m_falloff;
};

ALPHORN_REGISTER(Texture, "exponential3d", Exponential3D);

}  // namespace alphorn
