// <emitter type="spotlight">: PBRT v2's spotlight. A delta-position light at toWorld(0, 0, 0)
// shining along toWorld's local +z axis.
//   power         total emitted flux (a colour), required
//   totalAngle    half-angle of the cone outside which it is dark, in degrees, in (0, 180]
//                 (default 30); a cone too narrow for float cosines (below about 0.014
//                 degrees) is refused
//   falloffStart  half-angle up to which the intensity is full, in degrees, in (0, totalAngle]
//                 (default 25)
//   toWorld       position and orientation
//   falloff       "quartic" (default, PBRT v2's) or "smoothstep" (pbrt-v4's)
// Between the cones the intensity falls off as delta^4 with
// delta = (cos theta - cos totalAngle) / (cos falloffStart - cos totalAngle) (quartic in cosine
// space), or as smoothstep(delta) = delta^2 (3 - 2 delta), whose integral over delta is 1/2
// (in place of the quartic's 1/5 below). Integrating over the sphere, the flux of central intensity
// I is 2 pi I [(1 - cos ts) + (cos ts - cos tt) / 5], so I = power / that bracket (the delta^4 term
// integrates to (cos ts - cos tt) / 5 over cos theta).
#include "common/core/frame.h"
#include "common/emitter/delta_light.h"

namespace alphorn {

class SpotLight : public DeltaPositionLight {
  public:
    explicit SpotLight(const PropertyList& props) {
        if (!props.has("power")) props.fail("a spotlight needs a \"power\" colour (total flux)");
        m_power = props.getNonNegativeColor("power", Color3f(0.0f));
        const float totalAngle = props.getFloat("totalAngle", 30.0f);
        const float falloffStart = props.getFloat("falloffStart", 25.0f);
        // Every half-angle up to 180 degrees (a cone wider than a hemisphere) is a cone: the
        // falloff, the flux integral and the photon sampling all work in cos theta in [-1, 1].
        if (!(totalAngle > 0.0f && totalAngle <= 180.0f))
            props.fail("totalAngle must be in (0, 180] degrees, got %g", totalAngle);
        if (!(falloffStart > 0.0f && falloffStart <= 180.0f))
            props.fail("falloffStart must be in (0, 180] degrees, got %g", falloffStart);
        if (falloffStart > totalAngle)
            props.fail("falloffStart (%g degrees) must not exceed totalAngle (%g degrees)",
                       falloffStart, totalAngle);
        const std::string falloffName = props.getString("falloff", "quartic");
        if (falloffName != "quartic" && falloffName != "smoothstep")
            props.fail("falloff must be \"quartic\" or \"smoothstep\", got \"%s\"", falloffName);
        m_smoothstep = falloffName == "smoothstep";
        const Transform toWorld = props.getTransform("toWorld", Transform());
        m_position = toWorld.applyPoint(Point3f::Zero());
        // Directions are compared in a rigid frame, so scaling in toWorld cannot skew the cone.
        const Vector3f axis = toWorld.applyVector(Vector3f::UnitZ());
        if (!(axis.norm() > 0.0f)) props.fail("toWorld collapses the spotlight's axis");
        m_frame = Frame(axis.normalized());

        m_cosTotal = std::cos(degToRad(totalAngle));
        m_cosStart = std::cos(degToRad(falloffStart));
        // Directions are tested against the cone by their float cosine: below about 0.014
        // degrees cos(totalAngle) rounds to 1, the cone holds no direction but the axis itself
        // and the intensity power / (cone's solid angle) is infinite.
        if (!(m_cosTotal < 1.0f))
            props.fail(
                "totalAngle %g degrees is too narrow to render in float precision: its cosine "
                "rounds to 1, so the cone holds no direction (at least about 0.014 degrees)",
                totalAngle);
        // The two parts of the flux integral over cos theta (per 2 pi and per unit intensity).
        m_innerMass = 1.0 - double(m_cosStart);
        m_outerMass = (double(m_cosStart) - double(m_cosTotal)) / (m_smoothstep ? 2.0 : 5.0);
        m_intensity = m_power / static_cast<float>(2.0 * M_PI * (m_innerMass + m_outerMass));
    }

    // The falloff factor for a direction at cos theta from the axis.
    float falloff(float cosTheta) const {
        if (cosTheta >= m_cosStart) return 1.0f;
        if (cosTheta < m_cosTotal) return 0.0f;
        const float delta = (cosTheta - m_cosTotal) / (m_cosStart - m_cosTotal);
        if (m_smoothstep) return delta * delta * (3.0f - 2.0f * delta);
        return (delta * delta) * (delta * delta);
    }

    // Intensity (W/sr) towards the world direction `d` (unit).
    Color3f intensity(const Vector3f& d) const override {
        return m_intensity * falloff(m_frame.n.dot(d));
    }

    Color3f power() const override { return m_power; }

    // Samples directions exactly in proportion to the intensity: cos theta is drawn from the
    // two-part marginal (uniform in the inner cone, density ~ the falloff between the cones,
    // inverted as delta = u^(1/5) for the quartic, by bisection for smoothstep), phi uniformly.
    // Every photon then carries exactly `power`.
    Color3f samplePhoton(Ray3f& ray, const Point2f&, const Point2f& sample) const override {
        const double total = m_innerMass + m_outerMass;
        const double u = double(sample.x()) * total;
        double cosTheta;
        if (u < m_innerMass || m_outerMass == 0.0) {
            cosTheta = 1.0 - u;
        } else {
            const double x = (u - m_innerMass) / m_outerMass;  // in [0, 1)
            const double delta = m_smoothstep ? inverseSmoothstepIntegral(x) : std::pow(x, 0.2);
            cosTheta = double(m_cosTotal) + delta * (double(m_cosStart) - double(m_cosTotal));
        }
        const double sinTheta = std::sqrt(std::max(0.0, 1.0 - cosTheta * cosTheta));
        const double phi = 2.0 * M_PI * double(sample.y());
        const Vector3f local(static_cast<float>(sinTheta * std::cos(phi)),
                             static_cast<float>(sinTheta * std::sin(phi)),
                             static_cast<float>(cosTheta));
        ray = Ray3f(m_position, m_frame.toWorld(local));
        return m_power;
    }

    std::string toString() const override { return "spotlight, power " + m_power.toString(); }

  private:
    // The delta in [0, 1] at which the normalised integral of smoothstep, 2 d^3 - d^4, reaches
    // x: by bisection (the quartic has no handier inverse), to double precision.
    static double inverseSmoothstepIntegral(double x) {
        double low = 0.0, high = 1.0;
        for (int i = 0; i < 60; ++i) {
            const double mid = 0.5 * (low + high);
            const double value = mid * mid * mid * (2.0 - mid);
            (value < x ? low : high) = mid;
        }
        return 0.5 * (low + high);
    }

    Frame m_frame;
    bool m_smoothstep = false;
    Color3f m_power, m_intensity;
    float m_cosTotal, m_cosStart;
    double m_innerMass, m_outerMass;
};

ALPHORN_REGISTER(Emitter, "spotlight", SpotLight);

}  // namespace alphorn
