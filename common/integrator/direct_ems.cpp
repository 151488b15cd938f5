// <integrator type="direct_ems">: direct illumination by emitter sampling (Nori's). Emission
// seen by the camera (environment lights included) plus one next-event estimate from a uniformly
// chosen emitter. Surfaces with
// only delta lobes (mirror, dielectric) receive no direct light under this strategy.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class DirectEms : public Integrator {
  public:
    explicit DirectEms(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        Intersection its;
        const Vector3f dir = ray.d.normalized();
        if (!scene.rayIntersect(ray, its)) return escapedRadiance(scene, ray.o, dir);
        Color3f result = emittedRadiance(ray.o, dir, its);
        const BSDF& bsdf = *its.mesh->bsdf();
        if (bsdf.isDiffuse())
            result += sampleDirect(scene, sampler, its, bsdf, its.toLocal(-dir), false);
        return result;
    }

    std::string toString() const override { return "direct_ems integrator"; }
};

ALPHORN_REGISTER(Integrator, "direct_ems", DirectEms);

}  // namespace alphorn
