// <integrator type="ao">: ambient occlusion (Nori's). The estimator of
// (1/pi) * integral of V(x, w) cos(theta) dw with one cosine-distributed direction is just the
// visibility of that direction: 1 when unoccluded within `length`, else 0. Misses are black.
#include "common/core/warp.h"
#include "common/integrator/integrator.h"
#include "common/sampler/sampler.h"
#include "common/scene/scene.h"

namespace alphorn {

class AmbientOcclusion : public Integrator {
  public:
    explicit AmbientOcclusion(const PropertyList& props) {
        // Infinite by default (Nori's); a finite length gives the usual local "dirt" look.
        m_length = props.getFloat("length", Infinity);
        if (!(m_length > 0.0f)) props.fail("\"length\" must be positive, got %g", m_length);
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return Color3f(0.0f);
        const Vector3f local = warp::squareToCosineHemisphere(sampler.next2D());
        const Ray3f probe(its.p, its.shFrame.toWorld(local), Epsilon, m_length);
        return scene.rayOccluded(probe) ? Color3f(0.0f) : Color3f(1.0f);
    }

    std::string toString() const override { return "ambient occlusion"; }

  private:
    float m_length;
};

ALPHORN_REGISTER(Integrator, "ao", AmbientOcclusion);

}  // namespace alphorn
