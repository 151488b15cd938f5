// The pbrt-v4 front end's entry points: what parseSceneFile, loadScene and listSceneFiles
// (common/scene/parser.h) do for a .pbrt file. Tokens (tokenizer.h), the parsed scene
// (parser.h, scene_description.h) and object creation (create_scene.h) are its three steps.
#pragma once

#include "common/scene/parser.h"

namespace alphorn::pbrt {

ParseResult parsePbrtSceneFile(const std::string& path, const FileReferencePolicy& policy,
                               const SceneOverrides& overrides, const SceneLimits& limits,
                               SceneUse use);

std::vector<std::string> listPbrtSceneFiles(const std::string& path,
                                            const FileReferencePolicy& policy);

}  // namespace alphorn::pbrt
