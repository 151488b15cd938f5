// <integrator type="direct_mis">: direct illumination combining one emitter sample and one BSDF
// sample with the balance heuristic (Nori's). Each strategy's weight uses both densities, light
// selection included. Delta lights keep weight 1 on the emitter side and delta BSDF samples keep
// weight 1 on the BSDF side, since the other strategy cannot produce them.
#include "common/integrator/integrator.h"
#include "common/integrator/path.h"

namespace alphorn {

class DirectMis : public Integrator {
  public:
    explicit DirectMis(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler& sampler, const Ray3f& ray,
               const PassData*) const override {
        // A one-bounce path: the path tracer's loop stopped at depth 1 is exactly this.
        return tracePath(scene, sampler, ray, 1, DirectLight::MIS);
    }

    std::string toString() const override { return "direct_mis integrator"; }
};

ALPHORN_REGISTER(Integrator, "direct_mis", DirectMis);

}  // namespace alphorn
