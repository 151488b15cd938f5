// <rfilter type="box">: every sample within half a pixel counts equally (Nori's).
#include "common/filter/rfilter.h"

namespace alphorn {

class BoxFilter : public ReconstructionFilter {
  public:
    explicit BoxFilter(const PropertyList& props) {
        m_radius = validatedRadius(props, 0.5f);
        tabulate();
    }
    float eval(float x) const override { return std::abs(x) <= m_radius ? 1.0f : 0.0f; }
};

ALPHORN_REGISTER(Filter, "box", BoxFilter);

}  // namespace alphorn
