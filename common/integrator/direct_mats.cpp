// <integrator type="direct_mats">: direct illumination by BSDF ("material") sampling (Nori's).
// Emission seen by the camera plus one BSDF-sampled ray whose emission, if it hits a light, is
// weighted by the sample weight. Delta lights (point) cannot be reached this way and stay dark.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class DirectMats : public Integrator {
  public:
    explicit DirectMats(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return Color3f(0.0f);
        const Vector3f dir = ray.d.normalized();
        Color3f result = emittedRadiance(ray.o, dir, its);

        BSDFQueryRecord bRec = makeBSDFQuery(its, its.toLocal(-dir));
        const Color3f weight = its.mesh->bsdf()->sample(bRec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) return result;
        const Ray3f next(its.p, its.toWorld(bRec.wo));
        Intersection lightIts;
        if (!scene.rayIntersect(next, lightIts)) return result;
        return result + weight * emittedRadiance(next.o, next.d, lightIts);
    }

    std::string toString() const override { return "direct_mats integrator"; }
};

ALPHORN_REGISTER(Integrator, "direct_mats", DirectMats);

}  // namespace alphorn
