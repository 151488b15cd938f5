#include "common/pbrt/pbrt_scene_file.h"

#include "common/core/error.h"
#include "common/core/warning.h"
#include "common/pbrt/create_scene.h"
#include "common/pbrt/parser.h"
#include "common/scene/scene.h"
#include "common/scene/scene_load.h"

#include <filesystem>

namespace alphorn::pbrt {
namespace {

struct Setup {
    SceneFileNaming naming;
    PropertyList base;
    std::shared_ptr<std::vector<std::string>> dependencies =
        std::make_shared<std::vector<std::string>>();
};

Setup setUp(const std::string& path, const FileReferencePolicy& policy, SceneUse use) {
    Setup setup{nameSceneFile(path, policy), PropertyList(), {}};
    setup.dependencies = std::make_shared<std::vector<std::string>>();
    setup.base.setBaseDirectory(std::filesystem::path(setup.naming.path).parent_path().string());
    setup.base.setFileReferencePolicy(setup.naming.policy);
    setup.base.setDependencyLog(setup.dependencies);
    auto context = std::make_shared<SceneLoadContext>();
    context->setBuildsAcceleration(use == SceneUse::Render);
    setup.base.setLoadContext(context);
    setup.base.setSource(setup.naming.name);
    return setup;
}

}  // namespace

ParseResult parsePbrtSceneFile(const std::string& path, const FileReferencePolicy& policy,
                               const SceneOverrides& overrides, const SceneLimits& limits,
                               SceneUse use) {
    Setup setup = setUp(path, policy, use);
    return setup.naming.confiningMessages([&] {
        const SceneDescription description =
            parseSceneDescription(setup.naming.path, setup.naming.name, setup.base);
        // pbrt-v4's format has no $name parameters: every -D is unused.
        for (const auto& [parameter, value] : overrides.parameters)
            warn("%s: -D %s=%s is not used: pbrt-v4 scene files take no $parameters",
                 setup.naming.name, parameter, value);
        CreateContext context{setup.base, overrides, limits};
        ParseResult result;
        result.root = createScene(description, context);
        result.dependencies = *setup.dependencies;
        return result;
    });
}

std::vector<std::string> listPbrtSceneFiles(const std::string& path,
                                            const FileReferencePolicy& policy) {
    Setup setup = setUp(path, policy, SceneUse::Check);
    return setup.naming.confiningMessages([&] {
        const SceneDescription description =
            parseSceneDescription(setup.naming.path, setup.naming.name, setup.base);
        listEntityFiles(description, setup.base);
        return *setup.dependencies;
    });
}

}  // namespace alphorn::pbrt
