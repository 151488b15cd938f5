// <texture type="uv">: shows the (mapped) surface coordinates as colour (frac(u'), frac(v'), 0),
// for checking a mesh's parameterisation and a projector's orientation. The fractional part
// keeps the value (and so the bounds) in [0, 1] whatever the mesh's uv range.
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

namespace alphorn {

class UVTexture : public Texture {
  public:
    explicit UVTexture(const PropertyList& props) : m_mapping(props) {}

    Color3f eval(const Point2f& uv, const Point3f&) const override {
        const Point2f m = m_mapping.map(uv);
        return Color3f(m.x() - std::floor(m.x()), m.y() - std::floor(m.y()), 0.0f);
    }
    bool is3D() const override { return false; }
    Color3f lowerBound() const override { return Color3f(0.0f); }
    Color3f upperBound() const override { return Color3f(1.0f, 1.0f, 0.0f); }
    std::string toString() const override { return "uv"; }

  private:
    UVMapping m_mapping;
};

ALPHORN_REGISTER(Texture, "uv", UVTexture);

}  // namespace alphorn
