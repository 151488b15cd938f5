// <rfilter type="tent">: a linear falloff over one pixel (Nori's; radius fixed at 1).
#include "common/filter/rfilter.h"

namespace alphorn {

class TentFilter : public ReconstructionFilter {
  public:
    explicit TentFilter(const PropertyList&) {
        m_radius = 1.0f;
        tabulate();
    }
    float eval(float x) const override { return std::max(0.0f, 1.0f - std::abs(x)); }
};

ALPHORN_REGISTER(Filter, "tent", TentFilter);

}  // namespace alphorn
