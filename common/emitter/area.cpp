// <emitter type="area">: a mesh that emits constant `radiance` (Nori's area light). Emission is
// one-sided, only towards the side the shading normal points to, unless `twoSided` (pbrt-v4's
// twosided area lights) makes both sides emit. Light sampling picks points
// uniformly by area and converts the density to solid angle at the receiving point.
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/emitter/emitter.h"
#include "common/scene/mesh.h"

namespace alphorn {

class AreaLight : public Emitter {
  public:
    explicit AreaLight(const PropertyList& props) {
        m_radiance = props.getNonNegativeColor("radiance", Color3f(0.0f));
        if (!props.has("radiance")) props.fail("an area emitter needs a \"radiance\" colour");
        m_twoSided = props.getBoolean("twoSided", false);
    }

    Color3f eval(const EmitterQueryRecord& rec) const override {
        // rec.wi points from the receiver to the light, so the light faces it when n.wi < 0.
        return m_twoSided || rec.n.dot(rec.wi) < 0.0f ? m_radiance : Color3f(0.0f);
    }

    float pdf(const EmitterQueryRecord& rec) const override {
        const float cosLight = m_twoSided ? std::abs(rec.n.dot(rec.wi)) : -rec.n.dot(rec.wi);
        // The back side is never sampled (sample() returns zero there), so its density is zero:
        // this keeps MIS weights of both strategies consistent.
        if (!(cosLight > 0.0f)) return 0.0f;
        const float dist2 = (rec.p - rec.ref).squaredNorm();
        const float pdf = dist2 / (cosLight * m_mesh->surfaceArea());
        return std::isfinite(pdf) ? pdf : 0.0f;
    }

    Color3f sample(EmitterQueryRecord& rec, const Point2f& sample) const override {
        const SurfaceSample s = m_mesh->sampleSurface(sample);
        rec.aimAt(s.p, s.n);
        rec.pdf = pdf(rec);
        // Zero when the point faces away, coincides with ref, or is seen exactly edge-on.
        if (!(rec.pdf > 0.0f) || rec.wi.isZero()) {
            rec.pdf = 0.0f;
            return Color3f(0.0f);
        }
        return eval(rec) / rec.pdf;
    }

    // The scene asks every emitter for its power when it activates, which makes this the
    // first place that can tell an area light was not nested in a mesh (children activate
    // before they are attached to their parent).
    Color3f power() const override {
        if (!m_mesh) fail("an area emitter must be nested in a <mesh>");
        return (m_twoSided ? 2.0f : 1.0f) * Pi * m_mesh->surfaceArea() * m_radiance;
    }

    Color3f samplePhoton(Ray3f& ray, const Point2f& positionSample,
                         const Point2f& directionSample) const override {
        // Uniform position (density 1/A) and cosine-weighted direction (density cos/pi): the
        // flux L cos / (pdfA pdfW) = pi A L is the same for every photon.
        // A two-sided light picks its side with the first direction number, reused.
        const SurfaceSample s = m_mesh->sampleSurface(positionSample);
        Point2f direction = directionSample;
        Normal3f n = s.n;
        if (m_twoSided) {
            const bool back = direction.x() >= 0.5f;
            direction.x() = std::min(2.0f * direction.x() - (back ? 1.0f : 0.0f), 0x1.fffffep-1f);
            if (back) n = -n;
        }
        const Vector3f local = warp::squareToCosineHemisphere(direction);
        ray = Ray3f(s.p, Frame(n).toWorld(local));
        return power();
    }

    std::string toString() const override {
        return std::string(m_twoSided ? "two-sided " : "") + "area light, radiance " +
               m_radiance.toString();
    }

  private:
    Color3f m_radiance;
    bool m_twoSided = false;
};

ALPHORN_REGISTER(Emitter, "area", AreaLight);

}  // namespace alphorn
