// The pinhole projection shared by the `perspective` and `physical` cameras (Nori's
// perspective model): parameters, the image-to-camera mapping and the clipping of rays. Both
// cameras go through this one code path, which is what makes a `physical` camera with
// apertureRadius 0 render the pinhole image byte for byte.
#pragma once

#include "common/camera/camera.h"
#include "common/core/properties.h"

#include <absl/strings/str_format.h>

#include <optional>
#include <string>

namespace alphorn {

class PinholeProjection {
  public:
    PinholeProjection() = default;
    // Reads width, height, toWorld, fov, nearClip, farClip (Nori's defaults) into `outputSize`
    // and this projection.
    PinholeProjection(const PropertyList& props, Vector2i& outputSize) {
        outputSize.x() = props.getPositiveInteger("width", 1280);
        outputSize.y() = props.getPositiveInteger("height", 720);
        if (outputSize.x() > 16384 || outputSize.y() > 16384)
            props.fail("image size %dx%d is too large (at most 16384 per side)", outputSize.x(),
                       outputSize.y());
        m_cameraToWorld = props.getTransform("toWorld", Transform());
        m_fov = props.getFloat("fov", 30.0f);
        // Any angle strictly between 0 and 180 degrees is a field of view (NaN and inf are
        // not); how narrow float precision lets it be is checked below, on the mapping itself.
        if (!(m_fov > 0.0f && m_fov < 180.0f))
            props.fail("fov must be in (0, 180) degrees, got %g", m_fov);
        m_nearClip = props.getPositiveFloat("nearClip", 1e-4f);
        m_farClip = props.getPositiveFloat("farClip", 1e4f);
        if (!(m_farClip > m_nearClip)) props.fail("farClip must be greater than nearClip");
        // A ray's direction is its point on the near plane, normalised: below this the point's
        // squared length is no normal float (below 3.7e-23 it is 0, the direction stays that
        // tiny point, and the image is black).
        if (m_nearClip < kMinNearClip)
            props.fail("nearClip %g is too small (at least %g)", m_nearClip, kMinNearClip);
        // The projection matrix holds nearClip * farClip; beyond the float range it is infinite
        // and every ray NaN (a black image).
        if (!std::isfinite(m_nearClip * m_farClip))
            props.fail(
                "nearClip * farClip (%g * %g) exceeds the float range; give a smaller farClip",
                m_nearClip, m_farClip);
        m_outputSize = outputSize;
        precompute();
        // A narrow fov is a telephoto lens, and Nori's test files use fov 1e-6 to send every
        // sample along the view axis. The mapping holds cot = 1 / tan(fov / 2): below about
        // 3.4e-37 degrees it exceeds the float range and every ray would be NaN.
        if (!mapsToRays())
            props.fail(
                "fov %g degrees is too narrow to render in float precision: the image-to-ray "
                "mapping holds 1 / tan(fov / 2) = %g, beyond the float range (the narrowest fov "
                "that renders is about 3.4e-37 degrees)",
                m_fov, 1.0 / std::tan(double(degToRad(m_fov / 2.0f))));
    }

    // Why light tracing cannot project onto this image, or "" when it can.
    std::string lightTracingRefusal() const {
        if (!isRigid()) return "the camera's toWorld scales or shears";
        // Light tracing weighs a splat by the raster area per solid angle, width^2 cot^2 / 4 on
        // the axis, which overflows for a very narrow fov on a large image (rendering without
        // light tracing is unaffected).
        if (!std::isfinite(m_rasterPerPlaneArea))
            return absl::StrFormat(
                "the fov %g degrees is too narrow for light tracing on a %dx%d image: the raster "
                "area per solid angle exceeds the float range",
                m_fov, m_outputSize.x(), m_outputSize.y());
        return "";
    }

    // The unit direction, in camera space (looking along +z), of the pinhole ray through
    // `samplePosition` (in pixels).
    Vector3f direction(const Point2f& samplePosition) const {
        const Point3f nearP =
            m_sampleToCamera.applyPoint(Point3f(samplePosition.x() * m_invOutputSize.x(),
                                                samplePosition.y() * m_invOutputSize.y(), 0.0f));
        return nearP.normalized();
    }

    // The world ray from the camera-space `origin` (on the lens plane z = 0) along the
    // camera-space unit direction `d`, clipped to the near and far planes.
    void makeRay(Ray3f& ray, const Point3f& origin, const Vector3f& d) const {
        const float invZ = 1.0f / d.z();
        ray.o = m_cameraToWorld.applyPoint(origin);
        ray.d = m_cameraToWorld.applyVector(d);
        ray.mint = m_nearClip * invZ;
        ray.maxt = m_farClip * invZ;
    }

    // The inverse of direction() and makeRay() for a pinhole at the origin of the lens plane:
    // where the world point lands on the image, or nothing when it lies behind the camera,
    // outside the near/far range or outside the image. Valid when lightTracingRefusal() is
    // empty: it needs a rigid toWorld, since the raster density is computed in camera space.
    std::optional<CameraProjection> project(const Point3f& world) const {
        const Point3f local = m_worldToCamera.applyPoint(world);
        if (!(local.z() >= m_nearClip && local.z() <= m_farClip)) return std::nullopt;
        const float x = local.x() / local.z(), y = local.y() / local.z();
        // direction() maps image u in [0, 1] to x = (1 - 2u) / cot and v in [0, 1] to
        // y = (1 - 2v) / (aspect cot).
        const float u = 0.5f * (1.0f - m_cot * x);
        const float v = 0.5f * (1.0f - m_aspect * m_cot * y);
        if (!(u >= 0.0f && u <= 1.0f && v >= 0.0f && v <= 1.0f)) return std::nullopt;
        CameraProjection result;
        result.raster = Point2f(u * m_outputSize.x(), v * m_outputSize.y());
        const float cosTheta = local.z() / local.norm();
        // dRaster/d(x, y) on the plane z = 1 is (W cot / 2)(H aspect cot / 2); the plane's area
        // per solid angle is 1 / cos^3.
        result.rasterPerSolidAngle = m_rasterPerPlaneArea / (cosTheta * cosTheta * cosTheta);
        result.position = m_cameraToWorld.applyPoint(Point3f::Zero());
        return result;
    }

    float rasterPerSolidAngle(const Vector3f& worldDirection) const {
        const Vector3f local = m_worldToCamera.applyVector(worldDirection).normalized();
        const float cosTheta = local.z();
        if (!(cosTheta > 0.0f)) return 0.0f;
        return m_rasterPerPlaneArea / (cosTheta * cosTheta * cosTheta);
    }

    // Whether toWorld is a rotation and translation (lookat), which project() assumes.
    bool isRigid() const {
        const Matrix3f m = m_cameraToWorld.matrix().topLeftCorner<3, 3>();
        return (m.transpose() * m - Matrix3f::Identity()).cwiseAbs().maxCoeff() < 1e-4f;
    }

    const Transform& cameraToWorld() const { return m_cameraToWorld; }
    float fov() const { return m_fov; }

  private:
    // Precomputes the image-to-camera mapping (Nori's).
    void precompute() {
        const float aspect = m_outputSize.x() / static_cast<float>(m_outputSize.y());
        const float recip = 1.0f / (m_farClip - m_nearClip);
        const float cot = 1.0f / std::tan(degToRad(m_fov / 2.0f));
        Matrix4f perspective;
        perspective << cot, 0, 0, 0, 0, cot, 0, 0, 0, 0, m_farClip * recip,
            -m_nearClip * m_farClip * recip, 0, 0, 1, 0;
        // Maps [0,1]^2 image coordinates to the near plane in camera space.
        Eigen::Affine3f toSample =
            Eigen::DiagonalMatrix<float, 3>(Vector3f(-0.5f, -0.5f * aspect, 1.0f)) *
            Eigen::Translation3f(-1.0f, -1.0f / aspect, 0.0f);
        m_sampleToCamera = Transform(toSample.matrix() * perspective).inverse();
        m_invOutputSize = Vector2f(1.0f / m_outputSize.x(), 1.0f / m_outputSize.y());
        m_worldToCamera = m_cameraToWorld.inverse();
        m_cot = cot;
        m_aspect = aspect;
        m_rasterPerPlaneArea = 0.25f * m_outputSize.x() * m_outputSize.y() * aspect * cot * cot;
    }

    // Whether the rays through the image's corners and centre are unit vectors looking
    // forwards (finite and z > 0), which they all are when the mapping is finite.
    bool mapsToRays() const {
        if (!m_sampleToCamera.matrix().allFinite()) return false;
        const Vector2f size = m_outputSize.cast<float>();
        for (const Point2f& raster :
             {Point2f(0.0f, 0.0f), Point2f(size.x(), 0.0f), Point2f(0.0f, size.y()), Point2f(size),
              Point2f(0.5f * size)}) {
            const Vector3f d = direction(raster);
            if (!d.allFinite() || !(d.z() > 0.0f) || !(std::abs(d.norm() - 1.0f) < 1e-5f))
                return false;
        }
        return true;
    }

    static constexpr float kMinNearClip = 1e-18f;
    Transform m_sampleToCamera, m_cameraToWorld, m_worldToCamera;
    float m_cot = 1.0f, m_aspect = 1.0f, m_rasterPerPlaneArea = 1.0f;
    Vector2i m_outputSize{1280, 720};
    Vector2f m_invOutputSize;
    float m_fov = 30.0f, m_nearClip = 1e-4f, m_farClip = 1e4f;
};

}  // namespace alphorn
