// Cameras turn an image-plane position (in pixels) and an aperture sample into a primary ray.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"
#include "common/core/ray.h"
#include "common/filter/rfilter.h"

#include <optional>
#include <string>

namespace alphorn {

class Medium;

// Where light tracing sees a world point on the image: its raster position (in pixels, as
// sampleRay() takes it) and the raster area per unit solid angle at the camera there, which
// turns a surface density into the camera's one-sample-per-pixel density.
struct CameraProjection {
    Point2f raster = Point2f::Zero();
    float rasterPerSolidAngle = 0.0f;
    Point3f position = Point3f::Zero();  // the camera's centre of projection, in world space
};

class Camera : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Camera; }

    // samplePosition is in pixels ([0, width] x [0, height]); returns the importance weight.
    virtual Color3f sampleRay(Ray3f& ray, const Point2f& samplePosition,
                              const Point2f& apertureSample) const = 0;

    // Light tracing needs the inverse of sampleRay(). Cameras that can give it exactly return
    // an empty string; others say why not (e.g. a lens with an aperture), and integrators that
    // trace light to the camera refuse the scene with that reason.
    virtual std::string lightTracingRefusal() const {
        return "this camera cannot be reached by light tracing";
    }
    // The projection of `world`, or nothing when no camera ray can reach it (behind the camera,
    // outside the image or the clipping planes). Valid only when lightTracingRefusal() is empty.
    virtual std::optional<CameraProjection> project(const Point3f& /*world*/) const {
        return std::nullopt;
    }

    // The raster area per unit solid angle of camera rays along the world direction `d`: the
    // camera's one-sample-per-pixel density of ray directions. Valid as project().
    virtual float rasterPerSolidAngle(const Vector3f& /*d*/) const { return 0.0f; }

    const Vector2i& outputSize() const { return m_outputSize; }
    const ReconstructionFilter* filter() const { return m_filter.get(); }
    // The medium the camera sits in (a nested <medium>); nullptr is vacuum.
    const Medium* medium() const { return m_medium.get(); }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override;
    // Creates the default gaussian filter when none was given; derived classes call this.
    void activate() override;

  protected:
    Vector2i m_outputSize{1280, 720};
    std::shared_ptr<ReconstructionFilter> m_filter;
    std::shared_ptr<Medium> m_medium;
};

}  // namespace alphorn
