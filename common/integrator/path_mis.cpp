// <integrator type="path_mis">: path tracing with multiple importance sampling (Nori's). At every
// vertex with a non-delta BSDF, one emitter sample and the continuation BSDF sample both look
// for direct light, combined by the balance heuristic (light selection included in the emitter
// density). Delta lights are reached only by the emitter sample (weight 1); after a delta BSDF
// bounce, or on the camera ray, emission hit by the path counts fully. Russian roulette and
// `maxDepth` as in path_mats.
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"

namespace alphorn {

class PathMis : public Integrator {
  public:
    explicit PathMis(const PropertyList& props) : m_maxDepth(maxDepthProperty(props)) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        return tracePath(scene, sampler, ray, m_maxDepth, DirectLight::MIS);
    }

    std::string toString() const override { return "path_mis integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_mis", PathMis);

}  // namespace alphorn
