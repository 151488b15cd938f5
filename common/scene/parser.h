// The Nori XML scene format. Every element and property type of Nori is accepted unchanged;
// Alphorn adds <texture>, <medium> and <phase> and a "name" attribute on nested objects.
#pragma once

#include "common/core/object.h"

namespace alphorn {

class Scene;

struct ParseResult {
    std::shared_ptr<Object> root;           // a Scene, or a Test for statistical test files
    std::vector<std::string> dependencies;  // every file the scene refers to, resolved
};

// Parses a scene or test file; throws Error("file:line:col: problem") on any problem. The policy
// says which files the scene may name (any, by default). With a confinement root (a farm job's
// bundle), messages name files relative to the root, so they never show where it lies.
ParseResult parseSceneFile(const std::string& path, const FileReferencePolicy& policy = {});
// Parses a file whose root must be <scene>.
std::shared_ptr<Scene> loadScene(const std::string& path, const FileReferencePolicy& policy = {});

}  // namespace alphorn
