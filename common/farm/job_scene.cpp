#include "common/farm/job_scene.h"

#include "common/scene/parser.h"
#include "common/scene/scene.h"

namespace alphorn::farm {

std::shared_ptr<Scene> loadJobScene(const std::string& scenePath,
                                    const std::string& integratorOverride) {
    std::shared_ptr<Scene> scene = loadScene(scenePath);
    if (!integratorOverride.empty()) {
        PropertyList props("integrator override \"" + integratorOverride + "\"");
        auto integrator = std::static_pointer_cast<Integrator>(
            ObjectFactory::create(ObjectKind::Integrator, integratorOverride, props));
        integrator->activate();
        scene->setIntegrator(std::move(integrator));
    }
    return scene;
}

}  // namespace alphorn::farm
