// The Nori XML scene format. Every element and property type of Nori is accepted unchanged;
// Alphorn adds <texture>, <medium> and <phase> and a "name" attribute on nested objects.
#pragma once

#include "common/core/object.h"

#include <filesystem>
#include <map>
#include <optional>

namespace alphorn {

class Scene;

struct ParseResult {
    std::shared_ptr<Object> root;           // a Scene, or a Test for statistical test files
    std::vector<std::string> dependencies;  // every file the scene refers to, resolved
};

// What the command line changes in a scene as it is read (`alphorn render -D`, `--size`).
struct SceneOverrides {
    // Values of $name in attribute values (Mitsuba 3 style): `value="$spp"` reads `spp`'s
    // value; an undefined $name is an error naming the file and line.
    std::map<std::string, std::string> parameters;
    // Replaces the camera's `width` and `height`, written or not.
    std::optional<Vector2i> imageSize;
};

// What a scene may make the loader build. Checked before any mesh is built: from counts of the
// vertices and faces in its OBJ files (a file that several <mesh> elements name counts for each).
struct SceneLimits {
    // The most memory the meshes may take together, as meshMemoryBytes (common/scene/mesh.h)
    // estimates it; 0: the machine's physical memory.
    uint64_t maxGeometryBytes = 0;
    // The setting maxGeometryBytes comes from, for messages (e.g. "--max-memory").
    std::string setting;
};

// What a scene is loaded for. Checking it (the coordinator at submit) builds every object as
// rendering would, so every file is read and every value checked with the same errors, but no
// acceleration structure: the scene knows its bounds (and its integrator's preprocess ran on
// them) but cannot trace rays.
enum class SceneUse { Render, Check };

// How a scene file is named in messages and which files it may name, for both scene formats.
struct SceneFileNaming {
    std::string path;            // where the file is read from
    std::string name;            // as messages name it: inside a confinement root, relative to it
    FileReferencePolicy policy;  // its confinement root absolute and lexically normal
    // The message without the confinement root's path, which is where the server keeps the
    // bundle and none of the user's business.
    std::string withoutConfinementRoot(std::string message) const;

    // Runs `function`, throwing its errors (of either kind) with withoutConfinementRoot's message.
    template <typename Function>
    auto confiningMessages(Function function) const {
        if (policy.confinementRoot.empty()) return function();
        try {
            return function();
        } catch (const ResourceLimitError& e) {
            throw ResourceLimitError(withoutConfinementRoot(e.what()));
        } catch (const Error& e) {
            throw Error(withoutConfinementRoot(e.what()));
        } catch (const std::filesystem::filesystem_error& e) {
            throw Error(withoutConfinementRoot(e.what()));
        }
    }
};
// Throws Error when the file lies outside the policy's confinement root.
SceneFileNaming nameSceneFile(const std::string& path, const FileReferencePolicy& policy);

// The text of the scene file (or a file it includes) at `path`, named `name` in messages; a
// directory, named pipe, socket or device is refused before it is opened (opening a pipe waits
// for a writer, and /dev/zero never ends).
std::string readSceneFileText(const std::string& path, const std::string& name);

// Whether a scene file is in pbrt-v4's format (by its extension, .pbrt), not Nori XML.
bool isPbrtSceneFile(const std::string& path);

// Parses a scene or test file (Nori XML, or pbrt-v4 for a .pbrt file); throws Error("file:line:col:
// problem") on any problem. The policy says which files the scene may name (any, by default). With
// a confinement root (a farm job's bundle), messages name files relative to the root, so they never
// show where it lies. A scene beyond the limits throws ResourceLimitError ("file:line (mesh ...):
// ...").
ParseResult parseSceneFile(const std::string& path, const FileReferencePolicy& policy = {},
                           const SceneOverrides& overrides = {}, const SceneLimits& limits = {},
                           SceneUse use = SceneUse::Render);
// Parses a file whose root must be <scene>.
std::shared_ptr<Scene> loadScene(const std::string& path, const FileReferencePolicy& policy = {},
                                 const SceneOverrides& overrides = {},
                                 const SceneLimits& limits = {}, SceneUse use = SceneUse::Render);

// The files a scene or test file names (resolved, as ParseResult::dependencies lists them),
// found without building anything: the file is read as parseSceneFile reads it (malformed XML,
// unknown elements, attributes and types, unparsable values, $names: the same file:line errors)
// and every file reference is resolved under `policy` and refused, naming the element, when it
// cannot be opened; but no mesh is read, no image decoded and no object made, so what only the
// objects check (a value out of range, a misspelt property, a broken OBJ or PNG, the mesh
// memory) is left to loading the scene.
std::vector<std::string> listSceneFiles(const std::string& path,
                                        const FileReferencePolicy& policy = {});

}  // namespace alphorn
