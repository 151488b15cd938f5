// <rfilter type="gaussian">: a gaussian shifted to reach zero at the radius (Nori's default
// filter: radius 2, stddev 0.5).
#include "common/filter/rfilter.h"

namespace alphorn {

class GaussianFilter : public ReconstructionFilter {
  public:
    explicit GaussianFilter(const PropertyList& props) {
        m_radius = validatedRadius(props, 2.0f);
        m_stddev = props.getPositiveFloat("stddev", 0.5f);
    }
    float eval(float x) const override {
        float alpha = -1.0f / (2.0f * m_stddev * m_stddev);
        return std::max(0.0f, std::exp(alpha * x * x) - std::exp(alpha * m_radius * m_radius));
    }

  private:
    float m_stddev;
};

ALPHORN_REGISTER(Filter, "gaussian", GaussianFilter);

}  // namespace alphorn
