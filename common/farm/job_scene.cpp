#include "common/farm/job_scene.h"

#include "common/scene/parser.h"
#include "common/scene/scene.h"

namespace alphorn::farm {

namespace {

std::shared_ptr<Scene> withIntegrator(std::shared_ptr<Scene> scene,
                                      const std::string& integratorOverride) {
    if (!integratorOverride.empty()) {
        PropertyList props("integrator override \"" + integratorOverride + "\"");
        auto integrator = std::static_pointer_cast<Integrator>(
            ObjectFactory::create(ObjectKind::Integrator, integratorOverride, props));
        integrator->activate();
        scene->setIntegrator(std::move(integrator));
    }
    return scene;
}

}  // namespace

std::shared_ptr<Scene> loadJobScene(const std::string& bundleDirectory,
                                    const std::string& scenePath,
                                    const std::string& integratorOverride,
                                    const SceneLimits& limits, SceneUse use) {
    FileReferencePolicy policy;
    policy.confinementRoot = bundleDirectory;
    return withIntegrator(loadScene(scenePath, policy, {}, limits, use), integratorOverride);
}

std::shared_ptr<Scene> loadSceneWithIntegrator(const std::string& scenePath,
                                               const std::string& integratorOverride) {
    return withIntegrator(loadScene(scenePath), integratorOverride);
}

}  // namespace alphorn::farm
