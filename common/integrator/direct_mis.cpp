// <integrator type="direct_mis">: direct illumination combining one emitter sample and one BSDF
// sample with the balance heuristic (Nori's). Each strategy's weight uses both densities, light
// selection included. Delta lights keep weight 1 on the emitter side and delta BSDF samples keep
// weight 1 on the BSDF side, since the other strategy cannot produce them.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class DirectMis : public Integrator {
  public:
    explicit DirectMis(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return Color3f(0.0f);
        const Vector3f dir = ray.d.normalized();
        Color3f result = emittedRadiance(ray.o, dir, its);
        const BSDF& bsdf = *its.mesh->bsdf();
        const Vector3f wi = its.toLocal(-dir);
        if (bsdf.isDiffuse()) result += sampleDirect(scene, sampler, its, bsdf, wi, true);

        BSDFQueryRecord bRec = makeBSDFQuery(its, wi);
        const Color3f weight = bsdf.sample(bRec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) return result;
        const Ray3f next(its.p, its.toWorld(bRec.wo));
        Intersection lightIts;
        if (!scene.rayIntersect(next, lightIts)) return result;
        const Color3f le = emittedRadiance(next.o, next.d, lightIts);
        if (le.isBlack()) return result;
        float w = 1.0f;
        if (bRec.measure != Measure::Discrete)
            w = balanceHeuristic(bsdf.pdf(bRec),
                                 emitterSamplingPdf(scene, next.o, next.d, lightIts));
        return result + weight * le * w;
    }

    std::string toString() const override { return "direct_mis integrator"; }
};

ALPHORN_REGISTER(Integrator, "direct_mis", DirectMis);

}  // namespace alphorn
