// <camera type="physical">: a thin-lens camera. Every parameter of `perspective` (width,
// height, fov, toWorld, nearClip, farClip), plus
//   apertureRadius  radius of the lens disk, in scene units (default 0: a pinhole)
//   focalDistance   distance from the lens plane to the plane in focus, along the view axis
//                   (default 10)
// The ray origin is a point on the lens disk (the concentric map of the aperture sample) and
// the ray passes through the point of the focal plane that the pinhole ray through the same
// image position reaches. A point at depth Z then blurs into a disk of radius
// apertureRadius |1/Z - 1/focalDistance| in tangent-space image units.
#include "common/camera/camera.h"
#include "common/camera/pinhole.h"
#include "common/core/warp.h"

namespace alphorn {

class PhysicalCamera : public Camera {
  public:
    explicit PhysicalCamera(const PropertyList& props) : m_projection(props, m_outputSize) {
        m_apertureRadius = props.getNonNegativeFloat("apertureRadius", 0.0f);
        m_focalDistance = props.getPositiveFloat("focalDistance", 10.0f);
        // Rays leave from the lens: beyond 1e15 Embree could not trace them.
        if (!(m_apertureRadius <= 1e15f) || !(m_focalDistance <= 1e15f))
            props.fail("apertureRadius and focalDistance must be at most 1e15");
    }

    Color3f sampleRay(Ray3f& ray, const Point2f& samplePosition,
                      const Point2f& apertureSample) const override {
        const Vector3f d = m_projection.direction(samplePosition);
        // A zero aperture is exactly the pinhole ray (not a recomputed, rounded copy of it).
        if (m_apertureRadius == 0.0f) {
            m_projection.makeRay(ray, Point3f::Zero(), d);
            return Color3f(1.0f);
        }
        const Point2f lens = m_apertureRadius * warp::squareToUniformDisk(apertureSample);
        const Point3f origin(lens.x(), lens.y(), 0.0f);
        const Point3f focus = d * (m_focalDistance / d.z());
        m_projection.makeRay(ray, origin, (focus - origin).normalized());
        return Color3f(1.0f);
    }

    // Light tracing through a lens would need the lens's importance and a second sample of the
    // aperture per connection; only the pinhole case (apertureRadius 0) is supported.
    std::string lightTracingRefusal() const override {
        if (m_apertureRadius > 0.0f)
            return "light tracing supports the physical camera only as a pinhole (apertureRadius "
                   "0), got apertureRadius " +
                   std::to_string(m_apertureRadius);
        return m_projection.lightTracingRefusal();
    }
    std::optional<CameraProjection> project(const Point3f& world) const override {
        return m_projection.project(world);
    }
    float rasterPerSolidAngle(const Vector3f& d) const override {
        return m_projection.rasterPerSolidAngle(d);
    }

    std::string toString() const override { return "physical (thin lens) camera"; }

  private:
    PinholeProjection m_projection;
    float m_apertureRadius, m_focalDistance;
};

ALPHORN_REGISTER(Camera, "physical", PhysicalCamera);

}  // namespace alphorn
