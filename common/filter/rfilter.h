// Pixel reconstruction filters (Nori's). A sample at image position x contributes to every pixel
// whose centre lies within radius(); the 2D weight is eval(dx) * eval(dy). eval's magnitude is
// at most 1 (every filter here peaks at 1 or below): the film rounds the taps of most samples
// through 64-bit integers (film.cpp) and relies on it.
#pragma once

#include "common/core/object.h"

namespace alphorn {

class ReconstructionFilter : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Filter; }
    float radius() const { return m_radius; }
    virtual float eval(float x) const = 0;

    static constexpr float kMinRadius = 0.5f;
    static constexpr float kMaxRadius = 7.0f;

  protected:
    static float validatedRadius(const PropertyList& props, float defaultRadius);
    float m_radius = 0.5f;
};

}  // namespace alphorn
