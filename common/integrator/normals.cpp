// <integrator type="normals">: shows the absolute shading normal as a colour (Nori's first
// integrator), for checking geometry and transforms.
#include "common/integrator/integrator.h"
#include "common/scene/scene.h"

namespace alphorn {

class NormalIntegrator : public Integrator {
  public:
    explicit NormalIntegrator(const PropertyList&) {}

    Color3f Li(const Scene& scene, Sampler&, const Ray3f& ray, const PassData*) const override {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return Color3f(0.0f);
        const Normal3f n = its.shFrame.n.cwiseAbs();
        return Color3f(n.x(), n.y(), n.z());
    }
};

ALPHORN_REGISTER(Integrator, "normals", NormalIntegrator);

}  // namespace alphorn
