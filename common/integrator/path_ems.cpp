// <integrator type="path_ems">: path tracing with next-event estimation at every vertex with a
// non-delta BSDF. Light reaching such a vertex is counted only by its emitter sample, so
// emission found by the continuation ray is added only on the camera ray and after delta
// (mirror/dielectric) bounces, which NEE cannot handle: direct light is counted exactly once.
// Russian roulette and `maxDepth` as in path_mats.
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"

namespace alphorn {

class PathEms : public Integrator {
  public:
    explicit PathEms(const PropertyList& props) : m_maxDepth(maxDepthProperty(props)) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        return tracePath(scene, sampler, ray, m_maxDepth, DirectLight::EmitterSampling);
    }

    std::string toString() const override { return "path_ems integrator"; }

  private:
    int m_maxDepth;
};

ALPHORN_REGISTER(Integrator, "path_ems", PathEms);

}  // namespace alphorn
