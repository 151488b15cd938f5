// Reads a pbrt-v4 scene file and the files it includes into a SceneDescription: the directives,
// their parameters, and the graphics state they see (transforms, materials, media, area lights,
// object instances). Every problem is an Error naming the file, line and column.
#pragma once

#include "common/core/properties.h"
#include "common/pbrt/scene_description.h"

namespace alphorn::pbrt {

// `displayName` is the main file as messages name it; `resolver` resolves the files it includes
// (relative to the main file's directory, as pbrt-v4 resolves every file a scene names) under
// the scene's file policy and records them as the scene's files.
SceneDescription parseSceneDescription(const std::string& path, const std::string& displayName,
                                       const PropertyList& resolver);

// The same for text in memory (tests, fuzzing); includes resolve through `resolver`.
SceneDescription parseSceneDescriptionText(std::string text, const std::string& displayName,
                                           const PropertyList& resolver);

}  // namespace alphorn::pbrt
