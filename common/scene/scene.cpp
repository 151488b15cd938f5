#include "common/scene/scene.h"
#include "common/core/warning.h"
#include "common/scene/media_traversal.h"
#include "common/scene/scene_load.h"

#include <absl/strings/str_format.h>

namespace alphorn {

Scene::Scene(const PropertyList& props)
    : m_buildsAcceleration(!props.loadContext() || props.loadContext()->buildsAcceleration()) {}

void Scene::addChild(const std::shared_ptr<Object>& child, const std::string& name) {
    switch (child->kind()) {
        case ObjectKind::Mesh: {
            auto mesh = std::static_pointer_cast<Mesh>(child);
            m_meshes.push_back(mesh);
            if (mesh->emitter()) m_emitters.push_back(mesh->emitterShared());
            break;
        }
        case ObjectKind::Emitter:
            m_emitters.push_back(std::static_pointer_cast<Emitter>(child));
            break;
        case ObjectKind::Camera:
            if (m_camera) child->fail("the scene has more than one camera");
            m_camera = std::static_pointer_cast<Camera>(child);
            break;
        case ObjectKind::Integrator:
            if (m_integrator) child->fail("the scene has more than one integrator");
            m_integrator = std::static_pointer_cast<Integrator>(child);
            break;
        case ObjectKind::Sampler:
            if (m_sampler) child->fail("the scene has more than one sampler");
            m_sampler = std::static_pointer_cast<Sampler>(child);
            break;
        default:
            Object::addChild(child, name);
    }
}

void Scene::addInstance(std::shared_ptr<MeshGroup> group, const Transform& toWorld) {
    if (m_activated)
        fail("%s: an instance of object \"%s\" was added after the scene was built", source(),
             group ? group->name() : std::string("(null)"));
    m_instances.emplace_back(group, toWorld);
    if (m_placedGroups.insert(group.get()).second) m_groups.push_back(group);
    group->markPlaced();
}

void Scene::activate() {
    if (!m_camera) fail("the scene has no camera");
    if (!m_integrator) fail("the scene has no integrator");
    if (!m_sampler) {
        // Owen-scrambled Sobol with one sample per pixel: at equal samples it beat the
        // independent sampler (Nori's default) on direct light and fog and tied on the Cornell
        // box (bench_sampler_variance, bench/RESULTS.md); unlike stratified, it needs no
        // sample count to stratify over.
        PropertyList props(source() + " (default sampler)");
        m_sampler = std::static_pointer_cast<Sampler>(
            ObjectFactory::create(ObjectKind::Sampler, "sobol", props));
        m_sampler->activate();
    }
    // Not an error (the normals and ao integrators need no light), but every other integrator
    // renders such a scene black, which a user should hear about before the render, not after.
    if (m_emitters.empty())
        warn(
            "%s: the scene has no emitter; every integrator that transports light renders it "
            "black",
            source());
    // Checking the scene needs its bounds (the integrators derive default radii from them), which
    // are those of its meshes; Embree's BVH, the largest part of loading a scene of many
    // meshes, is built only to trace rays.
    m_activated = true;
    if (m_buildsAcceleration)
        m_accel.build(m_meshes, m_instances);
    else
        m_accel.boundMeshes(m_meshes, m_instances);
    placeLightsAtInfinity();
    checkMediaTrackingWork(*this);
    m_powerPdf.clear();
    for (const auto& emitter : m_emitters) {
        Color3f power = emitter->power();
        m_powerPdf.append(std::max(0.0f, power.mean()));
    }
    m_powerPdf.normalize();
    m_integrator->preprocess(*this);
}

void Scene::placeLightsAtInfinity() {
    m_environmentEmitters.clear();
    const bool any = std::any_of(m_emitters.begin(), m_emitters.end(),
                                 [](const auto& emitter) { return emitter->isInfinite(); });
    if (!any) return;
    // Lights at infinity emit photons through a disk as wide as the scene's bounding sphere, and
    // need it before they can tell their power. With media, light scatters anywhere in the box
    // media end at (which holds the camera and the other lights too), so the sphere holds that.
    const Eigen::AlignedBox3f box = needsVolumetricPaths(*this) ? mediaBounds(*this) : bounds();
    const Point3f centre = box.isEmpty() ? Point3f::Zero() : Point3f(box.center());
    const float radius = box.isEmpty() ? 0.0f : 0.5f * box.diagonal().norm();
    for (const auto& emitter : m_emitters) {
        if (!emitter->isInfinite()) continue;
        emitter->setSceneBounds(centre, radius);
        if (!emitter->isDelta()) m_environmentEmitters.push_back(emitter.get());
    }
}

const Emitter* Scene::sampleEmitter(float& sample, float& pdf) const {
    if (m_emitters.empty()) {
        pdf = 0.0f;
        return nullptr;
    }
    size_t count = m_emitters.size();
    size_t index = std::min(count - 1, static_cast<size_t>(sample * count));
    sample = std::min(sample * count - index, 0.99999994f);
    pdf = 1.0f / count;
    return m_emitters[index].get();
}

const Emitter* Scene::sampleEmitterByPower(float& sample, float& pdf) const {
    if (m_emitters.empty() || !(m_powerPdf.sum() > 0.0)) {
        pdf = 0.0f;
        return nullptr;
    }
    size_t index = m_powerPdf.sampleReuse(sample);
    pdf = m_powerPdf[index];
    return m_emitters[index].get();
}

void Scene::setIntegrator(std::shared_ptr<Integrator> integrator) {
    m_integrator = std::move(integrator);
    m_integrator->preprocess(*this);
}

std::string Scene::toString() const {
    size_t triangles = 0;
    for (const auto& m : m_meshes) triangles += m->triangleCount();
    std::string instances;
    if (!m_instances.empty()) {
        size_t placed = 0;
        for (const Instance& instance : m_instances) placed += instance.group().triangleCount();
        instances = absl::StrFormat(", %zu instances of %zu objects (%zu triangles placed)",
                                    m_instances.size(), m_groups.size(), placed);
    }
    return absl::StrFormat("scene: %zu meshes (%zu triangles)%s, %zu emitters, %dx%d pixels",
                           m_meshes.size(), triangles, instances, m_emitters.size(),
                           m_camera->outputSize().x(), m_camera->outputSize().y());
}

ALPHORN_REGISTER(Scene, "scene", Scene);

}  // namespace alphorn
