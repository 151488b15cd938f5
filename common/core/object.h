// The base of every scene plugin and the registry that builds plugins by XML tag and type name
// (Nori's NoriObject and NoriObjectFactory). A plugin is one class in one file, registered with
// ALPHORN_REGISTER(Kind, "type", Class) and constructed from a PropertyList.
#pragma once

#include "common/core/properties.h"

#include <functional>

namespace alphorn {

enum class ObjectKind {
    Scene,
    Mesh,
    BSDF,
    Texture,
    Medium,
    PhaseFunction,
    Emitter,
    Camera,
    Integrator,
    Sampler,
    Filter,
    Test,
};

// The XML tag of a kind ("bsdf", "rfilter", ...).
const char* kindTag(ObjectKind kind);

class Object : public std::enable_shared_from_this<Object> {
  public:
    virtual ~Object() = default;
    virtual ObjectKind kind() const = 0;

    // Receives a nested object. `name` is the child's "name" attribute (e.g. a texture's
    // parameter, or "inside"/"outside" for media), empty when absent. The default rejects it.
    virtual void addChild(const std::shared_ptr<Object>& child, const std::string& name);
    // Called once all children are added: validate and precompute.
    virtual void activate() {}
    virtual std::string toString() const { return kindTag(kind()); }

    // Where the object was written (for error messages).
    const std::string& source() const { return m_source; }
    void setSource(std::string source) { m_source = std::move(source); }
    // How the object was written, as the parser read it: its element and everything inside it,
    // but not the name its parent takes it under; empty for objects the parser did not make.
    // Objects with equal non-empty definitions compute the same values, so a plugin holding two
    // may evaluate one for both.
    const std::string& definition() const { return m_definition; }
    void setDefinition(std::string definition) { m_definition = std::move(definition); }

    template <typename... Args>
    [[noreturn]] void fail(const absl::FormatSpec<Args...>& format, const Args&... args) const {
        throw Error(m_source + ": " + absl::StrFormat(format, args...));
    }
    // The same for what asks for more memory or size than allowed (PropertyList::failBeyondLimit).
    template <typename... Args>
    [[noreturn]] void failBeyondLimit(const absl::FormatSpec<Args...>& format,
                                      const Args&... args) const {
        throw ResourceLimitError(m_source + ": " + absl::StrFormat(format, args...));
    }

  private:
    std::string m_source = "<unknown>";
    std::string m_definition;
};

class ObjectFactory {
  public:
    using Constructor = std::function<std::shared_ptr<Object>(const PropertyList&)>;

    static bool registerClass(ObjectKind kind, const std::string& type, Constructor constructor);
    static bool has(ObjectKind kind, const std::string& type);
    // Builds the object; throws Error naming props.source() for an unknown type.
    static std::shared_ptr<Object> create(ObjectKind kind, const std::string& type,
                                          const PropertyList& props);
    static std::vector<std::string> typesOf(ObjectKind kind);

    // Plugins that read files register a lister with ALPHORN_REGISTER_FILES, so that a scene's
    // files can be listed without building it (listSceneFiles): given the plugin's properties,
    // it resolves every file the plugin would read (PropertyList::resolvePath, which records it)
    // and refuses one that cannot be read, with the plugin's own message.
    using FileLister = std::function<void(const PropertyList&)>;
    static bool registerFileLister(ObjectKind kind, const std::string& type, FileLister lister);
    // Runs the type's lister, if it has one; throws what create() throws for an unknown type.
    static void listFiles(ObjectKind kind, const std::string& type, const PropertyList& props);
};

#define ALPHORN_REGISTER(Kind, TypeName, Class)                                          \
    static const bool Class##_registered = ::alphorn::ObjectFactory::registerClass(      \
        ::alphorn::ObjectKind::Kind, TypeName,                                           \
        [](const ::alphorn::PropertyList& props) -> std::shared_ptr<::alphorn::Object> { \
            return std::make_shared<Class>(props);                                       \
        })

#define ALPHORN_REGISTER_FILES(Kind, TypeName, Function)                                    \
    static const bool Function##_registered = ::alphorn::ObjectFactory::registerFileLister( \
        ::alphorn::ObjectKind::Kind, TypeName, Function)

}  // namespace alphorn
