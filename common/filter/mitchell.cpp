// <rfilter type="mitchell">: the Mitchell-Netravali cubic (Nori's defaults B = C = 1/3,
// radius 2).
#include "common/filter/rfilter.h"

namespace alphorn {

class MitchellNetravaliFilter : public ReconstructionFilter {
  public:
    explicit MitchellNetravaliFilter(const PropertyList& props) {
        m_radius = validatedRadius(props, 2.0f);
        m_B = parameter(props, "B");
        m_C = parameter(props, "C");
        tabulate();
    }
    float eval(float x) const override {
        x = std::abs(2.0f * x / m_radius);
        float x2 = x * x, x3 = x2 * x;
        if (x < 1.0f)
            return 1.0f / 6.0f *
                   ((12 - 9 * m_B - 6 * m_C) * x3 + (-18 + 12 * m_B + 6 * m_C) * x2 +
                    (6 - 2 * m_B));
        if (x < 2.0f)
            return 1.0f / 6.0f *
                   ((-m_B - 6 * m_C) * x3 + (6 * m_B + 30 * m_C) * x2 + (-12 * m_B - 48 * m_C) * x +
                    (8 * m_B + 24 * m_C));
        return 0.0f;
    }

  private:
    // B and C span the family Mitchell and Netravali studied, [0, 1] each (B = 1, C = 0 is the
    // cubic B-spline, B = 0, C = 1/2 Catmull-Rom). Without the check B = NaN rendered an
    // all-1 image and 1e30 a black one.
    static float parameter(const PropertyList& props, const char* name) {
        const float value = props.getFloat(name, 1.0f / 3.0f);
        if (!(value >= 0.0f && value <= 1.0f))
            props.fail("\"%s\" must be in [0, 1], got %g", name, value);
        return value;
    }
    float m_B, m_C;
};

ALPHORN_REGISTER(Filter, "mitchell", MitchellNetravaliFilter);

}  // namespace alphorn
