// A pbrt-v4 scene as its directives describe it, before any object is made: each entity is a type
// name, its parameters and the state the directive saw (transform, material, media, area light).
// The parser (parser.h) fills it from the files; object creation (create_scene.h) makes Alphorn's
// plugins from it. The split is pbrt-v4's own (tokens, a parsed scene, object creation).
#pragma once

#include "common/core/transform.h"
#include "common/pbrt/parameters.h"

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace alphorn::pbrt {

struct Entity {
    std::string directive;  // "Shape", "Material", ...
    std::string type;       // "sphere", "diffuse", ...
    ParameterList parameters;
    Location location;

    // `Shape "sphere"`, for messages.
    std::string describe() const { return directive + " \"" + type + "\""; }
};

// An entity placed in the world: `toWorld` is the transform in effect at its directive.
struct PlacedEntity : Entity {
    Eigen::Matrix4d toWorld = Eigen::Matrix4d::Identity();
};

struct CameraEntity : PlacedEntity {
    std::string medium;  // the outside medium in effect at the Camera directive
};

struct LightEntity : PlacedEntity {
    std::string medium;
};

struct ShapeEntity : PlacedEntity {
    bool reverseOrientation = false;
    // The material in effect: an index into SceneDescription::materials, or a named one.
    int materialIndex = -1;
    std::string materialName;
    std::optional<Entity> areaLight;
    std::string insideMedium, outsideMedium;
};

struct TextureEntity : PlacedEntity {
    std::string name;
    std::string valueType;  // "float" or "spectrum"
};

struct MediumEntity : PlacedEntity {
    std::string name;
};

// ObjectBegin ... ObjectEnd: shapes placed by each ObjectInstance of the name.
struct InstanceDefinition {
    std::string name;
    Location location;
    std::vector<ShapeEntity> shapes;
};

struct InstanceUse {
    std::string name;
    Location location;
    Eigen::Matrix4d toWorld = Eigen::Matrix4d::Identity();
};

struct SceneDescription {
    // Optional directives before WorldBegin; a missing one takes pbrt-v4's default.
    std::optional<CameraEntity> camera;
    std::optional<Entity> film, sampler, integrator, filter;

    std::vector<Entity> materials;                     // Material, by index
    std::map<std::string, Entity> namedMaterials;      // MakeNamedMaterial
    std::map<std::string, TextureEntity> textures[2];  // Texture: [0] float, [1] spectrum
    std::map<std::string, MediumEntity> media;         // MakeNamedMedium
    std::vector<ShapeEntity> shapes;
    std::vector<LightEntity> lights;
    std::map<std::string, InstanceDefinition> instances;
    std::vector<InstanceUse> instanceUses;

    // Every file the scene read (the main file's includes), resolved.
    std::vector<std::string> includedFiles;
};

}  // namespace alphorn::pbrt
