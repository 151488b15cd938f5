// <texture type="checkerboard2d">: a checkerboard in uv. After the uv mapping (uscale, vscale,
// uoffset, voffset), each unit square of uv holds 2 x 2 checks (as Mitsuba's checkerboard):
// color0 where floor(2u') + floor(2v') is even -- the check at the uv origin -- and color1
// elsewhere.
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

namespace alphorn {

class Checkerboard2D : public Texture {
  public:
    explicit Checkerboard2D(const PropertyList& props) : m_mapping(props) {
        m_color0 = props.getColor("color0", Color3f(0.4f));
        m_color1 = props.getColor("color1", Color3f(0.2f));
        if (!m_color0.allFinite() || !m_color1.allFinite()) props.fail("colours must be finite");
    }

    Color3f eval(const Point2f& uv, const Point3f&) const override {
        const Point2f m = m_mapping.map(uv);
        const auto parity = latticeIndex(2.0f * m.x()) + latticeIndex(2.0f * m.y());
        return (parity & 1) == 0 ? m_color0 : m_color1;
    }
    bool is3D() const override { return false; }
    Color3f lowerBound() const override { return m_color0.min(m_color1); }
    Color3f upperBound() const override { return m_color0.max(m_color1); }
    std::string toString() const override { return "checkerboard2d"; }

  private:
    UVMapping m_mapping;
    Color3f m_color0, m_color1;
};

ALPHORN_REGISTER(Texture, "checkerboard2d", Checkerboard2D);

}  // namespace alphorn
