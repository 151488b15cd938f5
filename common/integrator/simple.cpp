// <integrator type="simple">: Nori's first shading integrator. A point light of power `energy`
// at `position`, owned by the integrator (not an emitter), lights diffuse-looking surfaces:
// L = energy / (4 pi^2) * max(0, cos theta) / d^2 when the light is visible.
#include "common/integrator/integrator.h"
#include "common/scene/scene.h"

namespace alphorn {

class SimpleIntegrator : public Integrator {
  public:
    explicit SimpleIntegrator(const PropertyList& props) {
        m_position = props.getPoint("position");
        m_energy = props.getNonNegativeColor("energy", Color3f(0.0f));
        if (!props.has("energy")) props.fail("the simple integrator needs an \"energy\" colour");
    }

    Color3f Li(const Scene& scene, Sampler&, const Ray3f& ray, const PassData*) const override {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return Color3f(0.0f);
        const Vector3f toLight = m_position - its.p;
        const float dist2 = toLight.squaredNorm();
        if (!(dist2 > 0.0f)) return Color3f(0.0f);  // shading point on the light: no direction
        const float dist = std::sqrt(dist2);
        const Vector3f dir = toLight / dist;
        const float cosTheta = its.shFrame.n.dot(dir);
        if (cosTheta <= 0.0f) return Color3f(0.0f);
        if (scene.rayOccluded(Ray3f(its.p, dir, Epsilon, dist - Epsilon))) return Color3f(0.0f);
        // energy/(4 pi) is the intensity; the remaining 1/pi is a white Lambertian BRDF.
        return m_energy * (cosTheta / (4.0f * Pi * Pi * dist2));
    }

    std::string toString() const override { return "simple integrator"; }

  private:
    Point3f m_position;
    Color3f m_energy;
};

ALPHORN_REGISTER(Integrator, "simple", SimpleIntegrator);

}  // namespace alphorn
