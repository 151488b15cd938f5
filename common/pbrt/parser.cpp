#include "common/pbrt/parser.h"

#include "common/core/error.h"
#include "common/core/spectrum.h"
#include "common/core/warning.h"
#include "common/scene/parser.h"

#include <absl/strings/str_cat.h>
#include <absl/strings/str_format.h>
#include <absl/strings/str_join.h>

#include <charconv>
#include <cmath>
#include <deque>
#include <filesystem>
#include <set>
#include <sstream>

namespace alphorn::pbrt {
namespace {

// Includes nest a few levels in real scenes; a file that includes itself would never end.
constexpr int kMaxIncludeDepth = 32;
// AttributeBegin nests a few levels too; a file of a million of them would hold a million states.
constexpr size_t kMaxAttributeDepth = 4096;

// The graphics state pbrt-v4 keeps between directives and saves at AttributeBegin.
struct GraphicsState {
    // The transforms at the shutter's open and close; equal unless the scene animates.
    Eigen::Matrix4d ctm[2] = {Eigen::Matrix4d::Identity(), Eigen::Matrix4d::Identity()};
    bool activeTransform[2] = {true, true};
    bool reverseOrientation = false;
    int materialIndex = -1;  // -1 with an empty name: the default material
    std::string materialName;
    std::optional<Entity> areaLight;
    std::string insideMedium, outsideMedium;
    // Attribute "shape" | "light" | "material" | "medium" | "texture": defaults for the
    // parameters of later entities of that kind.
    std::map<std::string, ParameterList> attributes;
};

const std::set<std::string> kParameterTypes = {
    "integer", "float",  "point2",  "vector2", "point3",   "vector3",   "normal3",
    "bool",    "string", "texture", "rgb",     "spectrum", "blackbody",
};

// pbrt-v3's and pbrt-v4's other spellings of the same types.
std::string canonicalType(const std::string& type) {
    if (type == "point") return "point3";
    if (type == "vector") return "vector3";
    if (type == "normal") return "normal3";
    if (type == "color") return "rgb";
    return type;
}

class Parser {
  public:
    Parser(const std::string& displayName, const PropertyList& resolver)
        : m_mainName(displayName), m_resolver(resolver) {
        m_states.emplace_back();
    }

    SceneDescription run(std::string text, const std::string& name) {
        pushFile(std::move(text), name);
        Token token;
        while (nextToken(token)) directive(token);
        if (m_states.size() > 1)
            warn("%s: %d AttributeBegin without a matching AttributeEnd at the end of the scene",
                 m_mainName, m_states.size() - 1);
        if (m_inInstance) failAt(m_instanceStart, "ObjectBegin without a matching ObjectEnd");
        checkReferences();
        return std::move(m_scene);
    }

  private:
    struct OpenFile {
        std::unique_ptr<std::string> text;
        std::unique_ptr<Tokenizer> tokenizer;
    };

    void pushFile(std::string text, const std::string& name) {
        OpenFile file;
        file.text = std::make_unique<std::string>(std::move(text));
        file.tokenizer =
            std::make_unique<Tokenizer>(*file.text, std::make_shared<const std::string>(name));
        m_files.push_back(std::move(file));
    }

    // The next token of the innermost open file; a file's end returns to its includer.
    bool nextToken(Token& token) {
        if (m_peeked) {
            token = *m_peeked;
            m_peeked.reset();
            return true;
        }
        while (!m_files.empty()) {
            if (m_files.back().tokenizer->next(token)) return true;
            // Its tokens' text dies with it, so nothing may hold one: parameters copy their
            // values, and a directive's tokens are used before the next file is opened.
            m_files.pop_back();
        }
        return false;
    }

    bool peekToken(Token& token) {
        if (!m_peeked) {
            Token next;
            // Peeking does not cross into the includer: a directive's parameters end with its file.
            if (m_files.empty() || !m_files.back().tokenizer->next(next)) return false;
            m_peeked = next;
        }
        token = *m_peeked;
        return true;
    }

    Token expectToken(const Token& after, const char* what) {
        Token token;
        if (!peekToken(token))
            failAt(after.location,
                   absl::StrFormat("%s needs %s; the file ends first", after.text, what));
        m_peeked.reset();
        return token;
    }

    std::string expectString(const Token& directive, const char* what) {
        Token token = expectToken(directive, what);
        if (!token.isString())
            failAt(token.location, absl::StrFormat("%s needs %s (a quoted string), found %s",
                                                   directive.text, what, token.text));
        return token.stringValue();
    }

    double parseNumber(const Token& token, const std::string& context) {
        double value = 0;
        const char* begin = token.text.data();
        const char* end = begin + token.text.size();
        // from_chars takes no leading '+', which pbrt's files may write.
        if (begin != end && *begin == '+') ++begin;
        auto [ptr, ec] = std::from_chars(begin, end, value);
        if (ec != std::errc() || ptr != end || !std::isfinite(value))
            failAt(token.location, absl::StrFormat("%s: \"%s\" is not a finite number", context,
                                                   std::string(token.text)));
        return value;
    }

    // `count` numbers after the directive (Translate x y z, ...).
    std::vector<double> numbers(const Token& directive, int count) {
        std::vector<double> values;
        for (int i = 0; i < count; ++i) {
            Token token = expectToken(directive, absl::StrFormat("%d numbers", count).c_str());
            values.push_back(parseNumber(token, std::string(directive.text)));
        }
        return values;
    }

    // The numbers of Transform and ConcatTransform: 16, with or without brackets.
    std::vector<double> matrixNumbers(const Token& directive) {
        Token token;
        if (peekToken(token) && token.text == "[") {
            m_peeked.reset();
            std::vector<double> values = numbers(directive, 16);
            Token close = expectToken(directive, "a closing ]");
            if (close.text != "]")
                failAt(close.location, absl::StrFormat("%s takes 16 numbers; expected ] after "
                                                       "them, found %s",
                                                       directive.text, close.text));
            return values;
        }
        return numbers(directive, 16);
    }

    ParameterList parameters() {
        ParameterList list;
        Token token;
        while (peekToken(token) && token.isString()) {
            m_peeked.reset();
            const std::string declaration = token.stringValue();
            std::istringstream words(declaration);
            std::string type, name, extra;
            words >> type >> name >> extra;
            if (type.empty() || name.empty() || !extra.empty())
                failAt(token.location,
                       absl::StrFormat("\"%s\" is not a parameter declaration (\"TYPE NAME\", e.g. "
                                       "\"float radius\")",
                                       declaration));
            Parameter p;
            p.type = canonicalType(type);
            p.name = name;
            p.location = token.location;
            if (!kParameterTypes.count(p.type))
                failAt(token.location,
                       absl::StrFormat("\"%s\": unknown parameter type \"%s\" (types: %s)",
                                       declaration, type, absl::StrJoin(kParameterTypes, ", ")));
            // pbrt-v4 reads the first of repeated parameters (and the public corpus repeats some),
            // so the later ones are read, checked and dropped, with a warning.
            const bool repeated = list.has(name);
            std::vector<Token> values;
            Token value = expectToken(token, "a value");
            if (value.text == "[") {
                for (;;) {
                    Token item = expectToken(token, "a closing ]");
                    if (item.text == "]") break;
                    if (item.text == "[")
                        failAt(item.location, "a '[' inside a parameter's values");
                    values.push_back(item);
                }
            } else if (value.text == "]") {
                failAt(value.location, "a ']' without a '['");
            } else {
                values.push_back(value);
            }
            readValues(p, values);
            if (p.type == "spectrum" && p.strings.size() == 1 &&
                !namedSpectrumRgb(p.strings[0], SpectrumUse::Unbounded))
                readSpectrumFile(p);
            if (repeated)
                warn(
                    "%s: parameter \"%s\" is given more than once; the first value is used, as "
                    "pbrt-v4 uses it",
                    token.location.toString(), name);
            else
                list.add(std::move(p));
        }
        return list;
    }

    // A spectrum named by a file (pbrt's .spd: wavelength and value pairs, '#' comments) is read
    // here, through the scene's file policy, so the farm bundles it with the scene; the parameter
    // then holds its numbers as if they were written inline.
    void readSpectrumFile(Parameter& p) {
        const std::string file = p.strings[0];
        std::string path, text;
        try {
            path = m_resolver.resolvePath(file);
            text = readSceneFileText(path, file);
        } catch (const Error& e) {
            failAt(p.location, absl::StrFormat("\"%s\": \"%s\" is neither a named spectrum nor a "
                                               "readable spectrum file: %s",
                                               p.describe(), file, e.what()));
        }
        Tokenizer tokenizer(text, std::make_shared<const std::string>(file));
        Token token;
        p.strings.clear();
        while (tokenizer.next(token))
            p.numbers.push_back(parseNumber(token, "spectrum file " + file));
        if (p.numbers.size() < 4 || p.numbers.size() % 2 != 0)
            failAt(p.location, absl::StrFormat("\"%s\": the spectrum file \"%s\" holds %d numbers, "
                                               "not (wavelength, value) pairs",
                                               p.describe(), file, p.numbers.size()));
    }

    void readValues(Parameter& p, const std::vector<Token>& values) {
        const std::string context = absl::StrCat("\"", p.describe(), "\"");
        const bool numeric = p.type == "integer" || p.type == "float" || p.type == "point2" ||
                             p.type == "vector2" || p.type == "point3" || p.type == "vector3" ||
                             p.type == "normal3" || p.type == "rgb" || p.type == "blackbody";
        for (const Token& value : values) {
            if (p.type == "bool") {
                const std::string word =
                    value.isString() ? value.stringValue() : std::string(value.text);
                if (word != "true" && word != "false")
                    failAt(value.location,
                           absl::StrFormat("%s: \"%s\" is not true or false", context, word));
                p.bools.push_back(word == "true");
            } else if (p.type == "string" || p.type == "texture") {
                if (!value.isString())
                    failAt(value.location,
                           absl::StrFormat("%s: %s is not a quoted string", context, value.text));
                p.strings.push_back(value.stringValue());
            } else if (p.type == "spectrum" && value.isString()) {
                if (values.size() != 1)
                    failAt(value.location,
                           absl::StrFormat("%s: a named spectrum is one string", context));
                p.strings.push_back(value.stringValue());
            } else if (numeric || p.type == "spectrum") {
                if (value.isString())
                    failAt(value.location, absl::StrFormat("%s: %s is a string, not a number",
                                                           context, value.text));
                const double number = parseNumber(value, context);
                if (p.type == "integer" &&
                    (number != std::floor(number) || std::abs(number) > 2147483647.0))
                    failAt(value.location,
                           absl::StrFormat("%s: %s is not an integer within +-2147483647", context,
                                           value.text));
                p.numbers.push_back(number);
            }
        }
        if (values.empty()) failAt(p.location, absl::StrFormat("%s has no value", context));
        if (p.type == "point2" || p.type == "vector2") {
            if (p.numbers.size() % 2 != 0)
                failAt(p.location, absl::StrFormat("%s has %d numbers, not a multiple of 2",
                                                   context, p.numbers.size()));
        } else if (p.type == "point3" || p.type == "vector3" || p.type == "normal3" ||
                   p.type == "rgb") {
            if (p.numbers.size() % 3 != 0)
                failAt(p.location, absl::StrFormat("%s has %d numbers, not a multiple of 3",
                                                   context, p.numbers.size()));
        }
    }

    GraphicsState& state() { return m_states.back(); }

    // Applies `m` after the current transform (pbrt's CTM = CTM * m) in the active slots.
    void concatenate(const Eigen::Matrix4d& m) {
        for (int i = 0; i < 2; ++i)
            if (state().activeTransform[i]) state().ctm[i] = state().ctm[i] * m;
    }
    void setTransform(const Eigen::Matrix4d& m) {
        for (int i = 0; i < 2; ++i)
            if (state().activeTransform[i]) state().ctm[i] = m;
    }

    // The transform an entity sees; a scene whose transforms move during the shutter would need
    // motion blur, which Alphorn does not render.
    Eigen::Matrix4d placement(const Token& directive) {
        if (state().ctm[0] != state().ctm[1])
            failAt(directive.location,
                   absl::StrFormat("%s: the transform differs between ActiveTransform StartTime "
                                   "and EndTime (motion blur), which Alphorn does not render",
                                   directive.text));
        return state().ctm[0];
    }

    // Adds the Attribute defaults of `category` that the entity does not give itself.
    void addAttributes(Entity& entity, const std::string& category) {
        auto it = state().attributes.find(category);
        if (it == state().attributes.end()) return;
        for (const Parameter& p : it->second.all())
            if (!entity.parameters.has(p.name)) entity.parameters.add(p);
    }

    Entity entity(const Token& directive, const std::string& category) {
        Entity e;
        e.directive = std::string(directive.text);
        e.location = directive.location;
        e.type = expectString(directive, "a type name");
        e.parameters = parameters();
        if (!category.empty()) addAttributes(e, category);
        return e;
    }

    void requireWorld(const Token& directive, bool inWorld) {
        if (inWorld && !m_inWorld)
            failAt(directive.location,
                   absl::StrFormat("%s is only allowed after WorldBegin", directive.text));
        if (!inWorld && m_inWorld)
            failAt(directive.location,
                   absl::StrFormat("%s is only allowed before WorldBegin", directive.text));
    }

    static Eigen::Matrix4d fromColumnMajor(const std::vector<double>& v) {
        Eigen::Matrix4d m;
        for (int column = 0; column < 4; ++column)
            for (int row = 0; row < 4; ++row) m(row, column) = v[column * 4 + row];
        return m;
    }

    void checkInvertible(const Token& directive, const Eigen::Matrix4d& m) {
        const Eigen::Matrix4d inverse = m.inverse();
        if (!m.allFinite() || !inverse.allFinite() || m.determinant() == 0.0)
            failAt(directive.location,
                   absl::StrFormat("%s: the matrix is singular (it collapses space onto a plane, "
                                   "line or point), so normals and rays could not be taken "
                                   "through it",
                                   directive.text));
    }

    void directive(const Token& token) {
        const std::string name(token.text);
        if (token.isString() || name == "[" || name == "]")
            failAt(token.location,
                   absl::StrFormat("expected a directive (Shape, Material, ...), found %s", name));
        if (name == "AttributeBegin" || name == "TransformBegin") {
            if (m_states.size() >= kMaxAttributeDepth)
                failAt(token.location, absl::StrFormat("%s nests more than %d levels deep", name,
                                                       kMaxAttributeDepth));
            GraphicsState copy = state();
            m_states.push_back(std::move(copy));
            m_transformOnly.push_back(name == "TransformBegin");
        } else if (name == "AttributeEnd" || name == "TransformEnd") {
            if (m_states.size() <= m_instanceDepth + 1)
                failAt(token.location, absl::StrFormat("%s without a matching %s", name,
                                                       name == "AttributeEnd" ? "AttributeBegin"
                                                                              : "TransformBegin"));
            const bool transformOnly = m_transformOnly.back();
            if (transformOnly != (name == "TransformEnd"))
                failAt(token.location,
                       absl::StrFormat("%s closes %s", name,
                                       transformOnly ? "a TransformBegin" : "an AttributeBegin"));
            GraphicsState inner = std::move(m_states.back());
            m_states.pop_back();
            m_transformOnly.pop_back();
            if (transformOnly) {
                // TransformEnd restores the transform only.
                Eigen::Matrix4d start = state().ctm[0], end = state().ctm[1];
                state() = std::move(inner);
                state().ctm[0] = start;
                state().ctm[1] = end;
            }
        } else if (name == "Attribute") {
            const std::string category = expectString(token, "a category");
            static const std::set<std::string> kCategories = {"shape", "light", "material",
                                                              "medium", "texture"};
            if (!kCategories.count(category))
                failAt(token.location,
                       absl::StrFormat("Attribute \"%s\": the category must be shape, light, "
                                       "material, medium or texture",
                                       category));
            ParameterList list = parameters();
            ParameterList& defaults = state().attributes[category];
            ParameterList merged;
            for (const Parameter& p : list.all()) merged.add(p);
            for (const Parameter& p : defaults.all())
                if (!list.has(p.name)) merged.add(p);
            defaults = std::move(merged);
        } else if (name == "ActiveTransform") {
            Token which = expectToken(token, "StartTime, EndTime or All");
            if (which.text == "StartTime") {
                state().activeTransform[0] = true;
                state().activeTransform[1] = false;
            } else if (which.text == "EndTime") {
                state().activeTransform[0] = false;
                state().activeTransform[1] = true;
            } else if (which.text == "All") {
                state().activeTransform[0] = state().activeTransform[1] = true;
            } else {
                failAt(which.location,
                       absl::StrFormat("ActiveTransform takes StartTime, EndTime or All, not %s",
                                       which.text));
            }
        } else if (name == "TransformTimes") {
            numbers(token, 2);
            warn("%s: TransformTimes is ignored: Alphorn renders no motion blur",
                 token.location.toString());
        } else if (name == "Identity") {
            setTransform(Eigen::Matrix4d::Identity());
        } else if (name == "Translate") {
            std::vector<double> v = numbers(token, 3);
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            m.block<3, 1>(0, 3) = Eigen::Vector3d(v[0], v[1], v[2]);
            concatenate(m);
        } else if (name == "Scale") {
            std::vector<double> v = numbers(token, 3);
            Eigen::Matrix4d m = Eigen::Vector4d(v[0], v[1], v[2], 1.0).asDiagonal();
            checkInvertible(token, m);
            concatenate(m);
        } else if (name == "Rotate") {
            std::vector<double> v = numbers(token, 4);
            const Eigen::Vector3d axis(v[1], v[2], v[3]);
            if (!(axis.norm() > 0.0)) failAt(token.location, "Rotate: the axis is zero");
            Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
            m.block<3, 3>(0, 0) =
                Eigen::AngleAxisd(v[0] * M_PI / 180.0, axis.normalized()).toRotationMatrix();
            concatenate(m);
        } else if (name == "LookAt") {
            std::vector<double> v = numbers(token, 9);
            const Eigen::Vector3d eye(v[0], v[1], v[2]), look(v[3], v[4], v[5]),
                up(v[6], v[7], v[8]);
            if (!((look - eye).norm() > 0.0))
                failAt(token.location, "LookAt: the eye and the point looked at coincide");
            const Eigen::Vector3d dir = (look - eye).normalized();
            if (!(up.norm() > 0.0) || !(up.normalized().cross(dir).norm() > 0.0))
                failAt(token.location,
                       "LookAt: the up vector is zero or parallel to the viewing direction");
            const Eigen::Vector3d right = up.normalized().cross(dir).normalized();
            const Eigen::Vector3d newUp = dir.cross(right);
            Eigen::Matrix4d worldFromCamera = Eigen::Matrix4d::Identity();
            worldFromCamera.block<3, 1>(0, 0) = right;
            worldFromCamera.block<3, 1>(0, 1) = newUp;
            worldFromCamera.block<3, 1>(0, 2) = dir;
            worldFromCamera.block<3, 1>(0, 3) = eye;
            concatenate(worldFromCamera.inverse());
        } else if (name == "Transform" || name == "ConcatTransform") {
            const Eigen::Matrix4d m = fromColumnMajor(matrixNumbers(token));
            checkInvertible(token, m);
            if (name == "Transform")
                setTransform(m);
            else
                concatenate(m);
        } else if (name == "CoordinateSystem") {
            const std::string system = expectString(token, "a name");
            m_coordinateSystems[system] = {state().ctm[0], state().ctm[1]};
        } else if (name == "CoordSysTransform") {
            const std::string system = expectString(token, "a name");
            auto it = m_coordinateSystems.find(system);
            if (it == m_coordinateSystems.end())
                failAt(token.location,
                       absl::StrFormat("CoordSysTransform: no coordinate system \"%s\" was "
                                       "defined (CoordinateSystem, or \"camera\" after Camera)",
                                       system));
            for (int i = 0; i < 2; ++i)
                if (state().activeTransform[i]) state().ctm[i] = it->second[i];
        } else if (name == "ReverseOrientation") {
            state().reverseOrientation = !state().reverseOrientation;
        } else if (name == "Option") {
            ParameterList options = parameters();
            for (const Parameter& p : options.all())
                warn("%s: Option \"%s\" is ignored", p.location.toString(), p.describe());
        } else if (name == "ColorSpace") {
            const std::string space = expectString(token, "a colour space name");
            if (space != "srgb")
                failAt(token.location,
                       absl::StrFormat("ColorSpace \"%s\": Alphorn renders in linear sRGB only",
                                       space));
        } else if (name == "Camera") {
            requireWorld(token, false);
            CameraEntity camera;
            static_cast<Entity&>(camera) = entity(token, "");
            camera.toWorld = placement(token).inverse();
            camera.medium = state().outsideMedium;
            // pbrt-v4 names the camera's space "camera" (worldFromCamera).
            m_coordinateSystems["camera"] = {camera.toWorld, camera.toWorld};
            m_scene.camera = std::move(camera);
        } else if (name == "Film" || name == "Sampler" || name == "Integrator" ||
                   name == "PixelFilter" || name == "Accelerator") {
            requireWorld(token, false);
            Entity e = entity(token, "");
            if (name == "Film") m_scene.film = std::move(e);
            if (name == "Sampler") m_scene.sampler = std::move(e);
            if (name == "Integrator") m_scene.integrator = std::move(e);
            if (name == "PixelFilter") m_scene.filter = std::move(e);
            if (name == "Accelerator")
                warn("%s: Accelerator \"%s\" is ignored: Alphorn traces rays with Embree's BVH",
                     token.location.toString(), e.type);
        } else if (name == "WorldBegin") {
            requireWorld(token, false);
            m_inWorld = true;
            state().ctm[0] = state().ctm[1] = Eigen::Matrix4d::Identity();
            m_coordinateSystems["world"] = {state().ctm[0], state().ctm[1]};
        } else if (name == "WorldEnd") {
            // pbrt-v3's end of the scene; pbrt-v4 reads it and ignores it.
        } else if (name == "Include" || name == "Import") {
            const std::string file = expectString(token, "a file name");
            include(token, file);
        } else if (name == "Material") {
            requireWorld(token, true);
            Entity e = entity(token, "material");
            m_scene.materials.push_back(std::move(e));
            state().materialIndex = int(m_scene.materials.size()) - 1;
            state().materialName.clear();
        } else if (name == "MakeNamedMaterial") {
            requireWorld(token, true);
            Entity e;
            e.directive = name;
            e.location = token.location;
            const std::string materialName = expectString(token, "a material name");
            e.parameters = parameters();
            addAttributes(e, "material");
            e.type = e.parameters.getString("type", "");
            if (e.type.empty())
                failAt(token.location,
                       absl::StrFormat("MakeNamedMaterial \"%s\" needs a \"string type\"",
                                       materialName));
            if (m_scene.namedMaterials.count(materialName))
                failAt(token.location,
                       absl::StrFormat("MakeNamedMaterial: \"%s\" is defined twice", materialName));
            m_scene.namedMaterials.emplace(materialName, std::move(e));
        } else if (name == "NamedMaterial") {
            requireWorld(token, true);
            const std::string materialName = expectString(token, "a material name");
            state().materialName = materialName;
            state().materialIndex = -1;
            m_namedMaterialUses.emplace_back(materialName, token.location);
        } else if (name == "Texture") {
            requireWorld(token, true);
            TextureEntity texture;
            texture.directive = name;
            texture.location = token.location;
            texture.name = expectString(token, "a texture name");
            texture.valueType = expectString(token, "a value type (float or spectrum)");
            if (texture.valueType != "float" && texture.valueType != "spectrum")
                failAt(token.location,
                       absl::StrFormat("Texture \"%s\": the value type must be float or "
                                       "spectrum, not \"%s\"",
                                       texture.name, texture.valueType));
            texture.type = expectString(token, "a texture class");
            texture.parameters = parameters();
            addAttributes(texture, "texture");
            texture.toWorld = placement(token);
            auto& textures = m_scene.textures[texture.valueType == "spectrum"];
            if (textures.count(texture.name))
                warn("%s: Texture \"%s\" is defined again; the later definition is used",
                     token.location.toString(), texture.name);
            textures[texture.name] = std::move(texture);
        } else if (name == "MakeNamedMedium") {
            MediumEntity medium;
            medium.directive = name;
            medium.location = token.location;
            medium.name = expectString(token, "a medium name");
            medium.parameters = parameters();
            addAttributes(medium, "medium");
            medium.type = medium.parameters.getString("type", "");
            if (medium.type.empty())
                failAt(
                    token.location,
                    absl::StrFormat("MakeNamedMedium \"%s\" needs a \"string type\"", medium.name));
            medium.toWorld = placement(token);
            m_scene.media[medium.name] = std::move(medium);
        } else if (name == "MediumInterface") {
            const std::string inside = expectString(token, "a medium name");
            std::string outside = inside;
            Token next;
            if (peekToken(next) && next.isString() &&
                next.stringValue().find(' ') == std::string::npos) {
                m_peeked.reset();
                outside = next.stringValue();
            }
            state().insideMedium = inside;
            state().outsideMedium = outside;
            for (const std::string& medium : {inside, outside})
                if (!medium.empty()) m_mediumUses.emplace_back(medium, token.location);
        } else if (name == "LightSource") {
            requireWorld(token, true);
            LightEntity light;
            static_cast<Entity&>(light) = entity(token, "light");
            light.toWorld = placement(token);
            light.medium = state().outsideMedium;
            m_scene.lights.push_back(std::move(light));
        } else if (name == "AreaLightSource") {
            requireWorld(token, true);
            state().areaLight = entity(token, "light");
        } else if (name == "Shape") {
            requireWorld(token, true);
            ShapeEntity shape;
            static_cast<Entity&>(shape) = entity(token, "shape");
            shape.toWorld = placement(token);
            shape.reverseOrientation = state().reverseOrientation;
            shape.materialIndex = state().materialIndex;
            shape.materialName = state().materialName;
            shape.areaLight = state().areaLight;
            shape.insideMedium = state().insideMedium;
            shape.outsideMedium = state().outsideMedium;
            if (m_inInstance)
                m_scene.instances[m_instanceName].shapes.push_back(std::move(shape));
            else
                m_scene.shapes.push_back(std::move(shape));
        } else if (name == "ObjectBegin") {
            requireWorld(token, true);
            const std::string instance = expectString(token, "an instance name");
            if (m_inInstance)
                failAt(token.location,
                       absl::StrFormat("ObjectBegin \"%s\" inside ObjectBegin \"%s\": instance "
                                       "definitions do not nest",
                                       instance, m_instanceName));
            if (m_scene.instances.count(instance))
                failAt(token.location,
                       absl::StrFormat("ObjectBegin: \"%s\" is defined twice", instance));
            // ObjectBegin opens an attribute block of its own, as in pbrt-v4.
            GraphicsState copy = state();
            m_states.push_back(std::move(copy));
            m_transformOnly.push_back(false);
            m_instanceDepth = m_states.size() - 1;
            m_inInstance = true;
            m_instanceName = instance;
            m_instanceStart = token.location;
            InstanceDefinition& definition = m_scene.instances[instance];
            definition.name = instance;
            definition.location = token.location;
        } else if (name == "ObjectEnd") {
            if (!m_inInstance) failAt(token.location, "ObjectEnd without ObjectBegin");
            if (m_states.size() != m_instanceDepth + 1)
                failAt(token.location,
                       "ObjectEnd inside an AttributeBegin block opened after "
                       "its ObjectBegin");
            m_states.pop_back();
            m_transformOnly.pop_back();
            m_inInstance = false;
            m_instanceDepth = 0;
        } else if (name == "ObjectInstance") {
            requireWorld(token, true);
            const std::string instance = expectString(token, "an instance name");
            if (m_inInstance) failAt(token.location, "ObjectInstance inside an ObjectBegin block");
            InstanceUse use;
            use.name = instance;
            use.location = token.location;
            use.toWorld = placement(token);
            m_scene.instanceUses.push_back(std::move(use));
        } else if (name == "MakeNamedCamera" || name == "CameraMedium") {
            failAt(token.location, absl::StrFormat("%s is not a pbrt-v4 directive", name));
        } else {
            static const std::vector<std::string> kDirectives = {"AttributeBegin",
                                                                 "AttributeEnd",
                                                                 "Attribute",
                                                                 "ActiveTransform",
                                                                 "AreaLightSource",
                                                                 "Accelerator",
                                                                 "Camera",
                                                                 "ColorSpace",
                                                                 "ConcatTransform",
                                                                 "CoordinateSystem",
                                                                 "CoordSysTransform",
                                                                 "Film",
                                                                 "Identity",
                                                                 "Import",
                                                                 "Include",
                                                                 "Integrator",
                                                                 "LightSource",
                                                                 "LookAt",
                                                                 "MakeNamedMaterial",
                                                                 "MakeNamedMedium",
                                                                 "Material",
                                                                 "MediumInterface",
                                                                 "NamedMaterial",
                                                                 "ObjectBegin",
                                                                 "ObjectEnd",
                                                                 "ObjectInstance",
                                                                 "Option",
                                                                 "PixelFilter",
                                                                 "ReverseOrientation",
                                                                 "Rotate",
                                                                 "Sampler",
                                                                 "Scale",
                                                                 "Shape",
                                                                 "Texture",
                                                                 "Transform",
                                                                 "TransformBegin",
                                                                 "TransformEnd",
                                                                 "TransformTimes",
                                                                 "Translate",
                                                                 "WorldBegin",
                                                                 "WorldEnd"};
            const std::string intended = closestName(name, kDirectives);
            failAt(token.location,
                   absl::StrFormat("unknown directive \"%s\"%s", name,
                                   intended.empty() ? "" : "; did you mean " + intended + "?"));
        }
    }

    void include(const Token& token, const std::string& file) {
        if (m_files.size() >= size_t(kMaxIncludeDepth))
            failAt(token.location,
                   absl::StrFormat("Include \"%s\": includes nest more than %d files deep (does "
                                   "a file include itself?)",
                                   file, kMaxIncludeDepth));
        std::string path;
        try {
            path = m_resolver.resolvePath(file);
        } catch (const Error& e) {
            failAt(token.location, absl::StrFormat("%s \"%s\": %s", token.text, file, e.what()));
        }
        std::string text;
        try {
            text = readSceneFileText(path, file);
        } catch (const Error& e) {
            failAt(token.location, e.what());
        }
        m_scene.includedFiles.push_back(path);
        m_peeked.reset();
        pushFile(std::move(text), file);
    }

    // After the files are read: names used before they were defined are defined by now.
    void checkReferences() {
        for (const auto& [material, location] : m_namedMaterialUses)
            if (!m_scene.namedMaterials.count(material))
                failAt(location, absl::StrFormat("NamedMaterial \"%s\" is not defined "
                                                 "(MakeNamedMaterial)",
                                                 material));
        for (const auto& [medium, location] : m_mediumUses)
            if (!m_scene.media.count(medium))
                failAt(location, absl::StrFormat("MediumInterface: the medium \"%s\" is not "
                                                 "defined (MakeNamedMedium)",
                                                 medium));
        for (const InstanceUse& use : m_scene.instanceUses)
            if (!m_scene.instances.count(use.name))
                failAt(use.location,
                       absl::StrFormat("ObjectInstance \"%s\" is not defined (ObjectBegin)",
                                       use.name));
    }

    std::string m_mainName;
    const PropertyList& m_resolver;
    std::vector<OpenFile> m_files;
    std::optional<Token> m_peeked;
    std::vector<GraphicsState> m_states;
    std::vector<bool> m_transformOnly;
    std::map<std::string, std::array<Eigen::Matrix4d, 2>> m_coordinateSystems;
    std::vector<std::pair<std::string, Location>> m_namedMaterialUses, m_mediumUses;
    bool m_inWorld = false;
    bool m_inInstance = false;
    size_t m_instanceDepth = 0;
    std::string m_instanceName;
    Location m_instanceStart;
    SceneDescription m_scene;
};

}  // namespace

SceneDescription parseSceneDescriptionText(std::string text, const std::string& displayName,
                                           const PropertyList& resolver) {
    Parser parser(displayName, resolver);
    return parser.run(std::move(text), displayName);
}

SceneDescription parseSceneDescription(const std::string& path, const std::string& displayName,
                                       const PropertyList& resolver) {
    Parser parser(displayName, resolver);
    return parser.run(readSceneFileText(path, displayName), displayName);
}

}  // namespace alphorn::pbrt
