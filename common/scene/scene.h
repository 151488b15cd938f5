// A loaded scene: meshes in one Embree BVH, emitters, camera, sampler and integrator.
#pragma once

#include "common/camera/camera.h"
#include "common/core/dpdf.h"
#include "common/emitter/emitter.h"
#include "common/integrator/integrator.h"
#include "common/sampler/sampler.h"
#include "common/scene/accel.h"
#include "common/scene/mesh.h"

namespace alphorn {

class Scene : public Object {
  public:
    explicit Scene(const PropertyList& props);
    ObjectKind kind() const override { return ObjectKind::Scene; }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override;
    void activate() override;
    std::string toString() const override;

    // Whether rays can be traced: false for a scene loaded only to be checked (SceneUse::Check),
    // which has no acceleration structure (rayIntersect and rayOccluded would find nothing).
    bool canTrace() const { return m_buildsAcceleration; }

    // Closest hit along the ray within [mint, maxt].
    bool rayIntersect(const Ray3f& ray, Intersection& its) const {
        return m_accel.intersect(ray, its);
    }
    // Any hit along the ray within [mint, maxt] (shadow rays).
    bool rayOccluded(const Ray3f& ray) const { return m_accel.occluded(ray); }

    const Camera* camera() const { return m_camera.get(); }
    const Integrator* integrator() const { return m_integrator.get(); }
    Integrator* integrator() { return m_integrator.get(); }
    const Sampler* sampler() const { return m_sampler.get(); }
    const std::vector<std::shared_ptr<Mesh>>& meshes() const { return m_meshes; }
    const std::vector<std::shared_ptr<Emitter>>& emitters() const { return m_emitters; }
    // The lights at infinity a ray that leaves the scene sees (environment lights; directional
    // lights are delta, seen by no ray), valid after activate().
    const std::vector<const Emitter*>& environmentEmitters() const { return m_environmentEmitters; }
    const Eigen::AlignedBox3f& bounds() const { return m_accel.bounds(); }
    const Accel& accel() const { return m_accel; }

    // Uniform light selection for next-event estimation (as in Nori).
    const Emitter* sampleEmitter(float& sample, float& pdf) const;
    float emitterPdf() const { return m_emitters.empty() ? 0.0f : 1.0f / m_emitters.size(); }
    // Light selection in proportion to power, for photon emission.
    const Emitter* sampleEmitterByPower(float& sample, float& pdf) const;

    // Replaces the integrator (e.g. the statistical tests' or a job's override).
    void setIntegrator(std::shared_ptr<Integrator> integrator);

  private:
    // Gives lights at infinity the scene's bounding sphere and lists the environments (activate).
    void placeLightsAtInfinity();

    std::vector<std::shared_ptr<Mesh>> m_meshes;
    std::vector<std::shared_ptr<Emitter>> m_emitters;
    std::vector<const Emitter*> m_environmentEmitters;
    std::shared_ptr<Camera> m_camera;
    std::shared_ptr<Integrator> m_integrator;
    std::shared_ptr<Sampler> m_sampler;
    DiscretePDF m_powerPdf;
    Accel m_accel;
    bool m_buildsAcceleration = true;
};

}  // namespace alphorn
