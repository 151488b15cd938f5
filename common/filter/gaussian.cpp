// <rfilter type="gaussian">: a gaussian shifted to reach zero at the radius (Nori's default
// filter: radius 2, stddev 0.5).
#include "common/filter/rfilter.h"

namespace alphorn {

class GaussianFilter : public ReconstructionFilter {
  public:
    explicit GaussianFilter(const PropertyList& props) {
        m_radius = validatedRadius(props, 2.0f);
        const float stddev = props.getPositiveFloat("stddev", 0.5f);
        // Narrower, samples far from a pixel centre weigh less than the film's fixed-point
        // resolution (2^-40 = 9e-13) and are lost: at 0.1, half a pixel off along both axes
        // weighs exp(-0.5^2 / (2 * 0.1^2))^2 = 1.4e-11 before the shift to zero at the radius;
        // at 1e-30 every weight vanished (a black image).
        if (stddev < kMinStddev)
            props.fail("\"stddev\" %g is too small (at least %g pixels)", stddev, kMinStddev);
        // Wider, the weights are differences of numbers within 1/200 of 1 and lose their
        // precision (the shape tends to a parabola, which a wider gaussian only approaches); at
        // 1e30 every weight was 0 (a black image).
        if (stddev > kMaxStddevPerRadius * m_radius)
            props.fail("\"stddev\" %g is too large (at most %g times the radius %g)", stddev,
                       kMaxStddevPerRadius, m_radius);
        m_alpha = -1.0f / (2.0f * stddev * stddev);
        m_valueAtRadius = std::exp(m_alpha * m_radius * m_radius);
        tabulate();
    }
    // The constant exponential is computed once.
    float eval(float x) const override {
        return std::max(0.0f, std::exp(m_alpha * x * x) - m_valueAtRadius);
    }

  private:
    static constexpr float kMinStddev = 0.1f;
    static constexpr float kMaxStddevPerRadius = 10.0f;
    float m_alpha;          // -1 / (2 stddev^2)
    float m_valueAtRadius;  // exp(alpha radius^2), subtracted so the filter ends at zero
};

ALPHORN_REGISTER(Filter, "gaussian", GaussianFilter);

}  // namespace alphorn
