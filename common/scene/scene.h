// A loaded scene: meshes in one Embree BVH, emitters, camera, sampler and integrator.
#pragma once

#include "common/camera/camera.h"
#include "common/core/dpdf.h"
#include "common/emitter/emitter.h"
#include "common/integrator/integrator.h"
#include "common/sampler/sampler.h"
#include "common/scene/accel.h"
#include "common/scene/instance.h"
#include "common/scene/mesh.h"

#include <set>

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
    // The scene's own meshes, in world space. Instanced meshes are not among them: they are in
    // object space (see instances(), groups() and findMesh()).
    const std::vector<std::shared_ptr<Mesh>>& meshes() const { return m_meshes; }
    // Places `group` (its meshes activated, in object space, not given to addChild) in the
    // scene by `toWorld`; before activate() only. Refuses what Instance refuses, with an Error
    // naming the group.
    void addInstance(std::shared_ptr<MeshGroup> group, const Transform& toWorld);
    // The placements, in the order given, and the distinct groups they place, in the order of
    // the first placement of each.
    const std::vector<Instance>& instances() const { return m_instances; }
    const std::vector<std::shared_ptr<MeshGroup>>& groups() const { return m_groups; }
    // The first mesh, of the scene's own (in order) and then of the placed groups (in order),
    // for which `predicate` holds; null when none does. For what asks of every mesh what it
    // bounds or is (media, null BSDFs), which no transform changes.
    template <typename Predicate>
    const Mesh* findMesh(const Predicate& predicate) const {
        for (const auto& mesh : m_meshes)
            if (predicate(*mesh)) return mesh.get();
        for (const auto& group : m_groups)
            for (const auto& mesh : group->meshes())
                if (predicate(*mesh)) return mesh.get();
        return nullptr;
    }
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
    // Never moved once activate() built the Accel (hits point into it).
    std::vector<Instance> m_instances;
    std::vector<std::shared_ptr<MeshGroup>> m_groups;
    std::set<const MeshGroup*> m_placedGroups;  // m_groups, to find one (never iterated)
    bool m_activated = false;
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
