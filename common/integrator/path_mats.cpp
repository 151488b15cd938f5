// <integrator type="path_mats">: unidirectional path tracing by BSDF sampling only (Nori's).
// Emission is added wherever the path hits a light. Russian roulette and the optional
// `maxDepth` (bounces; -1 = unlimited, for debugging only) are described in path.h.
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"

namespace alphorn {

class PathMats : public Integrator {
  public:
    explicit PathMats(const PropertyList& props) : m_maxDepth(maxDepthProperty(props)) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        return tracePath(scene, sampler, ray, m_maxDepth, DirectLight::BSDFSampling);
    }

    std::string toString() const override { return "path_mats integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_mats", PathMats);

}  // namespace alphorn
