// <integrator type="path_mats">: unidirectional path tracing by BSDF sampling only (Nori's).
// Emission is added wherever the path hits a light. Paths end by Russian roulette from the
// fourth vertex on (no depth cap, which would bias low), with continuation probability
// min(0.99, max throughput * eta^2): the eta^2 undoes the 1/eta^2 radiance scaling of
// refraction so paths inside glass are not killed for a change of units. Optional `maxDepth`
// (bounces; -1 = unlimited) exists for debugging only.
#include "common/integrator/direct.h"
#include "common/integrator/integrator.h"

namespace alphorn {

class PathMats : public Integrator {
  public:
    explicit PathMats(const PropertyList& props) {
        m_maxDepth = props.getInteger("maxDepth", -1);
        if (m_maxDepth < -1) props.fail("\"maxDepth\" must be -1 (unlimited) or >= 0");
    }

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
               const PassData*) const override {
        Color3f result(0.0f), throughput(1.0f);
        float etaScale = 1.0f;
        Ray3f ray = cameraRay;
        for (int depth = 0;; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            const Vector3f dir = ray.d.normalized();
            result += throughput * emittedRadiance(ray.o, dir, its);
            if (m_maxDepth >= 0 && depth >= m_maxDepth) break;

            if (depth >= 3) {
                const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                if (sampler.next1D() >= q) break;
                throughput /= q;
            }

            BSDFQueryRecord bRec = makeBSDFQuery(its, its.toLocal(-dir));
            const Color3f weight = its.mesh->bsdf()->sample(bRec, sampler.next2D());
            if (weight.isBlack() || !weight.allFinite()) break;
            throughput *= weight;
            etaScale *= bRec.eta * bRec.eta;
            ray = Ray3f(its.p, its.toWorld(bRec.wo));
        }
        return result;
    }

    std::string toString() const override { return "path_mats integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_mats", PathMats);

}  // namespace alphorn
