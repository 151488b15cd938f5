#include "common/pbrt/create_scene.h"

#include "common/bsdf/bsdf.h"
#include "common/core/error.h"
#include "common/core/system_memory.h"
#include "common/core/warning.h"
#include "common/scene/bilinear_patches.h"
#include "common/scene/instance.h"
#include "common/scene/loop_subdivision.h"
#include "common/scene/ply_reader.h"
#include "common/scene/quadrics.h"
#include "common/scene/scene.h"
#include "common/scene/scene_load.h"
#include "common/scene/triangle_mesh.h"

#include <absl/strings/str_format.h>
#include <absl/strings/str_join.h>

#include <cmath>
#include <fstream>
#include <set>

namespace alphorn::pbrt {
namespace {

// pbrt-v4's defaults where a scene leaves a directive out.
constexpr int kDefaultWidth = 1280, kDefaultHeight = 720;
constexpr int kDefaultPixelSamples = 16;
constexpr int kDefaultMaxDepth = 5;
// Entries of a placement beyond this would send rays Embree refuses (see the XML front end).
constexpr double kMaxTransformEntry = 1e15;

Matrix4f toFloatMatrix(const Eigen::Matrix4d& m, const Location& location,
                       const std::string& what) {
    if (!m.allFinite() || m.cwiseAbs().maxCoeff() > kMaxTransformEntry)
        failAt(location, absl::StrFormat("%s: the transform has an entry beyond %g; scenes must "
                                         "fit within +-%g",
                                         what, kMaxTransformEntry, kMaxTransformEntry));
    return m.cast<float>();
}

Transform toTransform(const Eigen::Matrix4d& m, const Location& location, const std::string& what) {
    return Transform(toFloatMatrix(m, location, what), toFloatMatrix(m.inverse(), location, what));
}

bool swapsHandedness(const Eigen::Matrix4d& m) {
    return m.block<3, 3>(0, 0).determinant() < 0.0;
}

// A mesh's surface area before it is activated (it knows its area after), summed in double.
double surfaceAreaOf(const Mesh& mesh) {
    double area = 0.0;
    for (uint32_t t = 0; t < mesh.triangleCount(); ++t) area += mesh.triangleArea(t);
    return area;
}

// Refuses the first parameter the creation did not read: pbrt-v4 refuses a parameter it does
// not use, and one Alphorn does not translate would change the image without a word.
void failIfUnused(const Entity& entity) {
    if (const Parameter* p = entity.parameters.firstUnused())
        failAt(p->location,
               absl::StrFormat("%s: Alphorn does not support the parameter \"%s\" (pbrt-v4's "
                               "parameters Alphorn reads are listed in docs/pbrt-v4-format.md)",
                               entity.describe(), p->describe()));
}

void ignoreWithWarning(const Entity& entity, const std::string& name, const std::string& why) {
    if (const Parameter* p = entity.parameters.find(name))
        warn("%s: %s: \"%s\" is ignored: %s", p->location.toString(), entity.describe(),
             p->describe(), why);
}

[[noreturn]] void unsupported(const Entity& entity, const std::string& what) {
    failAt(entity.location, absl::StrFormat("%s: %s", entity.describe(), what));
}

class SceneCreator {
  public:
    SceneCreator(const SceneDescription& description, const CreateContext& context)
        : m_description(description), m_context(context) {}

    std::shared_ptr<Scene> create() {
        checkFilm();
        m_hasMedia = !m_description.media.empty();
        auto scene = std::static_pointer_cast<Scene>(
            ObjectFactory::create(ObjectKind::Scene, "scene", props("scene", Location())));
        scene->addChild(camera(), "");
        scene->addChild(sampler(), "");
        scene->addChild(integrator(), "");
        for (const ShapeEntity& shape : m_description.shapes)
            if (auto mesh = makeMesh(shape, Eigen::Matrix4d::Identity(), true))
                scene->addChild(mesh, "");
        addInstances(*scene);
        for (const LightEntity& light : m_description.lights)
            if (auto emitter = makeLight(light)) scene->addChild(emitter, "");
        scene->activate();
        return scene;
    }

  private:
    PropertyList props(const std::string& what, const Location& location) const {
        PropertyList list = m_context.base;
        list.setSource(location.file ? location.toString() + " (" + what + ")" : std::string(what));
        return list;
    }
    PropertyList props(const Entity& entity) const {
        return props(entity.describe(), entity.location);
    }

    std::shared_ptr<Object> create(ObjectKind kind, const std::string& type,
                                   const PropertyList& list) const {
        return ObjectFactory::create(kind, type, list);
    }

    // ---- film, camera, sampler, integrator, filter

    int width() const {
        if (m_context.overrides.imageSize) return m_context.overrides.imageSize->x();
        return m_description.film
                   ? m_description.film->parameters.getInteger("xresolution", kDefaultWidth)
                   : kDefaultWidth;
    }
    int height() const {
        if (m_context.overrides.imageSize) return m_context.overrides.imageSize->y();
        return m_description.film
                   ? m_description.film->parameters.getInteger("yresolution", kDefaultHeight)
                   : kDefaultHeight;
    }

    void checkFilm() {
        if (!m_description.film) return;
        const Entity& film = *m_description.film;
        if (film.type == "spectral")
            warn("%s: Film \"spectral\" is rendered as \"rgb\": Alphorn renders in RGB",
                 film.location.toString());
        else if (film.type != "rgb" && film.type != "gbuffer")
            unsupported(film, "Alphorn's films are rgb and gbuffer (an RGB image)");
        const ParameterList& p = film.parameters;
        p.ignore("xresolution");
        p.ignore("yresolution");
        for (const char* window : {"cropwindow", "pixelbounds"})
            if (p.has(window)) {
                const std::vector<float> crop = p.getFloats(window);
                const bool whole = std::string(window) == "cropwindow" && crop.size() == 4 &&
                                   crop[0] == 0 && crop[1] == 1 && crop[2] == 0 && crop[3] == 1;
                if (!whole)
                    failAt(p.find(window)->location,
                           absl::StrFormat("%s: \"%s\" (a part of the image) is not supported; "
                                           "Alphorn renders the whole image",
                                           film.describe(), window));
            }
        if (p.getFloat("whitebalance", 0.0f) != 0.0f)
            failAt(p.find("whitebalance")->location,
                   film.describe() + ": white balancing is not supported");
        const std::string sensor = p.getString("sensor", "cie1931");
        if (sensor != "cie1931")
            failAt(p.find("sensor")->location,
                   absl::StrFormat("%s: the sensor \"%s\" is not supported (only cie1931, "
                                   "the default)",
                                   film.describe(), sensor));
        if (p.has("maxcomponentvalue") && std::isfinite(p.getFloat("maxcomponentvalue", INFINITY)))
            failAt(p.find("maxcomponentvalue")->location,
                   film.describe() + ": clamping samples (maxcomponentvalue) is not supported");
        m_exposure *= p.getFloat("iso", 100.0f) / 100.0f;
        for (const char* name :
             {"filename", "savefp16", "diagonal", "coordinatesystem", "writefp16"})
            ignoreWithWarning(film, name, "it has no effect on Alphorn's image");
        failIfUnused(film);
    }

    std::shared_ptr<Object> camera() {
        CameraEntity camera;
        if (m_description.camera) {
            camera = *m_description.camera;
        } else {
            camera.directive = "Camera";
            camera.type = "perspective";
        }
        if (camera.type != "perspective")
            unsupported(camera,
                        "Alphorn's cameras are perspective (with a thin lens); "
                        "orthographic, realistic and spherical ones are not supported");
        const ParameterList& p = camera.parameters;
        const float fov = p.getFloat("fov", 90.0f);
        const float lensRadius = p.getFloat("lensradius", 0.0f);
        const float focalDistance = p.getFloat("focaldistance", 1e6f);
        for (const char* name : {"screenwindow", "frameaspectratio"})
            if (p.has(name))
                failAt(p.find(name)->location,
                       absl::StrFormat("%s: \"%s\" is not supported", camera.describe(), name));
        const float exposure = p.getFloat("shutterclose", 1.0f) - p.getFloat("shutteropen", 0.0f);
        if (!(exposure > 0.0f))
            failAt(camera.location, camera.describe() + ": shutterclose must exceed shutteropen");
        m_exposure *= exposure;
        failIfUnused(camera);
        if (!(fov > 0.0f && fov < 180.0f))
            failAt(camera.location, absl::StrFormat("%s: fov must be in (0, 180) degrees, got %g",
                                                    camera.describe(), fov));
        // pbrt-v4's fov spans the shorter side of the image; Alphorn's, the width.
        const int w = width(), h = height();
        const double halfTangent = std::tan(fov * M_PI / 360.0);
        const double horizontalFov =
            w >= h ? 2.0 * std::atan(halfTangent * double(w) / double(h)) * 180.0 / M_PI : fov;
        PropertyList list = props(camera);
        list.setInteger("width", w);
        list.setInteger("height", h);
        list.setFloat("fov", float(horizontalFov));
        // Alphorn's camera (Nori's) shows its local +x on the image's left, pbrt's on the right:
        // the same world seen through the same matrix would be mirrored.
        Eigen::Matrix4d toWorld = camera.toWorld;
        toWorld.col(0) = -toWorld.col(0);
        list.setTransform("toWorld", toTransform(toWorld, camera.location, camera.describe()));
        // pbrt's camera sees as far as the scene goes.
        list.setFloat("farClip", 1e12f);
        std::string type = "perspective";
        if (lensRadius > 0.0f) {
            type = "physical";
            list.setFloat("apertureRadius", lensRadius);
            list.setFloat("focalDistance", focalDistance);
        }
        std::shared_ptr<Object> object = create(ObjectKind::Camera, type, list);
        object->addChild(filter(), "");
        if (!camera.medium.empty()) object->addChild(medium(camera.medium), "");
        object->activate();
        return object;
    }

    std::shared_ptr<Object> filter() {
        if (!m_description.filter) {
            // pbrt-v4's default: a gaussian of radius 1.5 pixels and sigma 0.5.
            PropertyList list = props("default PixelFilter", Location());
            list.setFloat("radius", 1.5f);
            list.setFloat("stddev", 0.5f);
            return create(ObjectKind::Filter, "gaussian", list);
        }
        const Entity& filter = *m_description.filter;
        const ParameterList& p = filter.parameters;
        PropertyList list = props(filter);
        auto radius = [&](float defaultRadius) {
            const float x = p.getFloat("xradius", defaultRadius);
            const float y = p.getFloat("yradius", defaultRadius);
            if (x != y)
                failAt(filter.location, filter.describe() +
                                            ": filters with different x and y radii are not "
                                            "supported");
            return x;
        };
        std::shared_ptr<Object> object;
        if (filter.type == "gaussian") {
            list.setFloat("radius", radius(1.5f));
            list.setFloat("stddev", p.getFloat("sigma", 0.5f));
            object = create(ObjectKind::Filter, "gaussian", list);
        } else if (filter.type == "box") {
            list.setFloat("radius", radius(0.5f));
            object = create(ObjectKind::Filter, "box", list);
        } else if (filter.type == "triangle") {
            if (radius(2.0f) != 1.0f)
                failAt(filter.location,
                       filter.describe() + ": Alphorn's triangle (tent) filter has radius 1");
            object = create(ObjectKind::Filter, "tent", list);
        } else if (filter.type == "mitchell") {
            list.setFloat("radius", radius(2.0f));
            list.setFloat("B", p.getFloat("B", 1.0f / 3.0f));
            list.setFloat("C", p.getFloat("C", 1.0f / 3.0f));
            object = create(ObjectKind::Filter, "mitchell", list);
        } else {
            unsupported(filter, "Alphorn's filters are gaussian, box, triangle and mitchell");
        }
        failIfUnused(filter);
        return object;
    }

    std::shared_ptr<Object> sampler() {
        PropertyList list = props("default Sampler", Location());
        if (!m_description.sampler) {
            list.setInteger("sampleCount", kDefaultPixelSamples);
            return create(ObjectKind::Sampler, "sobol", list);
        }
        const Entity& sampler = *m_description.sampler;
        const ParameterList& p = sampler.parameters;
        list = props(sampler);
        std::string type;
        int samples = 0;
        if (sampler.type == "independent") {
            type = "independent";
            samples = p.getInteger("pixelsamples", kDefaultPixelSamples);
        } else if (sampler.type == "stratified") {
            type = "stratified";
            samples = p.getInteger("xsamples", 4) * p.getInteger("ysamples", 4);
            ignoreWithWarning(sampler, "jitter", "Alphorn's strata are always jittered");
        } else if (sampler.type == "halton" || sampler.type == "sobol" ||
                   sampler.type == "zsobol" || sampler.type == "paddedsobol" ||
                   sampler.type == "pmj02bn") {
            // Low-discrepancy samplers: Alphorn's is Owen-scrambled Sobol'.
            type = "sobol";
            samples = p.getInteger("pixelsamples", kDefaultPixelSamples);
            ignoreWithWarning(sampler, "randomization", "Alphorn's Sobol' is Owen-scrambled");
        } else {
            unsupported(sampler,
                        "Alphorn's samplers are independent, stratified and sobol "
                        "(halton, zsobol, paddedsobol and pmj02bn are rendered by it)");
        }
        ignoreWithWarning(sampler, "seed", "the job's seed sets the noise");
        failIfUnused(sampler);
        list.setInteger("sampleCount", samples);
        return create(ObjectKind::Sampler, type, list);
    }

    std::shared_ptr<Object> integrator() {
        Entity integrator;
        if (m_description.integrator) {
            integrator = *m_description.integrator;
        } else {
            integrator.directive = "Integrator";
            integrator.type = "volpath";
        }
        const ParameterList& p = integrator.parameters;
        PropertyList list =
            m_description.integrator ? props(integrator) : props("default Integrator", Location());
        std::string type;
        if (integrator.type == "volpath" || integrator.type == "path") {
            // Only a scene with media pays for tracking them.
            type = m_hasMedia ? "volume_path_mis" : "path_mis";
            if (integrator.type == "path" && m_hasMedia)
                failAt(integrator.location, integrator.describe() +
                                                ": the scene has media, which pbrt-v4's path "
                                                "integrator ignores; use volpath");
        } else if (integrator.type == "bdpt") {
            type = "bdpt";
        } else if (integrator.type == "ambientocclusion") {
            type = "ao";
            list.setFloat("length", p.getFloat("maxdistance", INFINITY));
        } else {
            unsupported(integrator,
                        "Alphorn renders volpath and path (path tracing), bdpt and "
                        "ambientocclusion scenes");
        }
        if (type != "ao") list.setInteger("maxDepth", p.getInteger("maxdepth", kDefaultMaxDepth));
        ignoreWithWarning(integrator, "lightsampler",
                          "Alphorn chooses lights its own way (the expected image is the same)");
        if (p.getBool("regularize", false))
            failAt(p.find("regularize")->location,
                   integrator.describe() + ": \"regularize\" (a biased method) is not supported");
        failIfUnused(integrator);
        return create(ObjectKind::Integrator, type, list);
    }

    // ---- media

    std::shared_ptr<Object> medium(const std::string& name) {
        auto cached = m_media.find(name);
        if (cached != m_media.end()) return cached->second;
        const MediumEntity& medium = m_description.media.at(name);
        const ParameterList& p = medium.parameters;
        if (medium.type != "homogeneous")
            unsupported(medium,
                        "Alphorn reads homogeneous media from pbrt-v4 files (grid and "
                        "nanovdb media are not supported yet)");
        if (p.has("preset"))
            failAt(p.find("preset")->location,
                   medium.describe() + ": named medium presets are not supported");
        if (const std::optional<Color3f> emission = p.getColor("Le", SpectrumKind::Illuminant);
            emission && p.getFloat("Lescale", 1.0f) * emission->maxCoeff() > 0.0f)
            failAt(p.find("Le")->location,
                   medium.describe() + ": emissive media are not supported");
        p.ignore("Lescale");
        const float scale = p.getFloat("scale", 1.0f);
        // pbrt-v4's defaults (its homogeneous medium's sigma_a and sigma_s per mm).
        const Color3f sigmaA =
            p.getColor("sigma_a", SpectrumKind::Unbounded).value_or(Color3f(.0011f, .0024f, .014f));
        const Color3f sigmaS =
            p.getColor("sigma_s", SpectrumKind::Unbounded).value_or(Color3f(2.55f, 3.21f, 3.77f));
        const float g = p.getFloat("g", 0.0f);
        failIfUnused(medium);
        PropertyList list = props(medium);
        list.setColor("sigmaA", sigmaA * scale);
        list.setColor("sigmaS", sigmaS * scale);
        std::shared_ptr<Object> object = create(ObjectKind::Medium, "homogeneous", list);
        PropertyList phase = props(medium);
        std::shared_ptr<Object> phaseObject;
        if (g != 0.0f) {
            phase.setFloat("g", g);
            phaseObject = create(ObjectKind::PhaseFunction, "hg", phase);
        } else {
            phaseObject = create(ObjectKind::PhaseFunction, "isotropic", phase);
        }
        object->addChild(phaseObject, "");
        object->activate();
        m_media[name] = object;
        return object;
    }

    // ---- textures

    // A constant colour, or a nested texture, for parameter `name` of `entity`: adds the texture
    // to `list`'s owner later through `textures`, or sets the colour in `list`.
    struct Slot {
        std::string ourName;
        std::shared_ptr<Object> texture;
    };

    std::shared_ptr<Object> texture(const std::string& name, bool spectrum, const Location& use) {
        const auto& textures = m_description.textures[spectrum ? 1 : 0];
        auto it = textures.find(name);
        if (it == textures.end()) {
            const auto& other = m_description.textures[spectrum ? 0 : 1];
            failAt(use, absl::StrFormat("the %s texture \"%s\" is not defined%s",
                                        spectrum ? "spectrum" : "float", name,
                                        other.count(name)
                                            ? absl::StrFormat(" (a %s texture of that name is)",
                                                              spectrum ? "float" : "spectrum")
                                            : ""));
        }
        const TextureEntity& texture = it->second;
        const ParameterList& p = texture.parameters;
        const SpectrumKind kind = SpectrumKind::Reflectance;
        PropertyList list = props(texture);
        std::shared_ptr<Object> object;
        auto constant = [&](const Color3f& value) {
            PropertyList c = props(texture);
            c.setColor("value", value);
            auto made = create(ObjectKind::Texture, "constant", c);
            made->activate();
            return made;
        };
        // A texture's own parameter that is a value or another texture.
        auto operand = [&](const std::string& parameter, const Color3f& defaultValue) {
            const std::string nested = p.textureName(parameter);
            if (!nested.empty()) return this->texture(nested, spectrum, texture.location);
            return constant(p.getColor(parameter, kind).value_or(defaultValue));
        };
        auto uvMapping = [&](PropertyList& l, float factor) {
            const std::string mapping = p.getString("mapping", "uv");
            if (mapping != "uv")
                failAt(texture.location,
                       absl::StrFormat("%s: the mapping \"%s\" is not supported (only uv)",
                                       texture.describe(), mapping));
            l.setFloat("uscale", p.getFloat("uscale", 1.0f) * factor);
            l.setFloat("vscale", p.getFloat("vscale", 1.0f) * factor);
            l.setFloat("uoffset", p.getFloat("udelta", 0.0f) * factor);
            l.setFloat("voffset", p.getFloat("vdelta", 0.0f) * factor);
        };
        if (texture.type == "imagemap") {
            list.setString("filename", p.getString("filename", ""));
            if (!p.has("filename"))
                failAt(texture.location, texture.describe() + ": needs a \"string filename\"");
            const std::string encoding = p.getString("encoding", "sRGB");
            const std::string filename = p.getString("filename", "");
            const bool png = filename.size() > 4 && filename.substr(filename.size() - 4) == ".png";
            if (encoding == "linear") {
                if (png) list.setBoolean("raw", true);
            } else if (encoding != "sRGB") {
                failAt(p.find("encoding")->location,
                       absl::StrFormat("%s: the encoding \"%s\" is not supported (sRGB or linear)",
                                       texture.describe(), encoding));
            }
            const std::string wrap = p.getString("wrap", "repeat");
            if (wrap != "repeat" && wrap != "clamp")
                failAt(p.find("wrap")->location,
                       absl::StrFormat("%s: the wrap mode \"%s\" is not supported (repeat or "
                                       "clamp)",
                                       texture.describe(), wrap));
            list.setString("wrapMode", wrap);
            uvMapping(list, 1.0f);
            ignoreWithWarning(texture, "filter", "Alphorn looks textures up bilinearly");
            ignoreWithWarning(texture, "maxanisotropy", "Alphorn looks textures up bilinearly");
            const float scale = p.getFloat("scale", 1.0f);
            const bool invert = p.getBool("invert", false);
            failIfUnused(texture);
            object = create(ObjectKind::Texture, "bitmap", list);
            object->activate();
            if (invert)
                object =
                    combine("sum",
                            {
                                constant(Color3f(1.0f)),
                                combine("product", {constant(Color3f(-1.0f)), object}, texture),
                            },
                            texture);
            if (scale != 1.0f)
                object = combine("product", {constant(Color3f(scale)), object}, texture);
            return object;
        }
        if (texture.type == "constant") {
            object = constant(p.getColor("value", kind).value_or(Color3f(1.0f)));
        } else if (texture.type == "scale") {
            object =
                combine("product", {operand("tex", Color3f(1.0f)), operand("scale", Color3f(1.0f))},
                        texture);
        } else if (texture.type == "mix") {
            if (!p.textureName("amount").empty())
                failAt(texture.location,
                       texture.describe() + ": a textured \"amount\" is not supported");
            const float amount = p.getFloat("amount", 0.5f);
            PropertyList mix = props(texture);
            mix.setString("operation", "mix");
            mix.setFloat("weight", amount);
            object = create(ObjectKind::Texture, "combination", mix);
            object->addChild(operand("tex1", Color3f(0.0f)), "");
            object->addChild(operand("tex2", Color3f(1.0f)), "");
            object->activate();
        } else if (texture.type == "checkerboard") {
            const int dimension = p.getInteger("dimension", 2);
            auto value = [&](const char* parameter, float defaultValue) {
                if (!p.textureName(parameter).empty())
                    failAt(texture.location,
                           absl::StrFormat("%s: a textured \"%s\" is not supported",
                                           texture.describe(), parameter));
                return p.getColor(parameter, kind).value_or(Color3f(defaultValue));
            };
            list.setColor("color0", value("tex1", 1.0f));
            list.setColor("color1", value("tex2", 0.0f));
            if (dimension == 2) {
                // Alphorn's checks are half a unit of uv wide, pbrt-v4's a whole unit.
                uvMapping(list, 0.5f);
                object = create(ObjectKind::Texture, "checkerboard2d", list);
            } else if (dimension == 3) {
                list.setTransform(
                    "toWorld", toTransform(texture.toWorld, texture.location, texture.describe()));
                object = create(ObjectKind::Texture, "checkerboard3d", list);
            } else {
                failAt(texture.location,
                       absl::StrFormat("%s: dimension must be 2 or 3", texture.describe()));
            }
            object->activate();
        } else {
            unsupported(texture,
                        "Alphorn reads the texture classes imagemap, constant, scale, "
                        "mix and checkerboard");
        }
        failIfUnused(texture);
        return object;
    }

    std::shared_ptr<Object> combine(const std::string& operation,
                                    std::vector<std::shared_ptr<Object>> operands,
                                    const Entity& entity) {
        PropertyList list = props(entity);
        list.setString("operation", operation);
        std::shared_ptr<Object> object = create(ObjectKind::Texture, "combination", list);
        for (auto& operand : operands) object->addChild(operand, "");
        object->activate();
        return object;
    }

    // ---- materials

    enum class Value { Color, Float, Integer, Bool };
    struct ParameterRule {
        const char* pbrtName;
        const char* ourName;
        Value value;
        SpectrumKind kind = SpectrumKind::Reflectance;
        bool texturable = false;
    };

    static const std::vector<ParameterRule>& rulesOf(const std::string& type) {
        using K = SpectrumKind;
        static const std::vector<ParameterRule> kRoughness = {
            {"roughness", "roughness", Value::Float, K::Reflectance, true},
            {"uroughness", "uroughness", Value::Float, K::Reflectance, true},
            {"vroughness", "vroughness", Value::Float, K::Reflectance, true},
            {"remaproughness", "remaproughness", Value::Bool},
        };
        auto with = [](std::vector<ParameterRule> rules, const std::vector<ParameterRule>& more) {
            rules.insert(rules.end(), more.begin(), more.end());
            return rules;
        };
        static const std::map<std::string, std::vector<ParameterRule>> kRules = {
            {"diffuse", {{"reflectance", "albedo", Value::Color, K::Reflectance, true}}},
            {"dielectric", with({}, kRoughness)},
            {"thindielectric", {}},
            {"conductor", with({{"eta", "eta", Value::Color, K::Unbounded, true},
                                {"k", "k", Value::Color, K::Unbounded, true},
                                {"reflectance", "reflectance", Value::Color, K::Reflectance, true}},
                               kRoughness)},
            {"coateddiffuse",
             with({{"reflectance", "reflectance", Value::Color, K::Reflectance, true},
                   {"thickness", "thickness", Value::Float, K::Reflectance, true},
                   {"albedo", "albedo", Value::Color, K::Reflectance, true},
                   {"g", "g", Value::Float, K::Reflectance, true},
                   {"maxdepth", "maxdepth", Value::Integer},
                   {"nsamples", "nsamples", Value::Integer}},
                  kRoughness)},
            {"coatedconductor",
             {{"interface.roughness", "interface.roughness", Value::Float, K::Reflectance, true},
              {"interface.uroughness", "interface.uroughness", Value::Float, K::Reflectance, true},
              {"interface.vroughness", "interface.vroughness", Value::Float, K::Reflectance, true},
              {"thickness", "thickness", Value::Float, K::Reflectance, true},
              {"conductor.eta", "conductor.eta", Value::Color, K::Unbounded, true},
              {"conductor.k", "conductor.k", Value::Color, K::Unbounded, true},
              {"reflectance", "reflectance", Value::Color, K::Reflectance, true},
              {"conductor.roughness", "conductor.roughness", Value::Float, K::Reflectance, true},
              {"conductor.uroughness", "conductor.uroughness", Value::Float, K::Reflectance, true},
              {"conductor.vroughness", "conductor.vroughness", Value::Float, K::Reflectance, true},
              {"albedo", "albedo", Value::Color, K::Reflectance, true},
              {"g", "g", Value::Float, K::Reflectance, true},
              {"maxdepth", "maxdepth", Value::Integer},
              {"nsamples", "nsamples", Value::Integer},
              {"remaproughness", "remaproughness", Value::Bool}}},
            {"diffusetransmission",
             {{"reflectance", "reflectance", Value::Color, K::Reflectance, true},
              {"transmittance", "transmittance", Value::Color, K::Reflectance, true},
              {"scale", "scale", Value::Float}}},
            {"mix", {{"amount", "amount", Value::Float, K::Reflectance, true}}},
            {"interface", {}},
        };
        static const std::vector<ParameterRule> kNone;
        auto it = kRules.find(type);
        return it == kRules.end() ? kNone : it->second;
    }

    // The index of refraction of a dielectric: a float, or a spectrum read at one wavelength
    // (Alphorn renders no dispersion).
    float indexOfRefraction(const Entity& material, const char* name, float defaultValue) {
        const Parameter* p = material.parameters.find(name);
        if (!p) return defaultValue;
        if (p->type == "float") return material.parameters.getFloat(name, defaultValue);
        const Color3f rgb = *material.parameters.getColor(name, SpectrumKind::Unbounded);
        // The green channel is the middle of the visible range.
        return rgb.g();
    }

    std::shared_ptr<Object> material(const Entity& material) {
        static const std::set<std::string> kUnsupported = {"measured", "hair", "subsurface",
                                                           "coatedconductor_measured"};
        if (kUnsupported.count(material.type))
            unsupported(material, "this material is not supported by Alphorn");
        if (material.type == "interface") {
            failIfUnused(material);
            return create(ObjectKind::BSDF, "null", props(material));
        }
        const std::vector<ParameterRule>& rules = rulesOf(material.type);
        if (rules.empty() && material.type != "thindielectric" && material.type != "dielectric")
            unsupported(material,
                        "Alphorn reads the materials diffuse, dielectric, thindielectric, "
                        "conductor, coateddiffuse, coatedconductor, diffusetransmission, mix and "
                        "interface");
        const ParameterList& p = material.parameters;
        p.ignore("type");
        if (p.has("displacement"))
            failAt(p.find("displacement")->location,
                   material.describe() + ": displacement (bump mapping) is not supported yet");
        PropertyList list = props(material);
        std::vector<std::pair<std::shared_ptr<Object>, std::string>> children;
        if (material.type == "dielectric" || material.type == "thindielectric") {
            const float eta = indexOfRefraction(material, "eta", 1.5f);
            if (material.type == "dielectric") {
                list.setFloat("intIOR", eta);
                list.setFloat("extIOR", 1.0f);
            } else {
                list.setFloat("eta", eta);
            }
        }
        if (material.type == "coateddiffuse")
            list.setFloat("eta", indexOfRefraction(material, "eta", 1.5f));
        if (material.type == "coatedconductor")
            list.setFloat("interface.eta", indexOfRefraction(material, "interface.eta", 1.5f));
        for (const ParameterRule& rule : rules) {
            const Parameter* given = p.find(rule.pbrtName);
            if (!given) continue;
            if (given->type == "texture") {
                if (!rule.texturable)
                    failAt(given->location, absl::StrFormat("%s: \"%s\" cannot be a texture",
                                                            material.describe(), rule.pbrtName));
                children.emplace_back(
                    texture(given->strings.at(0), rule.value == Value::Color, given->location),
                    rule.ourName);
                continue;
            }
            switch (rule.value) {
                case Value::Color:
                    list.setColor(rule.ourName, *p.getColor(rule.pbrtName, rule.kind));
                    break;
                case Value::Float:
                    list.setFloat(rule.ourName, p.getFloat(rule.pbrtName, 0.0f));
                    break;
                case Value::Integer:
                    list.setInteger(rule.ourName, p.getInteger(rule.pbrtName, 0));
                    break;
                case Value::Bool:
                    list.setBoolean(rule.ourName, p.getBool(rule.pbrtName, false));
                    break;
            }
        }
        if (material.type == "mix") {
            const std::vector<std::string> names = p.getStrings("materials");
            if (names.size() != 2)
                failAt(material.location,
                       material.describe() + ": needs \"string materials\" naming two materials");
            for (const std::string& name : names)
                children.emplace_back(namedMaterial(name, material.location), "");
        }
        const std::string normalMap = p.getString("normalmap", "");
        failIfUnused(material);
        std::shared_ptr<Object> bsdf = create(ObjectKind::BSDF, material.type, list);
        for (auto& [child, name] : children) bsdf->addChild(child, name);
        bsdf->activate();
        // pbrt-v4's reflective materials shade both sides of a surface; Alphorn's shade the side
        // their normal faces.
        static const std::set<std::string> kReflective = {"diffuse", "conductor", "coateddiffuse",
                                                          "coatedconductor"};
        if (kReflective.count(material.type)) {
            std::shared_ptr<Object> both = create(ObjectKind::BSDF, "twosided", props(material));
            both->addChild(bsdf, "");
            both->activate();
            bsdf = both;
        }
        if (normalMap.empty()) return bsdf;
        // pbrt-v4's normal map: an image whose rgb is (n + 1) / 2 in the shading frame.
        PropertyList image = props(material);
        image.setString("filename", normalMap);
        image.setBoolean("raw", true);
        std::shared_ptr<Object> map = create(ObjectKind::Texture, "bitmap", image);
        map->activate();
        std::shared_ptr<Object> wrapped = create(ObjectKind::BSDF, "normalmap", props(material));
        wrapped->addChild(bsdf, "");
        wrapped->addChild(map, "normalmap");
        wrapped->activate();
        return wrapped;
    }

    std::shared_ptr<Object> namedMaterial(const std::string& name, const Location& use) {
        auto cached = m_namedMaterials.find(name);
        if (cached != m_namedMaterials.end()) return cached->second;
        auto it = m_description.namedMaterials.find(name);
        if (it == m_description.namedMaterials.end())
            failAt(use, absl::StrFormat("the material \"%s\" is not defined", name));
        if (m_materialsBeingMade.count(name))
            failAt(use, absl::StrFormat("the mix material \"%s\" contains itself", name));
        m_materialsBeingMade.insert(name);
        std::shared_ptr<Object> bsdf = material(it->second);
        m_materialsBeingMade.erase(name);
        m_namedMaterials[name] = bsdf;
        return bsdf;
    }

    std::shared_ptr<Object> shapeMaterial(const ShapeEntity& shape) {
        if (!shape.materialName.empty()) return namedMaterial(shape.materialName, shape.location);
        if (shape.materialIndex < 0) {
            // pbrt-v4's default material: diffuse, reflectance 0.5.
            if (!m_defaultMaterial) {
                Entity diffuse;
                diffuse.directive = "Material";
                diffuse.type = "diffuse";
                diffuse.location = shape.location;
                m_defaultMaterial = material(diffuse);
            }
            return m_defaultMaterial;
        }
        auto cached = m_materials.find(shape.materialIndex);
        if (cached != m_materials.end()) return cached->second;
        std::shared_ptr<Object> bsdf = material(m_description.materials.at(shape.materialIndex));
        m_materials[shape.materialIndex] = bsdf;
        return bsdf;
    }

    // ---- shapes

    TriangleGeometry geometryOf(const ShapeEntity& shape) {
        const ParameterList& p = shape.parameters;
        const std::string source = shape.location.toString() + " (" + shape.describe() + ")";
        auto toMatrix3 = [](const std::vector<float>& v) {
            return Eigen::Matrix<float, 3, Eigen::Dynamic>(
                Eigen::Map<const Eigen::Matrix<float, 3, Eigen::Dynamic>>(v.data(), 3,
                                                                          v.size() / 3));
        };
        auto toMatrix2 = [](const std::vector<float>& v) {
            return Eigen::Matrix<float, 2, Eigen::Dynamic>(
                Eigen::Map<const Eigen::Matrix<float, 2, Eigen::Dynamic>>(v.data(), 2,
                                                                          v.size() / 2));
        };
        auto indices = [&](size_t perFace, size_t vertices) {
            std::vector<int> given = p.getIntegers("indices");
            if (given.empty() && vertices == perFace)
                for (size_t i = 0; i < perFace; ++i) given.push_back(int(i));
            if (given.empty() || given.size() % perFace != 0)
                failAt(shape.location,
                       absl::StrFormat("%s: \"indices\" must hold a multiple of %d vertex "
                                       "indices, %d given",
                                       shape.describe(), perFace, given.size()));
            for (int index : given)
                if (index < 0 || size_t(index) >= vertices)
                    failAt(p.find("indices")->location,
                           absl::StrFormat("%s: the index %d is outside the %d vertices",
                                           shape.describe(), index, vertices));
            return given;
        };
        auto radius = [&](const char* name, float defaultValue) {
            const float r = p.getFloat(name, defaultValue);
            if (!(r > 0.0f) || !std::isfinite(r))
                failAt(shape.location,
                       absl::StrFormat("%s: %s must be > 0 and finite", shape.describe(), name));
            return r;
        };
        TriangleGeometry geometry;
        if (shape.type == "trianglemesh" || shape.type == "bilinearmesh") {
            const std::vector<float> positions = p.getTriples("P", "point3");
            if (positions.empty())
                failAt(shape.location, shape.describe() + ": needs \"point3 P\"");
            const size_t vertices = positions.size() / 3;
            const std::vector<float> normals = p.getTriples("N", "normal3");
            const std::vector<float> uvs = p.getPairs("uv", "point2");
            if (!normals.empty() && normals.size() != positions.size())
                failAt(p.find("N")->location,
                       absl::StrFormat("%s: %d normals for %d vertices", shape.describe(),
                                       normals.size() / 3, vertices));
            if (!uvs.empty() && uvs.size() / 2 != vertices)
                failAt(p.find("uv")->location,
                       absl::StrFormat("%s: %d uvs for %d vertices", shape.describe(),
                                       uvs.size() / 2, vertices));
            ignoreWithWarning(shape, "S", "Alphorn's materials are isotropic, no tangents needed");
            ignoreWithWarning(shape, "faceIndices", "it only matters to ptex textures");
            if (shape.type == "trianglemesh") {
                const std::vector<int> faces = indices(3, vertices);
                geometry.positions = toMatrix3(positions);
                if (!normals.empty()) geometry.normals = toMatrix3(normals);
                if (!uvs.empty()) geometry.uvs = toMatrix2(uvs);
                geometry.faces.resize(3, faces.size() / 3);
                for (size_t i = 0; i < faces.size(); ++i)
                    geometry.faces(i % 3, i / 3) = uint32_t(faces[i]);
            } else {
                const std::vector<int> faces = indices(4, vertices);
                geometry = bilinearPatchesAsTriangles(
                    toMatrix3(positions), std::vector<uint32_t>(faces.begin(), faces.end()),
                    uvs.empty() ? Eigen::Matrix<float, 2, Eigen::Dynamic>() : toMatrix2(uvs),
                    normals.empty() ? Eigen::Matrix<float, 3, Eigen::Dynamic>()
                                    : toMatrix3(normals),
                    source);
            }
        } else if (shape.type == "loopsubdiv") {
            const std::vector<float> positions = p.getTriples("P", "point3");
            if (positions.empty())
                failAt(shape.location, shape.describe() + ": needs \"point3 P\"");
            const std::vector<int> faces = indices(3, positions.size() / 3);
            Eigen::Matrix<uint32_t, 3, Eigen::Dynamic> faceMatrix(3, faces.size() / 3);
            for (size_t i = 0; i < faces.size(); ++i) faceMatrix(i % 3, i / 3) = uint32_t(faces[i]);
            geometry =
                loopSubdivide(toMatrix3(positions), faceMatrix, p.getInteger("levels", 3), source);
        } else if (shape.type == "plymesh") {
            const std::string filename = p.getString("filename", "");
            if (filename.empty())
                failAt(shape.location, shape.describe() + ": needs a \"string filename\"");
            if (p.has("displacement"))
                failAt(p.find("displacement")->location,
                       shape.describe() + ": displacement is not supported yet");
            ignoreWithWarning(shape, "edgelength", "it only matters with displacement");
            const std::string path = props(shape).resolvePath(filename);
            try {
                geometry = readPlyFile(path, filename);
            } catch (const Error& e) {
                failAt(shape.location, absl::StrFormat("%s: %s", shape.describe(), e.what()));
            }
        } else if (shape.type == "sphere" || shape.type == "disk" || shape.type == "cylinder") {
            try {
                if (shape.type == "sphere") {
                    const float r = radius("radius", 1.0f);
                    geometry = tessellateSphere(r, p.getFloat("zmin", -r), p.getFloat("zmax", r),
                                                p.getFloat("phimax", 360.0f));
                } else if (shape.type == "disk") {
                    geometry = tessellateDisk(p.getFloat("height", 0.0f), radius("radius", 1.0f),
                                              p.getFloat("innerradius", 0.0f),
                                              p.getFloat("phimax", 360.0f));
                } else {
                    geometry =
                        tessellateCylinder(radius("radius", 1.0f), p.getFloat("zmin", -1.0f),
                                           p.getFloat("zmax", 1.0f), p.getFloat("phimax", 360.0f));
                }
            } catch (const Error& e) {
                failAt(shape.location, absl::StrFormat("%s: %s", shape.describe(), e.what()));
            }
        } else {
            unsupported(shape,
                        "Alphorn reads the shapes trianglemesh, plymesh, loopsubdiv, "
                        "bilinearmesh, sphere, disk and cylinder");
        }
        if (const Parameter* alpha = p.find("alpha")) {
            if (alpha->type != "float" || p.getFloat("alpha", 1.0f) != 1.0f)
                failAt(alpha->location,
                       shape.describe() + ": alpha (cut-outs) is not supported yet");
        }
        failIfUnused(shape);
        return geometry;
    }

    // The mesh of a shape placed by `placement` after its own transform; null for a shape with
    // nothing to render. `inWorld`: false for a shape of an instance definition, which may carry
    // no area light.
    std::shared_ptr<Mesh> makeMesh(const ShapeEntity& shape, const Eigen::Matrix4d& placement,
                                   bool inWorld) {
        TriangleGeometry geometry = geometryOf(shape);
        if (geometry.faces.cols() == 0) return nullptr;
        const Eigen::Matrix4d toWorld = placement * shape.toWorld;
        // pbrt-v4's orientation: a mesh's normals are flipped by ReverseOrientation; without
        // normals, the winding's normal is, and by a transform that swaps handedness.
        if (geometry.normals.cols() > 0) {
            if (shape.reverseOrientation) geometry.normals = -geometry.normals;
        } else if (shape.reverseOrientation != swapsHandedness(toWorld)) {
            geometry.faces.row(1).swap(geometry.faces.row(2));
        }
        transformGeometry(geometry, toTransform(toWorld, shape.location, shape.describe()));
        const std::string source = shape.location.toString() + " (" + shape.describe() + ")";
        checkGeometry(geometry, source);
        m_triangles += uint64_t(geometry.faces.cols());
        m_geometryBytes += meshMemoryBytes(geometry.faces.cols(), geometry.positions.cols(),
                                           geometry.normals.cols() > 0, geometry.uvs.cols() > 0);
        checkMemory(shape);
        auto mesh = std::make_shared<TriangleMesh>(std::move(geometry), source);
        mesh->addChild(shapeMaterial(shape), "");
        if (shape.areaLight) {
            if (inWorld)
                mesh->addChild(areaLight(*shape.areaLight, *mesh), "");
            else
                warn(
                    "%s: the area light of a shape inside ObjectBegin is ignored (as pbrt-v4 "
                    "ignores it)",
                    shape.location.toString());
        }
        if (!shape.insideMedium.empty() || !shape.outsideMedium.empty()) {
            if (!shape.insideMedium.empty()) mesh->addChild(medium(shape.insideMedium), "inside");
            if (!shape.outsideMedium.empty())
                mesh->addChild(medium(shape.outsideMedium), "outside");
        }
        mesh->activate();
        return mesh;
    }

    void checkMemory(const ShapeEntity& shape) {
        const uint64_t limit = m_context.limits.maxGeometryBytes ? m_context.limits.maxGeometryBytes
                                                                 : physicalMemoryBytesCached();
        if (m_geometryBytes <= limit) return;
        throw ResourceLimitError(absl::StrFormat(
            "%s (%s): from this shape on, the scene's meshes need more memory than allowed: "
            "%u triangles so far, about %s, more than %s%s",
            shape.location.toString(), shape.describe(), m_triangles, formatBytes(m_geometryBytes),
            formatBytes(limit),
            m_context.limits.setting.empty() ? "" : " (" + m_context.limits.setting + ")"));
    }

    uint64_t physicalMemoryBytesCached() {
        if (!m_physicalMemory) m_physicalMemory = physicalMemoryBytes();
        return m_physicalMemory;
    }

    void addInstances(Scene& scene) {
        std::map<std::string, int> uses;
        for (const InstanceUse& use : m_description.instanceUses) ++uses[use.name];
        std::map<std::string, std::shared_ptr<MeshGroup>> groups;
        for (const InstanceUse& use : m_description.instanceUses) {
            const InstanceDefinition& definition = m_description.instances.at(use.name);
            if (uses[use.name] == 1) {
                // Placed once: its meshes go into the scene as they are, without a level of
                // indirection to trace through.
                for (const ShapeEntity& shape : definition.shapes)
                    if (auto mesh = makeMesh(shape, use.toWorld, false)) scene.addChild(mesh, "");
                continue;
            }
            std::shared_ptr<MeshGroup>& group = groups[use.name];
            if (!group) {
                group = std::make_shared<MeshGroup>(use.name);
                for (const ShapeEntity& shape : definition.shapes)
                    if (auto mesh = makeMesh(shape, Eigen::Matrix4d::Identity(), false))
                        group->addMesh(mesh);
            }
            if (group->meshes().empty()) continue;
            try {
                scene.addInstance(group, toTransform(use.toWorld, use.location,
                                                     "ObjectInstance \"" + use.name + "\""));
            } catch (const Error& e) {
                failAt(use.location,
                       absl::StrFormat("ObjectInstance \"%s\": %s", use.name, e.what()));
            }
        }
    }

    // ---- lights

    std::shared_ptr<Object> areaLight(const Entity& light, const Mesh& mesh) {
        if (light.type != "diffuse") unsupported(light, "Alphorn's area lights are diffuse");
        const ParameterList& p = light.parameters;
        if (p.has("filename"))
            failAt(p.find("filename")->location,
                   light.describe() + ": image area lights are not supported yet");
        float scale = p.getFloat("scale", 1.0f) * m_exposure;
        const Color3f radiance =
            p.getColor("L", SpectrumKind::Illuminant).value_or(Color3f(1.0f)) * scale;
        const bool twoSided = p.getBool("twosided", false);
        Color3f emitted = radiance;
        if (p.has("power")) {
            // pbrt-v4 scales L (normalised to luminance 1) so that the light emits `power`:
            // power = L scale pi area (2 if two-sided).
            const float power = p.getFloat("power", 0.0f);
            const double area = surfaceAreaOf(mesh);
            if (!(power >= 0.0f) || !(area > 0.0))
                failAt(p.find("power")->location,
                       light.describe() + ": \"power\" needs a power >= 0 and a shape of area > 0");
            emitted = radiance * float(power / ((twoSided ? 2.0 : 1.0) * M_PI * area));
        }
        failIfUnused(light);
        PropertyList list = props(light);
        list.setColor("radiance", emitted);
        if (twoSided) list.setBoolean("twoSided", true);
        return create(ObjectKind::Emitter, "area", list);
    }

    std::shared_ptr<Object> makeLight(const LightEntity& light) {
        const ParameterList& p = light.parameters;
        PropertyList list = props(light);
        const float scale = p.getFloat("scale", 1.0f) * m_exposure;
        const Eigen::Matrix4d& toWorld = light.toWorld;
        std::string type;
        if (light.type == "point") {
            const Color3f intensity =
                p.getColor("I", SpectrumKind::Illuminant).value_or(Color3f(1.0f)) * scale;
            const Eigen::Vector3d from =
                p.getPoint3("from").value_or(Vector3f::Zero()).cast<double>();
            float powerScale = 1.0f;
            if (p.has("power")) powerScale = p.getFloat("power", 0.0f) / (4.0f * float(M_PI));
            const Eigen::Vector3d position = (toWorld * from.homogeneous()).hnormalized();
            list.setPoint("position", position.cast<float>());
            // Alphorn's point light takes its flux; pbrt's, its intensity.
            list.setColor("power", intensity * powerScale * 4.0f * float(M_PI));
            type = "point";
        } else if (light.type == "spot") {
            const Color3f intensity =
                p.getColor("I", SpectrumKind::Illuminant).value_or(Color3f(1.0f)) * scale;
            const Eigen::Vector3d from =
                p.getPoint3("from").value_or(Vector3f::Zero()).cast<double>();
            const Eigen::Vector3d to = p.getPoint3("to").value_or(Vector3f(0, 0, 1)).cast<double>();
            const float coneAngle = p.getFloat("coneangle", 30.0f);
            const float coneDelta = p.getFloat("conedelta", 5.0f);
            if (!((to - from).norm() > 0.0))
                failAt(light.location, light.describe() + ": from and to coincide");
            // pbrt-v4's spotlight falls off smoothly (a smoothstep in cos theta) between the
            // cones; its flux for intensity I is 2 pi I ((1 - cos start) + (cos start - cos
            // end) / 2).
            const float cosEnd = std::cos(coneAngle * float(M_PI) / 180.0f);
            const float cosStart =
                std::cos(std::max(0.0f, coneAngle - coneDelta) * float(M_PI) / 180.0f);
            const float flux =
                2.0f * float(M_PI) * ((1.0f - cosStart) + (cosStart - cosEnd) / 2.0f);
            float powerScale = 1.0f;
            if (p.has("power")) powerScale = p.getFloat("power", 0.0f) / flux;
            // A frame whose +z is the spot's axis.
            const Eigen::Vector3d dir = (to - from).normalized();
            Eigen::Vector3d a =
                std::abs(dir.x()) > 0.9 ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
            const Eigen::Vector3d b1 = a.cross(dir).normalized(), b2 = dir.cross(b1);
            Eigen::Matrix4d frame = Eigen::Matrix4d::Identity();
            frame.block<3, 1>(0, 0) = b1;
            frame.block<3, 1>(0, 1) = b2;
            frame.block<3, 1>(0, 2) = dir;
            frame.block<3, 1>(0, 3) = from;
            list.setTransform("toWorld",
                              toTransform(toWorld * frame, light.location, light.describe()));
            list.setColor("power", intensity * powerScale * flux);
            list.setFloat("totalAngle", coneAngle);
            list.setFloat("falloffStart", std::max(1e-3f, coneAngle - coneDelta));
            list.setString("falloff", "smoothstep");
            type = "spotlight";
        } else if (light.type == "distant") {
            const Color3f radiance =
                p.getColor("L", SpectrumKind::Illuminant).value_or(Color3f(1.0f)) * scale;
            const Eigen::Vector3d from =
                p.getPoint3("from").value_or(Vector3f::Zero()).cast<double>();
            const Eigen::Vector3d to = p.getPoint3("to").value_or(Vector3f(0, 0, 1)).cast<double>();
            const Eigen::Vector3d travel = toWorld.block<3, 3>(0, 0) * (to - from);
            if (!(travel.norm() > 0.0))
                failAt(light.location, light.describe() + ": from and to coincide");
            // pbrt-v4's illuminance sets the irradiance's luminance (L itself normalised to 1).
            Color3f irradiance = radiance;
            if (p.has("illuminance")) irradiance = radiance * p.getFloat("illuminance", 1.0f);
            list.setColor("irradiance", irradiance);
            list.setVector("direction", travel.normalized().cast<float>());
            type = "directional";
        } else if (light.type == "infinite") {
            list.setTransform("toWorld", toTransform(toWorld, light.location, light.describe()));
            const std::string filename = p.getString("filename", "");
            if (!filename.empty()) {
                if (p.has("L"))
                    failAt(light.location, light.describe() + ": give L or filename, not both");
                list.setString("filename", filename);
                list.setString("mapping", "octahedral");
            } else {
                list.setColor("radiance",
                              p.getColor("L", SpectrumKind::Illuminant).value_or(Color3f(1.0f)));
            }
            list.setFloat("scale", scale);
            if (p.has("illuminance")) {
                // pbrt-v4 sums an image map's illuminance with half each pixel's solid angle, so
                // its image maps give twice the illuminance asked for; Alphorn's environment
                // computes it exactly, and is asked for pbrt's, to render pbrt's image.
                const float illuminance = p.getFloat("illuminance", 1.0f);
                list.setFloat("illuminance", filename.empty() ? illuminance : 2.0f * illuminance);
            }
            ignoreWithWarning(light, "portal",
                              "it only changes how the light is sampled, not the image");
            type = "environment";
        } else {
            unsupported(light,
                        "Alphorn reads the lights point, spot, distant and infinite "
                        "(goniometric and projection are not supported yet)");
        }
        if (!light.medium.empty() && light.type != "infinite" && light.type != "distant")
            warn(
                "%s: %s sits in the medium \"%s\"; Alphorn finds a light's medium from the "
                "geometry around it",
                light.location.toString(), light.describe(), light.medium);
        failIfUnused(light);
        return create(ObjectKind::Emitter, type, list);
    }

    const SceneDescription& m_description;
    const CreateContext& m_context;
    bool m_hasMedia = false;
    // The film's imaging ratio (exposure time x ISO / 100), applied to every light.
    float m_exposure = 1.0f;
    std::map<std::string, std::shared_ptr<Object>> m_media;
    std::map<int, std::shared_ptr<Object>> m_materials;
    std::map<std::string, std::shared_ptr<Object>> m_namedMaterials;
    std::set<std::string> m_materialsBeingMade;
    std::shared_ptr<Object> m_defaultMaterial;
    uint64_t m_triangles = 0, m_geometryBytes = 0, m_physicalMemory = 0;
};

// Resolves one file parameter and checks it can be opened.
void listFile(const Entity& entity, const char* parameter, const PropertyList& resolver) {
    const Parameter* p = entity.parameters.find(parameter);
    if (!p || p->type != "string" || p->strings.size() != 1 || p->strings[0].empty()) return;
    PropertyList list = resolver;
    list.setSource(p->location.toString() + " (" + entity.describe() + ")");
    const std::string path = list.resolvePath(p->strings[0]);
    std::ifstream file(path, std::ios::binary);
    if (!file)
        list.fail("cannot open \"%s\" (\"%s\"): %s", p->strings[0], p->describe(),
                  std::strerror(errno));
}

}  // namespace

std::shared_ptr<Scene> createScene(const SceneDescription& description,
                                   const CreateContext& context) {
    return SceneCreator(description, context).create();
}

void listEntityFiles(const SceneDescription& description, const PropertyList& resolver) {
    for (const ShapeEntity& shape : description.shapes) listFile(shape, "filename", resolver);
    for (const auto& [name, definition] : description.instances)
        for (const ShapeEntity& shape : definition.shapes) listFile(shape, "filename", resolver);
    for (const auto& textures : description.textures)
        for (const auto& [name, texture] : textures) listFile(texture, "filename", resolver);
    for (const Entity& material : description.materials) listFile(material, "normalmap", resolver);
    for (const auto& [name, material] : description.namedMaterials)
        listFile(material, "normalmap", resolver);
    for (const LightEntity& light : description.lights) listFile(light, "filename", resolver);
    for (const ShapeEntity& shape : description.shapes)
        if (shape.areaLight) listFile(*shape.areaLight, "filename", resolver);
}

}  // namespace alphorn::pbrt
