// Makes Alphorn's scene from a pbrt-v4 SceneDescription: each directive's entity becomes the
// plugin that renders it (Shape "sphere" a triangle mesh, Material "conductor" <bsdf
// type="conductor">, LightSource "infinite" <emitter type="environment">, ...), built from a
// PropertyList like the Nori XML front end's. What Alphorn cannot render as pbrt-v4 would is
// refused naming the file, line and directive; what has no effect on the image is ignored with a
// warning. docs/pbrt-v4-format.md lists both.
#pragma once

#include "common/pbrt/scene_description.h"
#include "common/scene/parser.h"

namespace alphorn {
class Scene;
class SceneLoadContext;
}  // namespace alphorn

namespace alphorn::pbrt {

struct CreateContext {
    // Lists made for the scene's objects take their directory, file policy, dependency log and
    // load context from it.
    PropertyList base;
    SceneOverrides overrides;
    SceneLimits limits;
};

std::shared_ptr<Scene> createScene(const SceneDescription& description,
                                   const CreateContext& context);

// Resolves (under the scene's file policy) and checks readable every file the scene's entities
// name, as createScene would read them, without building anything.
void listEntityFiles(const SceneDescription& description, const PropertyList& resolver);

}  // namespace alphorn::pbrt
