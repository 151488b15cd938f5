// <integrator type="path_ems">: path tracing with next-event estimation at every vertex with a
// non-delta BSDF. Light reaching such a vertex is counted only by its emitter sample, so
// emission found by the continuation ray is added only on the camera ray and after delta
// (mirror/dielectric) bounces, which NEE cannot handle: direct light is counted exactly once.
// Russian roulette and `maxDepth` as in path_mats.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class PathEms : public Integrator {
  public:
    explicit PathEms(const PropertyList& props) {
        m_maxDepth = props.getInteger("maxDepth", -1);
        if (m_maxDepth < -1) props.fail("\"maxDepth\" must be -1 (unlimited) or >= 0");
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData*) const override {
        Color3f result(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        bool countEmission = true;  // camera ray, or the previous bounce was a delta lobe
        Ray3f ray = cameraRay;
        for (int depth = 0;; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            const Vector3f dir = ray.d.normalized();
            if (countEmission) result += throughput * emittedRadiance(ray.o, dir, its);
            if (m_maxDepth >= 0 && depth >= m_maxDepth) break;

            if (depth >= 3) {
                const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                if (sampler.next1D() >= q) break;
                throughput /= q;
            }

            const BSDF& bsdf = *its.mesh->bsdf();
            const Vector3f wi = its.toLocal(-dir);
            if (bsdf.isDiffuse())
                result += throughput * sampleDirect(scene, sampler, its, bsdf, wi, false);

            BSDFQueryRecord bRec = makeBSDFQuery(its, wi);
            const Color3f weight = bsdf.sample(bRec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            countEmission = bRec.measure == Measure::Discrete;
            throughput *= weight;
            etaScale *= bRec.eta * bRec.eta;
            ray = Ray3f(its.p, its.toWorld(bRec.wo));
        }
        return result;
    }

    std::string toString() const override { return "path_ems integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_ems", PathEms);

}  // namespace alphorn
