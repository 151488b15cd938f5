#include "common/scene/parser.h"

#include "common/core/decimal_number.h"
#include "common/core/system_memory.h"
#include "common/core/warning.h"
#include "common/pbrt/pbrt_scene_file.h"
#include "common/scene/mesh.h"
#include "common/scene/scene.h"
#include "common/scene/scene_load.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_cat.h>
#include <absl/strings/str_replace.h>
#include <absl/strings/str_split.h>
#include <pugixml.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

namespace alphorn {
namespace {

enum class Tag {
    Object,
    Boolean,
    Integer,
    Float,
    String,
    Point,
    Vector,
    Color,
    Transform,
    Translate,
    Matrix,
    Rotate,
    Scale,
    LookAt,
};

const std::map<std::string, ObjectKind> kObjectTags = {
    {"scene", ObjectKind::Scene},
    {"mesh", ObjectKind::Mesh},
    {"bsdf", ObjectKind::BSDF},
    {"texture", ObjectKind::Texture},
    {"medium", ObjectKind::Medium},
    {"phase", ObjectKind::PhaseFunction},
    {"emitter", ObjectKind::Emitter},
    {"camera", ObjectKind::Camera},
    {"integrator", ObjectKind::Integrator},
    {"sampler", ObjectKind::Sampler},
    {"rfilter", ObjectKind::Filter},
    {"test", ObjectKind::Test},
};

const std::map<std::string, Tag> kPropertyTags = {
    {"boolean", Tag::Boolean}, {"integer", Tag::Integer},     {"float", Tag::Float},
    {"string", Tag::String},   {"point", Tag::Point},         {"vector", Tag::Vector},
    {"color", Tag::Color},     {"transform", Tag::Transform}, {"translate", Tag::Translate},
    {"matrix", Tag::Matrix},   {"rotate", Tag::Rotate},       {"scale", Tag::Scale},
    {"lookat", Tag::LookAt},
};

// Whether the parser builds the scene's objects or only lists the files they would read.
enum class ParseMode { Build, ListFiles };

class Parser {
  public:
    Parser(const std::string& path, const FileReferencePolicy& policy,
           const SceneOverrides& overrides, const SceneLimits& limits, SceneUse use, ParseMode mode)
        : m_path(path),
          m_name(path),
          m_policy(policy),
          m_overrides(overrides),
          m_limits(limits),
          m_mode(mode) {
        m_loadContext->setBuildsAcceleration(use == SceneUse::Render);
        const SceneFileNaming naming = nameSceneFile(path, policy);
        m_path = naming.path;
        m_name = naming.name;
        m_policy = naming.policy;
    }

    // The scene file's name in messages: its path, or its path inside the confinement root.
    const std::string& name() const { return m_name; }

    ParseResult parse() {
        return SceneFileNaming{m_path, m_name, m_policy}.confiningMessages(
            [&] { return parseFile(); });
    }

  private:
    ParseResult parseFile() {
        m_text = readSceneFileText(m_path, m_name);
        m_baseDirectory = std::filesystem::path(m_path).parent_path().string();

        pugi::xml_document doc;
        // As a fragment, pugixml keeps text outside the root element (it drops it otherwise), so
        // that failIfNotOneRootElement can refuse it.
        pugi::xml_parse_result result = doc.load_buffer(m_text.data(), m_text.size(),
                                                        pugi::parse_default | pugi::parse_fragment);
        if (!result) fail("%s: malformed XML: %s", location(result.offset), result.description());

        pugi::xml_node root = doc.document_element();
        if (!root) fail("%s: the file has no root element", m_name);
        failIfNotOneRootElement(doc, root);
        failIfNestedTooDeepOrAttributeRepeated(doc);
        if (!kObjectTags.count(root.name()))
            fail("%s: the root element must be <scene> or <test>, found <%s>",
                 location(root.offset_debug()), root.name());
        if (m_mode == ParseMode::Build) checkGeometry(doc);
        ParseResult out;
        out.root = parseObject(root);
        for (const auto& [parameter, value] : m_overrides.parameters)
            if (!m_usedParameters.count(parameter))
                warn("%s: -D %s=%s is not used: no $%s in it", m_name, parameter, value, parameter);
        out.dependencies = std::move(*m_dependencies);
        return out;
    }

    // XML allows one root element and no text outside it. The file is read as a fragment, which
    // keeps both; the loader would otherwise silently ignore a second <scene> (or the part of a
    // scene after a stray </scene>).
    void failIfNotOneRootElement(const pugi::xml_document& doc, const pugi::xml_node& root) const {
        for (const pugi::xml_node& node : doc.children()) {
            if (node.type() == pugi::node_element && node != root)
                failAt(node,
                       "malformed XML: a second root element <%s> after <%s>; a file holds one",
                       node.name(), root.name());
            if (node.type() == pugi::node_pcdata || node.type() == pugi::node_cdata)
                failAt(node, "malformed XML: text \"%s\" outside the root element <%s>",
                       std::string(absl::StripAsciiWhitespace(node.value())).substr(0, 40),
                       root.name());
        }
    }

    // Scenes nest a few levels (scene, mesh, bsdf, texture); the parser recurses once per level,
    // so a file nesting thousands would overflow the stack (a crash of the coordinator that
    // admits it). The depth is measured by pugixml's walker, which keeps its own stack.
    // The same walk refuses an attribute written twice in one element, which XML forbids and
    // pugixml accepts (the first would be used, the second silently ignored).
    static constexpr int kMaxElementDepth = 64;
    void failIfNestedTooDeepOrAttributeRepeated(pugi::xml_document& doc) {
        struct Check : pugi::xml_tree_walker {
            pugi::xml_node tooDeep, repeating;
            std::string repeated;
            bool for_each(pugi::xml_node& node) override {
                if (node.type() != pugi::node_element) return true;
                if (depth() >= kMaxElementDepth) {
                    tooDeep = node;
                    return false;
                }
                std::set<std::string_view> names;
                for (const pugi::xml_attribute& attribute : node.attributes())
                    if (!names.insert(attribute.name()).second) {
                        repeating = node;
                        repeated = attribute.name();
                        return false;
                    }
                return true;
            }
        } check;
        doc.traverse(check);
        if (check.tooDeep)
            fail("%s: <%s> is nested more than %d elements deep; scenes nest a few",
                 location(check.tooDeep.offset_debug()), check.tooDeep.name(), kMaxElementDepth);
        if (check.repeating)
            failAt(check.repeating, "malformed XML: <%s> has the attribute \"%s\" more than once",
                   check.repeating.name(), check.repeated);
    }

    // Before any object is built: the OBJ file that each <mesh type="obj"> names is counted
    // (once per file, without building anything) and announced to the load context, which then
    // keeps a file's mesh until every <mesh> naming it has it, and the text counted (checked and
    // prepared for tinyobjloader) until the first of them builds from it. A scene whose meshes
    // would take more memory than allowed is refused at the mesh from which on they do, naming the
    // whole scene's figures, and one whose files would take too long to triangulate at the mesh
    // whose file goes beyond kMaxSceneTriangulationWork. A mesh whose file cannot be named or
    // counted here is left to its plugin, which reports the problem where it belongs as the scene
    // is built.
    void checkGeometry(pugi::xml_document& doc) {
        struct Meshes : pugi::xml_tree_walker {
            std::vector<pugi::xml_node> nodes;
            bool for_each(pugi::xml_node& node) override {
                if (node.type() == pugi::node_element && std::string_view(node.name()) == "mesh")
                    nodes.push_back(node);
                return true;
            }
        } meshes;
        doc.traverse(meshes);
        const uint64_t limit =
            m_limits.maxGeometryBytes ? m_limits.maxGeometryBytes : physicalMemoryBytes();
        std::map<std::string, std::optional<ObjCounts>> counted;  // by resolved path
        uint64_t meshCount = 0, triangles = 0, vertices = 0, bytes = 0, triangulationWork = 0;
        pugi::xml_node beyond;  // the mesh with which the total goes beyond the limit
        std::string beyondFile;
        ObjCounts beyondCounts;
        for (const pugi::xml_node& mesh : meshes.nodes) {
            std::string filename, path;
            try {
                if (attr(mesh, "type") != "obj") continue;
                for (const pugi::xml_node& child : mesh.children("string"))
                    if (attr(child, "name") == "filename") filename = attr(child, "value");
                if (filename.empty()) continue;
                PropertyList resolver;
                resolver.setBaseDirectory(m_baseDirectory);
                resolver.setFileReferencePolicy(m_policy);
                path = resolver.resolvePath(filename);
            } catch (const std::exception&) {
                continue;
            }
            auto [entry, isNew] = counted.try_emplace(path);
            std::optional<ObjText> text;
            if (isNew) {
                try {
                    CountedObj file = countedAndPreparedObjFile(path);
                    entry->second = file.counts;
                    text = std::move(file.prepared);
                } catch (const Error&) {
                }
            }
            if (!entry->second) continue;
            const ObjCounts& counts = *entry->second;
            // A file's mesh is built once for all the <mesh> elements naming it.
            if (isNew) triangulationWork += counts.triangulationWork;
            if (triangulationWork > kMaxSceneTriangulationWork)
                failAt(mesh,
                       "this mesh's OBJ file %s takes the scene beyond the triangulation work "
                       "allowed: the squares of the vertex counts of the faces of more than 4 "
                       "vertices in the scene's OBJ files add up to %u (this file %u), more than "
                       "%u (%d faces of %d vertices; triangulating a polygon takes time quadratic "
                       "in its vertices)",
                       filename, triangulationWork, counts.triangulationWork,
                       kMaxSceneTriangulationWork,
                       kMaxSceneTriangulationWork / (kMaxObjFaceVertices * kMaxObjFaceVertices),
                       kMaxObjFaceVertices);
            m_loadContext->announceObjFile(path);
            if (text) m_loadContext->keepObjText(path, std::move(*text));
            ++meshCount;
            triangles += counts.triangles;
            vertices += counts.vertices;
            bytes += counts.memoryBytes();
            if (bytes > limit && !beyond) {
                beyond = mesh;
                beyondFile = filename;
                beyondCounts = counts;
            }
        }
        if (!beyond) return;
        const std::string allowed =
            m_limits.maxGeometryBytes
                ? absl::StrFormat("the limit of %s%s", formatBytes(limit),
                                  m_limits.setting.empty() ? "" : " (" + m_limits.setting + ")")
                : absl::StrFormat("this machine's %s of memory", formatBytes(limit));
        throw ResourceLimitError(absl::StrFormat(
            "%s (mesh type=\"obj\"): from this mesh on, the scene's meshes need more memory than "
            "allowed: its %u meshes have %u triangles and %u vertices, which need about %s, more "
            "than %s; this mesh (%s) has %u triangles and %u vertices",
            location(beyond.offset_debug()), meshCount, triangles, vertices, formatBytes(bytes),
            allowed, beyondFile, beyondCounts.triangles, beyondCounts.vertices));
    }

    std::string location(ptrdiff_t offset) const {
        // The lines' starts are found once: every object names its line in its source, and
        // counting from the file's start for each made a scene of thousands of elements
        // quadratic (a second for 2000 meshes).
        if (m_lineStarts.empty()) {
            m_lineStarts.push_back(0);
            for (size_t i = 0; i < m_text.size(); ++i)
                if (m_text[i] == '\n') m_lineStarts.push_back(i + 1);
        }
        const size_t end =
            static_cast<size_t>(std::clamp<ptrdiff_t>(offset, 0, ptrdiff_t(m_text.size())));
        const size_t line =
            std::upper_bound(m_lineStarts.begin(), m_lineStarts.end(), end) - m_lineStarts.begin();
        return absl::StrFormat("%s:%d:%d", m_name, line, end - m_lineStarts[line - 1] + 1);
    }

    template <typename... Args>
    [[noreturn]] void failAt(const pugi::xml_node& node, const absl::FormatSpec<Args...>& format,
                             const Args&... args) const {
        throw Error(location(node.offset_debug()) + ": " + absl::StrFormat(format, args...));
    }

    void checkAttributes(const pugi::xml_node& node, std::initializer_list<const char*> allowed) {
        for (const pugi::xml_attribute& attr : node.attributes()) {
            bool ok = false;
            for (const char* name : allowed) ok |= std::strcmp(attr.name(), name) == 0;
            if (!ok)
                failAt(node, "<%s> does not take the attribute \"%s\"", node.name(), attr.name());
        }
        for (const char* name : allowed) {
            // "name" on objects is optional; everything else is required.
            bool optional = std::strcmp(name, "name") == 0 && kObjectTags.count(node.name());
            if (!optional && !node.attribute(name))
                failAt(node, "<%s> is missing the attribute \"%s\"", node.name(), name);
        }
    }

    // An attribute's value with every $name replaced by its -D value.
    std::string attr(const pugi::xml_node& node, const char* name) const {
        const std::string text = node.attribute(name).value();
        auto isNameCharacter = [](char c) {
            return std::isalnum(static_cast<unsigned char>(c)) || c == '_';
        };
        std::string out;
        for (size_t i = 0; i < text.size(); ++i) {
            if (text[i] != '$' || i + 1 == text.size() || !isNameCharacter(text[i + 1])) {
                out += text[i];
                continue;
            }
            size_t end = i + 1;
            while (end < text.size() && isNameCharacter(text[end])) ++end;
            const std::string parameter = text.substr(i + 1, end - i - 1);
            auto it = m_overrides.parameters.find(parameter);
            if (it == m_overrides.parameters.end()) {
                std::vector<std::string> defined;
                for (const auto& [known, value] : m_overrides.parameters) defined.push_back(known);
                const std::string intended = closestName(parameter, defined);
                failAt(node, "$%s in %s=\"%s\" is not defined (give it with -D %s=VALUE)%s",
                       parameter, name, text, parameter,
                       intended.empty() ? "" : absl::StrFormat("; did you mean $%s?", intended));
            }
            out += it->second;
            m_usedParameters.insert(parameter);
            i = end - 1;
        }
        return out;
    }

    float toFloat(const pugi::xml_node& node, const std::string& text) {
        std::string s(absl::StripAsciiWhitespace(text));
        // inf and nan are numbers here, so that the plugins' range checks refuse them naming
        // the parameter.
        const bool hasSign = !s.empty() && (s[0] == '-' || s[0] == '+');
        const std::string word = absl::AsciiStrToLower(absl::string_view(s).substr(hasSign));
        const bool infinityOrNan = word == "inf" || word == "infinity" || word == "nan";
        if (!infinityOrNan && !isDecimalNumber(s))
            failAt(node, "could not parse the number \"%s\" (numbers are decimal)", text);
        return std::strtof(s.c_str(), nullptr);
    }

    int toInt(const pugi::xml_node& node, const std::string& text) {
        std::string s(absl::StripAsciiWhitespace(text));
        char* end = nullptr;
        errno = 0;
        long v = std::strtol(s.c_str(), &end, 10);
        if (s.empty() || *end != '\0' || errno == ERANGE || v < INT32_MIN || v > INT32_MAX)
            failAt(node, "could not parse the integer \"%s\"", text);
        return static_cast<int>(v);
    }

    bool toBool(const pugi::xml_node& node, const std::string& text) {
        std::string s = absl::AsciiStrToLower(absl::StripAsciiWhitespace(text));
        if (s == "true") return true;
        if (s == "false") return false;
        failAt(node, "could not parse the boolean \"%s\" (expected true or false)", text);
    }

    std::vector<float> toFloats(const pugi::xml_node& node, const std::string& text) {
        std::vector<float> values;
        for (absl::string_view token :
             absl::StrSplit(text, absl::ByAnyChar(", \t\r\n"), absl::SkipEmpty()))
            values.push_back(toFloat(node, std::string(token)));
        return values;
    }

    // Points and vectors place things in the scene: a position of NaN, inf or beyond 1e15 would
    // send rays Embree refuses (it aborts the process on them).
    static constexpr float kMaxTransformEntry = 1e15f;
    Vector3f toVector3f(const pugi::xml_node& node, const std::string& text) {
        std::vector<float> v = toFloats(node, text);
        if (v.size() != 3) failAt(node, "expected 3 values, got \"%s\"", text);
        const Vector3f vector(v[0], v[1], v[2]);
        // allFinite first: Eigen's maxCoeff can pass over a NaN that is not the first
        // component ("2,nan,6" passed, and lookat reported its origin and target coinciding).
        if (!vector.allFinite() || !(vector.cwiseAbs().maxCoeff() <= kMaxTransformEntry))
            failAt(node, "\"%s\" must have finite components within +-%g", text,
                   kMaxTransformEntry);
        return vector;
    }

    Color3f toColor(const pugi::xml_node& node, const std::string& text) {
        std::vector<float> v = toFloats(node, text);
        if (v.size() == 1) return Color3f(v[0]);
        if (v.size() != 3) failAt(node, "expected 1 or 3 colour values, got \"%s\"", text);
        return Color3f(v[0], v[1], v[2]);
    }

    // Applies a transform operation after those already accumulated (Nori's order).
    Matrix4f transformOp(const pugi::xml_node& node, Tag tag) {
        Eigen::Affine3f op = Eigen::Affine3f::Identity();
        switch (tag) {
            case Tag::Translate:
                checkAttributes(node, {"value"});
                op = Eigen::Translation3f(toVector3f(node, attr(node, "value")));
                break;
            case Tag::Scale:
                checkAttributes(node, {"value"});
                op = Eigen::DiagonalMatrix<float, 3>(toVector3f(node, attr(node, "value")));
                break;
            case Tag::Rotate: {
                checkAttributes(node, {"angle", "axis"});
                float angle = degToRad(toFloat(node, attr(node, "angle")));
                Vector3f axis = toVector3f(node, attr(node, "axis"));
                if (!(axis.norm() > 0.0f)) failAt(node, "the rotation axis is zero");
                op = Eigen::AngleAxisf(angle, axis.normalized());
                break;
            }
            case Tag::Matrix: {
                checkAttributes(node, {"value"});
                std::vector<float> v = toFloats(node, attr(node, "value"));
                if (v.size() != 16) failAt(node, "a matrix needs 16 values, got %zu", v.size());
                Matrix4f m;
                for (int i = 0; i < 4; ++i)
                    for (int j = 0; j < 4; ++j) m(i, j) = v[i * 4 + j];
                return m;
            }
            case Tag::LookAt: {
                checkAttributes(node, {"origin", "target", "up"});
                Vector3f origin = toVector3f(node, attr(node, "origin"));
                Vector3f target = toVector3f(node, attr(node, "target"));
                Vector3f up = toVector3f(node, attr(node, "up"));
                Vector3f dir = target - origin;
                if (!(dir.norm() > 0.0f)) failAt(node, "lookat origin and target coincide");
                dir.normalize();
                Vector3f left = up.normalized().cross(dir);
                if (!(left.norm() > 0.0f) || !left.allFinite())
                    failAt(node, "lookat up vector is zero or parallel to the view direction");
                left.normalize();
                Vector3f newUp = dir.cross(left).normalized();
                Matrix4f m = Matrix4f::Identity();
                m.block<3, 1>(0, 0) = left;
                m.block<3, 1>(0, 1) = newUp;
                m.block<3, 1>(0, 2) = dir;
                m.block<3, 1>(0, 3) = origin;
                return m;
            }
            default:
                break;
        }
        return op.matrix();
    }

    std::shared_ptr<Object> parseObject(const pugi::xml_node& node) {
        ObjectKind kind = kObjectTags.at(node.name());
        if (kind == ObjectKind::Scene)
            checkAttributes(node, {"name"});
        else
            checkAttributes(node, {"type", "name"});
        std::string type = kind == ObjectKind::Scene ? "scene" : attr(node, "type");

        std::string where = location(node.offset_debug());
        PropertyList props(kind == ObjectKind::Scene
                               ? where + " (scene)"
                               : absl::StrFormat("%s (%s type=\"%s\")", where, node.name(), type));
        props.setBaseDirectory(m_baseDirectory);
        props.setFileReferencePolicy(m_policy);
        props.setDependencyLog(m_dependencies);
        props.setLoadContext(m_loadContext);

        std::vector<std::pair<std::shared_ptr<Object>, std::string>> children;
        std::map<std::string, ptrdiff_t> propertyOffsets;  // where each property was written
        for (const pugi::xml_node& child : node.children()) {
            if (child.type() == pugi::node_comment || child.type() == pugi::node_declaration)
                continue;
            if (child.type() != pugi::node_element) {
                if (std::string(absl::StripAsciiWhitespace(child.value())).empty()) continue;
                failAt(child, "unexpected text \"%s\" inside <%s>", child.value(), node.name());
            }
            std::string tag = child.name();
            if (kObjectTags.count(tag)) {
                if (tag == "scene" && kind != ObjectKind::Test)
                    failAt(child, "<scene> can only be nested in a <test>");
                children.emplace_back(parseObject(child), attr(child, "name"));
            } else if (kPropertyTags.count(tag)) {
                // --size replaces the camera's image size, written or not.
                if (kind == ObjectKind::Camera && m_overrides.imageSize &&
                    (attr(child, "name") == "width" || attr(child, "name") == "height"))
                    continue;
                parseProperty(child, kPropertyTags.at(tag), props);
                propertyOffsets.emplace(attr(child, "name"), child.offset_debug());
            } else {
                std::vector<std::string> known;
                for (const auto& [name, ignored] : kObjectTags) known.push_back(name);
                for (const auto& [name, ignored] : kPropertyTags) known.push_back(name);
                const std::string intended = closestName(tag, known);
                if (!intended.empty())
                    failAt(child, "unknown element <%s>; did you mean <%s>?", tag, intended);
                failAt(child, "unknown element <%s>", tag);
            }
        }

        if (kind == ObjectKind::Camera && m_overrides.imageSize) {
            props.setInteger("width", m_overrides.imageSize->x());
            props.setInteger("height", m_overrides.imageSize->y());
        }
        if (m_mode == ParseMode::ListFiles) {
            ObjectFactory::listFiles(kind, type, props);
            return nullptr;
        }
        std::shared_ptr<Object> object = ObjectFactory::create(kind, type, props);
        if (object->kind() != kind) failAt(node, "type \"%s\" is not a %s", type, node.name());
        object->setDefinition(definitionOf(node, true));
        for (auto& [child, name] : children) object->addChild(child, name);
        object->activate();
        // A property the plugin never read is most likely misspelt: when it is close to one the
        // plugin asked for, that is certain enough to refuse the scene (rendering it would
        // silently use the default); otherwise it may be meant for another renderer, so warn.
        const std::string element = kind == ObjectKind::Scene
                                        ? "<scene>"
                                        : absl::StrFormat("<%s type=\"%s\">", node.name(), type);
        for (const std::string& unused : props.unusedNames()) {
            const std::string where = location(propertyOffsets.at(unused));
            const std::string intended = closestName(unused, props.requestedNames());
            if (!intended.empty())
                fail("%s: %s has no property \"%s\"; did you mean \"%s\"?", where, element, unused,
                     intended);
            warn("%s: property \"%s\" of %s is not used", where, unused, element);
        }
        return object;
    }

    // An element as written, for Object::definition: its tag, its attributes (all but the name
    // its parent takes it under) and its elements, recursively; comments and whitespace are not
    // part of it. Values are prefixed by their length, so no value can pass for others. -D
    // parameters are substituted later, the same way in equal text.
    static std::string definitionOf(const pugi::xml_node& node, bool top) {
        std::string out = node.name();
        for (const pugi::xml_attribute& attribute : node.attributes()) {
            if (top && std::string_view(attribute.name()) == "name") continue;
            const std::string value = attribute.value();
            absl::StrAppend(&out, " ", attribute.name(), "=", value.size(), ":", value);
        }
        out += "{";
        for (const pugi::xml_node& child : node.children())
            if (child.type() == pugi::node_element) out += definitionOf(child, false);
        out += "}";
        return out;
    }

    void parseProperty(const pugi::xml_node& node, Tag tag, PropertyList& props) {
        if (tag == Tag::Transform) {
            checkAttributes(node, {"name"});
            Matrix4f m = Matrix4f::Identity();
            for (const pugi::xml_node& op : node.children()) {
                if (op.type() == pugi::node_comment) continue;
                if (op.type() != pugi::node_element)
                    failAt(op, "unexpected text inside <transform>");
                auto it = kPropertyTags.find(op.name());
                if (it == kPropertyTags.end() || it->second < Tag::Translate)
                    failAt(op,
                           "<%s> is not a transform operation (translate, scale, rotate, "
                           "lookat, matrix)",
                           op.name());
                m = transformOp(op, it->second) * m;
            }
            // Normals, cameras and 3D textures use the inverse: a transform without one (a
            // zero scale collapses space onto a plane) cannot be rendered. Tiny and huge scales
            // can (Transform inverts those in double, where their determinant still lives).
            const Transform transform(m);
            if (!m.allFinite() || !transform.inverseMatrix().allFinite())
                failAt(node, "the transform \"%s\" is %s", attr(node, "name"),
                       m.allFinite() ? "singular (it collapses space onto a plane, a line or a "
                                       "point) or so near it that its inverse exceeds the float "
                                       "range"
                                     : "not finite");
            // Embree refuses (aborts on) rays whose origin lies beyond about 1.8e18; a camera or
            // light placed or scaled past 1e15 would send such rays.
            if (m.cwiseAbs().maxCoeff() > kMaxTransformEntry)
                failAt(node,
                       "the transform \"%s\" has an entry beyond %g; scenes must fit "
                       "within +-%g",
                       attr(node, "name"), kMaxTransformEntry, kMaxTransformEntry);
            failIfDuplicate(node, props);
            props.setTransform(attr(node, "name"), transform);
            return;
        }
        if (tag >= Tag::Translate) failAt(node, "<%s> must be inside a <transform>", node.name());
        checkAttributes(node, {"name", "value"});
        std::string name = attr(node, "name"), value = attr(node, "value");
        failIfDuplicate(node, props);
        try {
            switch (tag) {
                case Tag::Boolean:
                    props.setBoolean(name, toBool(node, value));
                    break;
                case Tag::Integer:
                    props.setInteger(name, toInt(node, value));
                    break;
                case Tag::Float:
                    props.setFloat(name, toFloat(node, value));
                    break;
                case Tag::String:
                    props.setString(name, value);
                    break;
                case Tag::Point:
                    props.setPoint(name, toVector3f(node, value));
                    break;
                case Tag::Vector:
                    props.setVector(name, toVector3f(node, value));
                    break;
                case Tag::Color:
                    props.setColor(name, toColor(node, value));
                    break;
                default:
                    break;
            }
        } catch (const Error& e) {
            // Re-anchor errors from the property list at this element (duplicates never get
            // here: failIfDuplicate reports them first).
            std::string message = e.what();
            if (message.rfind(m_name, 0) == 0) throw;
            failAt(node, "%s", message);
        }
    }

    // A repeated property is reported at the repeat, where the user has to look.
    void failIfDuplicate(const pugi::xml_node& node, const PropertyList& props) const {
        const std::string name = attr(node, "name");
        if (props.has(name)) failAt(node, "property \"%s\" was specified more than once", name);
    }

    std::string m_path;  // where the scene file is read from
    std::string m_name;
    FileReferencePolicy m_policy;
    SceneOverrides m_overrides;
    SceneLimits m_limits;
    ParseMode m_mode;
    std::shared_ptr<SceneLoadContext> m_loadContext = std::make_shared<SceneLoadContext>();
    mutable std::set<std::string> m_usedParameters;  // the -D names some $name referred to
    std::string m_text;
    mutable std::vector<size_t> m_lineStarts;  // of m_text, made by location()
    std::string m_baseDirectory;
    std::shared_ptr<std::vector<std::string>> m_dependencies =
        std::make_shared<std::vector<std::string>>();
};

}  // namespace

SceneFileNaming nameSceneFile(const std::string& path, const FileReferencePolicy& policy) {
    namespace fs = std::filesystem;
    SceneFileNaming naming{path, path, policy};
    if (policy.confinementRoot.empty()) return naming;
    fs::path root = fs::absolute(policy.confinementRoot).lexically_normal();
    if (root.filename().empty()) root = root.parent_path();  // a trailing '/'
    naming.policy.confinementRoot = root.string();
    const fs::path scene = fs::absolute(path).lexically_normal();
    const fs::path inRoot = scene.lexically_relative(root);
    naming.path = scene.string();
    naming.name = inRoot.generic_string();
    if (inRoot.empty() || *inRoot.begin() == "..")
        fail("%s: the scene file lies outside the directory its files are confined to",
             scene.filename().string());
    return naming;
}

// Plugins name the files they could not read by their full path; inside a confinement root
// that is where the server keeps the bundle, which is none of the user's business.
std::string SceneFileNaming::withoutConfinementRoot(std::string message) const {
    if (policy.confinementRoot.empty()) return message;
    std::vector<std::string> roots{policy.confinementRoot};
    std::error_code error;
    const std::string real = std::filesystem::canonical(policy.confinementRoot, error).string();
    if (!error && real != roots.front()) roots.push_back(real);
    for (const std::string& root : roots)
        if (root != "/") message = absl::StrReplaceAll(message, {{root + "/", ""}, {root, "."}});
    return message;
}

std::string readSceneFileText(const std::string& path, const std::string& name) {
    std::error_code statusError;
    const auto status = std::filesystem::status(path, statusError);
    if (std::filesystem::is_directory(status)) fail("%s: is a directory, not a scene file", name);
    if (std::filesystem::exists(status) && !std::filesystem::is_regular_file(status))
        fail("%s: is a named pipe, socket or device, not a scene file", name);
    std::ifstream file(path, std::ios::binary);
    if (!file) fail("%s: cannot open the scene file: %s", name, std::strerror(errno));
    std::stringstream buffer;
    buffer << file.rdbuf();
    return buffer.str();
}

bool isPbrtSceneFile(const std::string& path) {
    return std::filesystem::path(path).extension() == ".pbrt";
}

ParseResult parseSceneFile(const std::string& path, const FileReferencePolicy& policy,
                           const SceneOverrides& overrides, const SceneLimits& limits,
                           SceneUse use) {
    if (isPbrtSceneFile(path))
        return pbrt::parsePbrtSceneFile(path, policy, overrides, limits, use);
    return Parser(path, policy, overrides, limits, use, ParseMode::Build).parse();
}

std::vector<std::string> listSceneFiles(const std::string& path,
                                        const FileReferencePolicy& policy) {
    if (isPbrtSceneFile(path)) return pbrt::listPbrtSceneFiles(path, policy);
    return Parser(path, policy, {}, {}, SceneUse::Check, ParseMode::ListFiles).parse().dependencies;
}

std::shared_ptr<Scene> loadScene(const std::string& path, const FileReferencePolicy& policy,
                                 const SceneOverrides& overrides, const SceneLimits& limits,
                                 SceneUse use) {
    if (isPbrtSceneFile(path))
        return std::static_pointer_cast<Scene>(
            pbrt::parsePbrtSceneFile(path, policy, overrides, limits, use).root);
    Parser parser(path, policy, overrides, limits, use, ParseMode::Build);
    ParseResult result = parser.parse();
    if (result.root->kind() != ObjectKind::Scene)
        fail("%s: expected a <scene> root element, found <%s>", parser.name(),
             kindTag(result.root->kind()));
    return std::static_pointer_cast<Scene>(result.root);
}

}  // namespace alphorn
