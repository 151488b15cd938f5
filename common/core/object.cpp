#include "common/core/object.h"

#include <absl/strings/str_join.h>

#include <map>
#include <mutex>

namespace alphorn {

const char* kindTag(ObjectKind kind) {
    switch (kind) {
        case ObjectKind::Scene:
            return "scene";
        case ObjectKind::Mesh:
            return "mesh";
        case ObjectKind::BSDF:
            return "bsdf";
        case ObjectKind::Texture:
            return "texture";
        case ObjectKind::Medium:
            return "medium";
        case ObjectKind::PhaseFunction:
            return "phase";
        case ObjectKind::Emitter:
            return "emitter";
        case ObjectKind::Camera:
            return "camera";
        case ObjectKind::Integrator:
            return "integrator";
        case ObjectKind::Sampler:
            return "sampler";
        case ObjectKind::Filter:
            return "rfilter";
        case ObjectKind::Test:
            return "test";
    }
    return "?";
}

void Object::addChild(const std::shared_ptr<Object>& child, const std::string&) {
    fail("a <%s> cannot be nested in a <%s>", kindTag(child->kind()), kindTag(kind()));
}

namespace {
using Registry = std::map<std::pair<ObjectKind, std::string>, ObjectFactory::Constructor>;
Registry& registry() {
    static Registry r;
    return r;
}
using ListerRegistry = std::map<std::pair<ObjectKind, std::string>, ObjectFactory::FileLister>;
ListerRegistry& listerRegistry() {
    static ListerRegistry r;
    return r;
}
std::mutex& registryMutex() {
    static std::mutex m;
    return m;
}
}  // namespace

bool ObjectFactory::registerClass(ObjectKind kind, const std::string& type, Constructor ctor) {
    std::lock_guard lock(registryMutex());
    registry()[{kind, type}] = std::move(ctor);
    return true;
}

bool ObjectFactory::has(ObjectKind kind, const std::string& type) {
    std::lock_guard lock(registryMutex());
    return registry().count({kind, type}) != 0;
}

std::vector<std::string> ObjectFactory::typesOf(ObjectKind kind) {
    std::lock_guard lock(registryMutex());
    std::vector<std::string> types;
    for (const auto& [key, ctor] : registry())
        if (key.first == kind) types.push_back(key.second);
    return types;
}

bool ObjectFactory::registerFileLister(ObjectKind kind, const std::string& type,
                                       FileLister lister) {
    std::lock_guard lock(registryMutex());
    listerRegistry()[{kind, type}] = std::move(lister);
    return true;
}

namespace {
[[noreturn]] void failUnknownType(ObjectKind kind, const std::string& type,
                                  const PropertyList& props) {
    props.fail("unknown %s type \"%s\" (known: %s)", kindTag(kind), type,
               absl::StrJoin(ObjectFactory::typesOf(kind), ", "));
}
}  // namespace

void ObjectFactory::listFiles(ObjectKind kind, const std::string& type, const PropertyList& props) {
    if (!has(kind, type)) failUnknownType(kind, type, props);
    FileLister lister;
    {
        std::lock_guard lock(registryMutex());
        auto it = listerRegistry().find({kind, type});
        if (it != listerRegistry().end()) lister = it->second;
    }
    if (lister) lister(props);
}

std::shared_ptr<Object> ObjectFactory::create(ObjectKind kind, const std::string& type,
                                              const PropertyList& props) {
    Constructor ctor;
    {
        std::lock_guard lock(registryMutex());
        auto it = registry().find({kind, type});
        if (it != registry().end()) ctor = it->second;
    }
    if (!ctor) failUnknownType(kind, type, props);
    std::shared_ptr<Object> object = ctor(props);
    object->setSource(props.source());
    return object;
}

}  // namespace alphorn
