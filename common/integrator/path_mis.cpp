// <integrator type="path_mis">: path tracing with multiple importance sampling (Nori's). At every
// vertex with a non-delta BSDF, one emitter sample and the continuation BSDF sample both look
// for direct light, combined by the balance heuristic (light selection included in the emitter
// density). Delta lights are reached only by the emitter sample (weight 1); after a delta BSDF
// bounce, or on the camera ray, emission hit by the path counts fully. Russian roulette and
// `maxDepth` as in path_mats.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class PathMis : public Integrator {
  public:
    explicit PathMis(const PropertyList& props) {
        m_maxDepth = props.getInteger("maxDepth", -1);
        if (m_maxDepth < -1) props.fail("\"maxDepth\" must be -1 (unlimited) or >= 0");
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData*) const override {
        Color3f result(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        // Density of the BSDF sample that produced `ray`; negative for the camera ray and for
        // delta bounces, whose emission hits are not shared with emitter sampling.
        float bsdfPdf = -1.0f;
        Ray3f ray = cameraRay;
        for (int depth = 0;; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            const Vector3f dir = ray.d.normalized();
            const Color3f le = emittedRadiance(ray.o, dir, its);
            if (!le.isBlack()) {
                const float w =
                    bsdfPdf < 0.0f
                        ? 1.0f
                        : balanceHeuristic(bsdfPdf, emitterSamplingPdf(scene, ray.o, dir, its));
                result += throughput * le * w;
            }
            if (m_maxDepth >= 0 && depth >= m_maxDepth) break;

            if (depth >= 3) {
                const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                if (sampler.next1D() >= q) break;
                throughput /= q;
            }

            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse())
                result += throughput * sampleDirect(scene, sampler, its, bsdf, wi, true);

            BSDFQueryRecord bRec = makeBSDFQuery(its, wi);
            const Color3f weight = bsdf.sample(bRec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            bsdfPdf = bRec.measure == Measure::Discrete ? -1.0f : bsdf.pdf(bRec);
            throughput *= weight;
            etaScale *= bRec.eta * bRec.eta;
            ray = Ray3f(its.p, its.toWorld(bRec.wo));
        }
        return result;
    }

    std::string toString() const override { return "path_mis integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_mis", PathMis);

}  // namespace alphorn
