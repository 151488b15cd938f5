// <integrator type="direct_mats">: direct illumination by BSDF ("material") sampling (Nori's).
// Emission seen by the camera plus one BSDF-sampled ray whose emission, if it hits a light, is
// weighted by the sample weight. Delta lights (point) cannot be reached this way and stay dark.
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"

namespace alphorn {

class DirectMats : public Integrator {
  public:
    explicit DirectMats(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        // A one-bounce path: the path tracer's loop stopped at depth 1 is exactly this.
        return tracePath(scene, sampler, ray, 1, DirectLight::BSDFSampling);
    }

    std::string toString() const override { return "direct_mats integrator"; }
};

ALPHORN_REGISTER(Integrator, "direct_mats", DirectMats);

}  // namespace alphorn
