#include "common/core/properties.h"

#include <absl/strings/ascii.h>

#include <algorithm>
#include <filesystem>

namespace alphorn {

std::string closestName(const std::string& word, const std::vector<std::string>& candidates) {
    // Nobody misspells a name this long; and it keeps a hostile scene from costing
    // length x length work.
    if (word.size() > 256) return "";
    const std::string a = absl::AsciiStrToLower(word);
    const size_t allowed = std::max<size_t>(1, a.size() / 3);
    std::string best;
    size_t bestDistance = allowed + 1;
    for (const std::string& candidate : candidates) {
        // The distance is at least the difference in length.
        if (candidate == word || candidate.size() > a.size() + allowed ||
            a.size() > candidate.size() + allowed)
            continue;
        const std::string b = absl::AsciiStrToLower(candidate);
        // Optimal string alignment distance over a (|a|+1) x (|b|+1) table.
        std::vector<std::vector<size_t>> d(a.size() + 1, std::vector<size_t>(b.size() + 1));
        for (size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
        for (size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
        for (size_t i = 1; i <= a.size(); ++i)
            for (size_t j = 1; j <= b.size(); ++j) {
                d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1,
                                    d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
                if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1])
                    d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
            }
        if (d[a.size()][b.size()] < bestDistance) {
            bestDistance = d[a.size()][b.size()];
            best = candidate;
        }
    }
    return best;
}

static const char* typeName(PropertyList::Type type) {
    switch (type) {
        case PropertyList::Type::Boolean:
            return "boolean";
        case PropertyList::Type::Integer:
            return "integer";
        case PropertyList::Type::Float:
            return "float";
        case PropertyList::Type::String:
            return "string";
        case PropertyList::Type::Color:
            return "color";
        case PropertyList::Type::Point:
            return "point";
        case PropertyList::Type::Vector:
            return "vector";
        case PropertyList::Type::Transform:
            return "transform";
    }
    return "?";
}

void PropertyList::set(const std::string& name, Type type, Value value) {
    if (m_values.count(name)) fail("property \"%s\" was specified more than once", name);
    m_values.emplace(name, Entry{type, std::move(value)});
}

const PropertyList::Entry* PropertyList::find(const std::string& name, Type type) const {
    m_requested.insert(name);
    auto it = m_values.find(name);
    if (it == m_values.end()) return nullptr;
    m_used.insert(name);
    if (it->second.type != type)
        fail("property \"%s\" has type %s, expected %s", name, typeName(it->second.type),
             typeName(type));
    return &it->second;
}

const PropertyList::Entry& PropertyList::get(const std::string& name, Type type) const {
    const Entry* entry = find(name, type);
    if (!entry) {
        // A required property written with a typo shows up here first, before the parser
        // reports the misspelt name as unused.
        std::vector<std::string> unread;
        for (const auto& [given, ignored] : m_values)
            if (!m_used.count(given)) unread.push_back(given);
        const std::string typo = closestName(name, unread);
        if (!typo.empty())
            fail("missing required %s property \"%s\" (is \"%s\" a misspelling of it?)",
                 typeName(type), name, typo);
        fail("missing required %s property \"%s\"", typeName(type), name);
    }
    return *entry;
}

void PropertyList::setBoolean(const std::string& n, bool v) {
    set(n, Type::Boolean, v);
}
void PropertyList::setInteger(const std::string& n, int v) {
    set(n, Type::Integer, v);
}
void PropertyList::setFloat(const std::string& n, float v) {
    set(n, Type::Float, v);
}
void PropertyList::setString(const std::string& n, const std::string& v) {
    set(n, Type::String, v);
}
void PropertyList::setColor(const std::string& n, const Color3f& v) {
    set(n, Type::Color, v);
}
void PropertyList::setPoint(const std::string& n, const Point3f& v) {
    set(n, Type::Point, Point3f(v));
}
void PropertyList::setVector(const std::string& n, const Vector3f& v) {
    set(n, Type::Vector, Point3f(v));
}
void PropertyList::setTransform(const std::string& n, const Transform& v) {
    set(n, Type::Transform, v);
}

#define ALPHORN_GETTERS(Name, CppType, TypeTag, Alternative)                             \
    CppType PropertyList::get##Name(const std::string& name) const {                     \
        return std::get<Alternative>(get(name, Type::TypeTag).value);                    \
    }                                                                                    \
    CppType PropertyList::get##Name(const std::string& name, const CppType& def) const { \
        const Entry* e = find(name, Type::TypeTag);                                      \
        return e ? CppType(std::get<Alternative>(e->value)) : def;                       \
    }

bool PropertyList::getBoolean(const std::string& name) const {
    return std::get<bool>(get(name, Type::Boolean).value);
}
bool PropertyList::getBoolean(const std::string& name, bool def) const {
    const Entry* e = find(name, Type::Boolean);
    return e ? std::get<bool>(e->value) : def;
}
int PropertyList::getInteger(const std::string& name) const {
    return std::get<int>(get(name, Type::Integer).value);
}
int PropertyList::getInteger(const std::string& name, int def) const {
    const Entry* e = find(name, Type::Integer);
    return e ? std::get<int>(e->value) : def;
}
float PropertyList::getFloat(const std::string& name) const {
    return std::get<float>(get(name, Type::Float).value);
}
float PropertyList::getFloat(const std::string& name, float def) const {
    const Entry* e = find(name, Type::Float);
    return e ? std::get<float>(e->value) : def;
}
ALPHORN_GETTERS(String, std::string, String, std::string)
ALPHORN_GETTERS(Color, Color3f, Color, Color3f)
ALPHORN_GETTERS(Point, Point3f, Point, Point3f)
ALPHORN_GETTERS(Vector, Vector3f, Vector, Point3f)
ALPHORN_GETTERS(Transform, Transform, Transform, Transform)
#undef ALPHORN_GETTERS

float PropertyList::getPositiveFloat(const std::string& name, float def) const {
    float v = getFloat(name, def);
    if (!(v > 0.0f) || !std::isfinite(v)) fail("\"%s\" must be a positive number, got %g", name, v);
    return v;
}

float PropertyList::getNonNegativeFloat(const std::string& name, float def) const {
    float v = getFloat(name, def);
    if (!(v >= 0.0f) || !std::isfinite(v))
        fail("\"%s\" must be a finite number >= 0, got %g", name, v);
    return v;
}

int PropertyList::getPositiveInteger(const std::string& name, int def) const {
    int v = getInteger(name, def);
    if (v <= 0) fail("\"%s\" must be a positive integer, got %d", name, v);
    return v;
}

Color3f PropertyList::getNonNegativeColor(const std::string& name, const Color3f& def) const {
    Color3f c = getColor(name, def);
    for (int i = 0; i < 3; ++i)
        if (!(c[i] >= 0.0f) || !std::isfinite(c[i]))
            fail("\"%s\" must have finite components >= 0, got %s", name, c.toString());
    return c;
}

std::vector<std::string> PropertyList::unusedNames() const {
    std::vector<std::string> unused;
    for (const auto& [name, entry] : m_values)
        if (!m_used.count(name)) unused.push_back(name);
    return unused;
}

// True if `path` is `directory` or lies below it; both absolute and lexically normal.
static bool isWithin(const std::filesystem::path& path, const std::filesystem::path& directory) {
    const std::filesystem::path relative = path.lexically_relative(directory);
    return !relative.empty() && *relative.begin() != "..";
}

void PropertyList::rethrowHere(const Error& e) const {
    const std::string message = e.what();
    if (message.rfind(m_source, 0) == 0) throw;
    if (dynamic_cast<const ResourceLimitError*>(&e)) failBeyondLimit("%s", message);
    fail("%s", message);
}

std::string PropertyList::resolvePath(const std::string& path) const {
    namespace fs = std::filesystem;
    const fs::path written(path);
    const std::string& root = m_filePolicy.confinementRoot;
    if (written.is_absolute() && (m_filePolicy.relativeOnly || !root.empty()))
        fail(
            "\"%s\" is an absolute path; a scene rendered on the farm must name its files "
            "relative to the scene file",
            path);
    fs::path resolved = written.is_absolute() || m_baseDirectory.empty()
                            ? written.lexically_normal()
                            : (fs::path(m_baseDirectory) / written).lexically_normal();
    if (!root.empty()) {
        // First by name (".." past the root), then by where the file really is, so that neither
        // ".." nor a symbolic link inside the root leads out of it.
        resolved = fs::absolute(resolved).lexically_normal();
        if (!isWithin(resolved, root))
            fail("\"%s\" leaves the scene bundle; paths must stay inside it", path);
        std::error_code error;
        const fs::path realRoot = fs::canonical(root, error);
        const fs::path real = error ? fs::path() : fs::weakly_canonical(resolved, error);
        if (error) fail("cannot resolve \"%s\": %s", path, error.message());
        if (!isWithin(real, realRoot))
            fail(
                "\"%s\" leaves the scene bundle through a symbolic link; paths must stay inside it",
                path);
    }
    // A directory, FIFO or device is refused here: reading a FIFO would wait forever for a
    // writer, and /dev/zero would fill the memory. A file that does not exist is left to the
    // plugin, which names what it expected.
    std::error_code statusError;
    const fs::file_status status = fs::status(resolved, statusError);
    if (statusError && statusError != std::errc::no_such_file_or_directory)
        fail("cannot use \"%s\": %s", path, statusError.message());
    if (fs::exists(status) && !fs::is_regular_file(status))
        fail("\"%s\" is %s, not a file", path,
             fs::is_directory(status) ? "a directory"
             : fs::is_fifo(status)    ? "a named pipe"
             : fs::is_socket(status)  ? "a socket"
                                      : "a device");
    if (m_dependencies) m_dependencies->push_back(resolved.string());
    return resolved.string();
}

}  // namespace alphorn
