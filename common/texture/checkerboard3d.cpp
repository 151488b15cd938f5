// <texture type="checkerboard3d">: a solid checkerboard of cubes of side `scale` (default 1) in
// the texture space placed by `toWorld`: color0 where floor(x/s) + floor(y/s) + floor(z/s) is
// even -- the cube [0, s)^3 -- and color1 elsewhere.
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

namespace alphorn {

class Checkerboard3D : public Texture {
  public:
    explicit Checkerboard3D(const PropertyList& props) : m_mapping(props) {
        m_color0 = props.getColor("color0", Color3f(0.4f));
        m_color1 = props.getColor("color1", Color3f(0.2f));
        m_invScale = 1.0f / props.getPositiveFloat("scale", 1.0f);
        if (!m_color0.allFinite() || !m_color1.allFinite()) props.fail("colours must be finite");
    }

    Color3f eval(const Point2f&, const Point3f& p) const override {
        const Point3f q = m_mapping.map(p) * m_invScale;
        // Cells are counted in 64 bits so far-away points cannot overflow into the wrong parity.
        int64_t parity = 0;
        for (int i = 0; i < 3; ++i) parity += latticeIndex(q[i]);
        return (parity & 1) == 0 ? m_color0 : m_color1;
    }
    bool is3D() const override { return true; }
    Color3f lowerBound() const override { return m_color0.min(m_color1); }
    Color3f upperBound() const override { return m_color0.max(m_color1); }
    std::string toString() const override { return "checkerboard3d"; }

  private:
    SpaceMapping m_mapping;
    Color3f m_color0, m_color1;
    float m_invScale;
};

ALPHORN_REGISTER(Texture, "checkerboard3d", Checkerboard3D);

}  // namespace alphorn
