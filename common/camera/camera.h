// Cameras turn an image-plane position (in pixels) and an aperture sample into a primary ray.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"
#include "common/core/ray.h"
#include "common/filter/rfilter.h"

namespace alphorn {

class Medium;

class Camera : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Camera; }

    // samplePosition is in pixels ([0, width] x [0, height]); returns the importance weight.
    virtual Color3f sampleRay(Ray3f& ray, const Point2f& samplePosition,
                              const Point2f& apertureSample) const = 0;

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
