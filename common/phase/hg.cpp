// <phase type="hg">: the Henyey–Greenstein phase function with mean cosine `g`,
//
//     p(cos t) = (1 - g^2) / (4 pi (1 + g^2 - 2 g cos t)^(3/2)),
//
// where t is the angle between the light's direction of travel before (-wi) and after (wo) the
// scattering event: g > 0 scatters forward, g < 0 backward, g = 0 is isotropic. A check of
// the sign: for g = 0.9 a fraction 0.977097 of samples have cos t > 0 (the integral of p over
// the forward hemisphere).
//
// g must lie in the open interval (-1, 1): at |g| = 1 the function is a delta (light passes
// unscattered, which a medium with smaller sigmaS models exactly) and the formula divides 0 by
// 0, so the parser rejects it rather than producing an infinite or NaN image. Values as close as
// +-0.999 work: the peak density (1 + |g|) / (4 pi (1 - |g|)^2) ~ 1.6e5 is still a finite float,
// and sampling inverts the CDF exactly so the sampling weight is exactly 1.
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/phase/phase.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class HenyeyGreenstein : public PhaseFunction {
  public:
    explicit HenyeyGreenstein(const PropertyList& props) {
        m_g = props.getFloat("g", 0.0f);
        if (!(std::abs(m_g) < 1.0f))
            props.fail("g must be in the open interval (-1, 1), got %g (|g| = 1 is a delta)", m_g);
    }

    float sample(const Vector3f& wi, Vector3f& wo, const Point2f& sample) const override {
        const float cosTheta = sampleCosTheta(sample.x());
        const float sinTheta = safeSqrt(1.0f - cosTheta * cosTheta);
        const float phi = 2.0f * Pi * sample.y();
        // The frame's axis is the direction of travel, -wi.
        const Frame frame(Vector3f(-wi));
        wo = frame.toWorld(Vector3f(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta));
        return 1.0f;
    }

    float eval(const Vector3f& wi, const Vector3f& wo) const override {
        return density(clamp(-wi.dot(wo), -1.0f, 1.0f));
    }
    float pdf(const Vector3f& wi, const Vector3f& wo) const override { return eval(wi, wo); }

    float g() const { return m_g; }
    std::string toString() const override {
        return absl::StrFormat("Henyey-Greenstein phase function, g = %g", m_g);
    }

  private:
    // In double: near |g| = 1 the denominator (1 - g)^2 ~ 1e-6 is a difference of numbers ~ 2,
    // which float would get wrong by ~10%.
    float density(float cosTheta) const {
        const double g = m_g;
        const double denominator = 1.0 + g * g - 2.0 * g * cosTheta;
        return static_cast<float>(0.25 / M_PI * (1.0 - g * g) /
                                  (denominator * std::sqrt(denominator)));
    }

    // Inverts the CDF of cos t. The textbook form (1 + g^2 - term^2) / (2g) divides a rounding
    // error by g and breaks down for small |g|; multiplied out with s = 2u - 1 it becomes
    //     cos t = (s + g (3 + s^2 + 2gs + g^2 s^2 - g^2) / 2) / (1 + gs)^2,
    // which is exact at g = 0 (isotropic) and stable for every g in (-1, 1). Double precision
    // keeps the cancellation near |g| -> 1 harmless.
    float sampleCosTheta(float u) const {
        const double g = m_g, s = 2.0 * double(u) - 1.0;
        const double denominator = (1.0 + g * s) * (1.0 + g * s);
        const double cosTheta =
            (s + 0.5 * g * (3.0 + s * s + 2.0 * g * s + g * g * s * s - g * g)) / denominator;
        return clamp(static_cast<float>(cosTheta), -1.0f, 1.0f);
    }

    float m_g;
};

ALPHORN_REGISTER(PhaseFunction, "hg", HenyeyGreenstein);

}  // namespace alphorn
