// <integrator type="whitted">: Nori's Whitted-style ray tracer. Surfaces with a non-delta BSDF
// take one emitter sample; mirror and dielectric surfaces continue along their sampled delta
// direction with probability 0.95 (Russian roulette, dividing by 0.95, so no depth cap biases
// the result). Emission of every surface the path hits is added.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class WhittedIntegrator : public Integrator {
  public:
    explicit WhittedIntegrator(const PropertyList&) {}

    // Nori writes this recursively; a loop with a throughput is the same estimator without the
    // (tiny, but unbounded) risk of a deep stack between two facing mirrors.
    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData*) const override {
        static constexpr float kContinue = 0.95f;
        Color3f result(0.0f), throughput(1.0f);
        Ray3f ray = cameraRay;
        while (true) {
            Intersection its;
            const Vector3f dir = ray.d.normalized();
            if (!scene.rayIntersect(ray, its)) {
                // Camera and delta rays count every emitter they see, environments too.
                result += throughput * escapedRadiance(scene, ray.o, dir);
                break;
            }
            result += throughput * emittedRadiance(ray.o, dir, its);

            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse()) {
                result += throughput * sampleDirect(scene, sampler, its, bsdf, wi, false);
                break;
            }
            if (sampler.next1D() >= kContinue) break;
            BSDFQueryRecord bRec = makeBSDFQuery(its, wi);
            const Color3f weight = bsdf.sample(bRec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            throughput *= weight / kContinue;
            ray = Ray3f(its.p, its.toWorld(bRec.wo));
        }
        return result;
    }

    std::string toString() const override { return "whitted integrator"; }
};

ALPHORN_REGISTER(Integrator, "whitted", WhittedIntegrator);

}  // namespace alphorn
