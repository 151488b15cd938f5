// <texture type="constant">: the same `value` everywhere (default 1). Mostly useful inside a
// `combination` or as a medium density.
#include "common/texture/texture.h"

namespace alphorn {

class ConstantTexture : public Texture {
  public:
    explicit ConstantTexture(const PropertyList& props) {
        m_value = props.getColor("value", Color3f(1.0f));
        if (!m_value.allFinite()) props.fail("value must be finite");
    }

    Color3f eval(const Point2f&, const Point3f&) const override { return m_value; }
    bool is3D() const override { return true; }
    Color3f lowerBound() const override { return m_value; }
    Color3f upperBound() const override { return m_value; }
    std::string toString() const override { return "constant " + m_value.toString(); }

  private:
    Color3f m_value;
};

ALPHORN_REGISTER(Texture, "constant", ConstantTexture);

}  // namespace alphorn
