// Lights at a single point (point, spotlight, projector). A ray never hits them and no other
// strategy can produce their direction, so they are reached only by next-event estimation:
// sample() returns intensity / distance^2 with pdf 1, eval() and pdf() are zero.
#pragma once

#include "common/emitter/emitter.h"

namespace alphorn {

class DeltaPositionLight : public Emitter {
  public:
    Color3f sample(EmitterQueryRecord& rec, const Point2f&) const final {
        rec.aimAt(m_position, Normal3f::Zero());
        const float dist2 = (m_position - rec.ref).squaredNorm();
        // A receiver at the light itself would see infinite irradiance: treat it as no sample.
        if (!(dist2 > 0.0f) || rec.wi.isZero()) {
            rec.pdf = 0.0f;
            return Color3f(0.0f);
        }
        rec.pdf = 1.0f;  // a delta in solid angle: the sample is certain
        const Color3f result = intensity(-rec.wi) / dist2;
        return result.isValid() ? result : Color3f(0.0f);
    }

    Color3f eval(const EmitterQueryRecord&) const final { return Color3f(0.0f); }
    float pdf(const EmitterQueryRecord&) const final { return 0.0f; }
    bool isDelta() const final { return true; }

    // Radiant intensity (W/sr) towards the unit world direction `d`.
    virtual Color3f intensity(const Vector3f& d) const = 0;
    const Point3f& position() const { return m_position; }

  protected:
    Point3f m_position = Point3f::Zero();
};

}  // namespace alphorn
