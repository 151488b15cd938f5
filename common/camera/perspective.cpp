// <camera type="perspective">: a pinhole camera (Nori's), looking along +z in its local frame,
// with a horizontal field of view `fov` in degrees. The projection lives in pinhole.h, shared
// with the thin-lens `physical` camera.
#include "common/camera/camera.h"
#include "common/camera/pinhole.h"

namespace alphorn {

class PerspectiveCamera : public Camera {
  public:
    explicit PerspectiveCamera(const PropertyList& props) : m_projection(props, m_outputSize) {}

    Color3f sampleRay(Ray3f& ray, const Point2f& samplePosition, const Point2f&) const override {
        m_projection.makeRay(ray, Point3f::Zero(), m_projection.direction(samplePosition));
        return Color3f(1.0f);
    }

    std::string lightTracingRefusal() const override { return m_projection.lightTracingRefusal(); }
    std::optional<CameraProjection> project(const Point3f& world) const override {
        return m_projection.project(world);
    }
    float rasterPerSolidAngle(const Vector3f& d) const override {
        return m_projection.rasterPerSolidAngle(d);
    }

    std::string toString() const override { return "perspective camera"; }

  private:
    PinholeProjection m_projection;
};

ALPHORN_REGISTER(Camera, "perspective", PerspectiveCamera);

}  // namespace alphorn
