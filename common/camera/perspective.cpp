// <camera type="perspective">: a pinhole camera (Nori's), looking along +z in its local frame,
// with a horizontal field of view `fov` in degrees.
#include "common/camera/camera.h"
#include "common/core/transform.h"

namespace alphorn {

class PerspectiveCamera : public Camera {
public:
    explicit PerspectiveCamera(const PropertyList& props) {
        m_outputSize.x() = props.getPositiveInteger("width", 1280);
        m_outputSize.y() = props.getPositiveInteger("height", 720);
        if (m_outputSize.x() > 16384 || m_outputSize.y() > 16384)
            props.fail("image size %dx%d is too large (at most 16384 per side)", m_outputSize.x(),
                       m_outputSize.y());
        m_cameraToWorld = props.getTransform("toWorld", Transform());
        m_fov = props.getFloat("fov", 30.0f);
        if (!(m_fov > 0.0f && m_fov < 180.0f)) props.fail("fov must be in (0, 180) degrees, got %g", m_fov);
        m_nearClip = props.getPositiveFloat("nearClip", 1e-4f);
        m_farClip = props.getPositiveFloat("farClip", 1e4f);
        if (!(m_farClip > m_nearClip)) props.fail("farClip must be greater than nearClip");
    }

    void activate() override {
        Camera::activate();
        const float aspect = m_outputSize.x() / static_cast<float>(m_outputSize.y());
        const float recip = 1.0f / (m_farClip - m_nearClip);
        const float cot = 1.0f / std::tan(degToRad(m_fov / 2.0f));
        Matrix4f perspective;
        perspective << cot, 0, 0, 0, 0, cot, 0, 0, 0, 0, m_farClip * recip,
            -m_nearClip * m_farClip * recip, 0, 0, 1, 0;
        // Maps [0,1]^2 image coordinates to the near plane in camera space (Nori's).
        Eigen::Affine3f toSample = Eigen::DiagonalMatrix<float, 3>(Vector3f(-0.5f, -0.5f * aspect, 1.0f)) *
                                   Eigen::Translation3f(-1.0f, -1.0f / aspect, 0.0f);
        m_sampleToCamera = Transform(toSample.matrix() * perspective).inverse();
        m_invOutputSize = Vector2f(1.0f / m_outputSize.x(), 1.0f / m_outputSize.y());
    }

    Color3f sampleRay(Ray3f& ray, const Point2f& samplePosition, const Point2f&) const override {
        const Point3f nearP = m_sampleToCamera.applyPoint(
            Point3f(samplePosition.x() * m_invOutputSize.x(), samplePosition.y() * m_invOutputSize.y(), 0.0f));
        const Vector3f d = nearP.normalized();
        const float invZ = 1.0f / d.z();
        ray.o = m_cameraToWorld.applyPoint(Point3f::Zero());
        ray.d = m_cameraToWorld.applyVector(d);
        ray.mint = m_nearClip * invZ;
        ray.maxt = m_farClip * invZ;
        return Color3f(1.0f);
    }

    std::string toString() const override { return "perspective camera"; }

private:
    Transform m_sampleToCamera, m_cameraToWorld;
    Vector2f m_invOutputSize;
    float m_fov, m_nearClip, m_farClip;
};

ALPHORN_REGISTER(Camera, "perspective", PerspectiveCamera);

}  // namespace alphorn
