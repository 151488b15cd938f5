// <rfilter type="gaussian">: a gaussian shifted to reach zero at the radius (Nori's default
// filter: radius 2, stddev 0.5).
#include "common/filter/rfilter.h"

namespace alphorn {

class GaussianFilter : public ReconstructionFilter {
  public:
    explicit GaussianFilter(const PropertyList& props) {
        m_radius = validatedRadius(props, 2.0f);
        const float stddev = props.getPositiveFloat("stddev", 0.5f);
        m_alpha = -1.0f / (2.0f * stddev * stddev);
        m_valueAtRadius = std::exp(m_alpha * m_radius * m_radius);
    }
    // The same float operations as evaluating both exponentials per call, the constant one
    // done once: every sample evaluates the filter at up to 30 offsets.
    float eval(float x) const override {
        return std::max(0.0f, std::exp(m_alpha * x * x) - m_valueAtRadius);
    }

  private:
    float m_alpha;          // -1 / (2 stddev^2)
    float m_valueAtRadius;  // exp(alpha radius^2), subtracted so the filter ends at zero
};

ALPHORN_REGISTER(Filter, "gaussian", GaussianFilter);

}  // namespace alphorn
