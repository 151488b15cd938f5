// The typed property list a plugin is built from (Nori's PropertyList). It remembers where it
// was written (file and line) so that a plugin can report a bad value where the user can find it,
// and which properties were read so the parser can warn about misspelt names.
#pragma once

#include "common/core/color.h"
#include "common/core/error.h"
#include "common/core/transform.h"

#include <map>
#include <set>
#include <variant>

namespace alphorn {

class SceneLoadContext;  // common/scene/scene_load.h

// Which files a scene may name. A scene rendered where it lies may name any file; a scene sent to
// the farm must name its files relative to itself (the client bundles them); on the farm every
// file must lie inside the job's bundle, so a scene cannot read the server's own files.
struct FileReferencePolicy {
    // Refuse absolute paths (implied by a confinement root).
    bool relativeOnly = false;
    // Nonempty: every file must resolve inside this absolute, lexically normal directory, also
    // after following symbolic links.
    std::string confinementRoot;
};

// The candidate closest to `word` by edit distance (insertions, deletions, substitutions and swaps
// of neighbouring letters, ignoring case), for "did you mean" hints; empty when none is close:
// at most one edit per three letters of `word`, and at least one edit allowed.
std::string closestName(const std::string& word, const std::vector<std::string>& candidates);

class PropertyList {
  public:
    enum class Type { Boolean, Integer, Float, String, Color, Point, Vector, Transform };

    PropertyList() = default;
    explicit PropertyList(std::string source) : m_source(std::move(source)) {}

    void setBoolean(const std::string& name, bool value);
    void setInteger(const std::string& name, int value);
    void setFloat(const std::string& name, float value);
    void setString(const std::string& name, const std::string& value);
    void setColor(const std::string& name, const Color3f& value);
    void setPoint(const std::string& name, const Point3f& value);
    void setVector(const std::string& name, const Vector3f& value);
    void setTransform(const std::string& name, const Transform& value);

    // Getters without a default throw if the property is missing; all throw on a type mismatch.
    bool getBoolean(const std::string& name) const;
    bool getBoolean(const std::string& name, bool defaultValue) const;
    int getInteger(const std::string& name) const;
    int getInteger(const std::string& name, int defaultValue) const;
    float getFloat(const std::string& name) const;
    float getFloat(const std::string& name, float defaultValue) const;
    std::string getString(const std::string& name) const;
    std::string getString(const std::string& name, const std::string& defaultValue) const;
    Color3f getColor(const std::string& name) const;
    Color3f getColor(const std::string& name, const Color3f& defaultValue) const;
    Point3f getPoint(const std::string& name) const;
    Point3f getPoint(const std::string& name, const Point3f& defaultValue) const;
    Vector3f getVector(const std::string& name) const;
    Vector3f getVector(const std::string& name, const Vector3f& defaultValue) const;
    Transform getTransform(const std::string& name) const;
    Transform getTransform(const std::string& name, const Transform& defaultValue) const;

    // Validated getters for the common constraints; the error names the source location.
    float getPositiveFloat(const std::string& name, float defaultValue) const;
    float getNonNegativeFloat(const std::string& name, float defaultValue) const;
    int getPositiveInteger(const std::string& name, int defaultValue) const;
    Color3f getNonNegativeColor(const std::string& name, const Color3f& defaultValue) const;

    bool has(const std::string& name) const { return m_values.count(name) != 0; }
    std::vector<std::string> unusedNames() const;
    // Every name a getter asked for, given or not: what the plugin understands, for suggesting
    // the intended name of an unused (misspelt) one.
    std::vector<std::string> requestedNames() const {
        return {m_requested.begin(), m_requested.end()};
    }

    // Where this list was written, e.g. "scene.xml:12 (bsdf type=\"diffuse\")".
    const std::string& source() const { return m_source; }
    void setSource(std::string source) { m_source = std::move(source); }
    // The directory of the scene file, for resolving relative paths.
    const std::string& baseDirectory() const { return m_baseDirectory; }
    void setBaseDirectory(std::string dir) { m_baseDirectory = std::move(dir); }
    // Resolves a relative path against the scene file's directory, enforces the file reference
    // policy and records the path as a file the scene depends on (the CLI uploads exactly these
    // with the scene). Plugins open files only through it, so the policy holds in one place.
    std::string resolvePath(const std::string& path) const;
    void setFileReferencePolicy(FileReferencePolicy policy) { m_filePolicy = std::move(policy); }
    void setDependencyLog(std::shared_ptr<std::vector<std::string>> log) {
        m_dependencies = std::move(log);
    }

    // What the loading of the scene file this list was written in shares among its objects;
    // null for a list the parser did not make.
    SceneLoadContext* loadContext() const { return m_loadContext.get(); }
    void setLoadContext(std::shared_ptr<SceneLoadContext> context) {
        m_loadContext = std::move(context);
    }

    template <typename... Args>
    [[noreturn]] void fail(const absl::FormatSpec<Args...>& format, const Args&... args) const {
        throw Error(m_source + ": " + absl::StrFormat(format, args...));
    }
    // Rethrows an error met reading a file for this list's plugin, named at the list: unchanged
    // when it names the list's source already, as a ResourceLimitError when it is one.
    [[noreturn]] void rethrowHere(const Error& e) const;
    // The same for a value that is well formed but asks for more memory or size than allowed
    // (the farm answers it with RESOURCE_EXHAUSTED, not INVALID_ARGUMENT).
    template <typename... Args>
    [[noreturn]] void failBeyondLimit(const absl::FormatSpec<Args...>& format,
                                      const Args&... args) const {
        throw ResourceLimitError(m_source + ": " + absl::StrFormat(format, args...));
    }

  private:
    using Value = std::variant<bool, int, float, std::string, Color3f, Point3f, Transform>;
    struct Entry {
        Type type;
        Value value;
    };
    void set(const std::string& name, Type type, Value value);
    const Entry* find(const std::string& name, Type type) const;
    const Entry& get(const std::string& name, Type type) const;

    std::map<std::string, Entry> m_values;
    mutable std::set<std::string> m_used;
    mutable std::set<std::string> m_requested;
    std::string m_source = "<unknown>";
    std::string m_baseDirectory;
    FileReferencePolicy m_filePolicy;
    std::shared_ptr<std::vector<std::string>> m_dependencies;
    std::shared_ptr<SceneLoadContext> m_loadContext;
};

}  // namespace alphorn
