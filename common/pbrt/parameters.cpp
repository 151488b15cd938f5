#include "common/pbrt/parameters.h"

#include "common/core/error.h"
#include "common/core/spectrum.h"

#include <absl/strings/str_format.h>
#include <absl/strings/str_join.h>

#include <cmath>

namespace alphorn::pbrt {

void failAt(const Location& location, const std::string& message) {
    throw Error(location.toString() + ": " + message);
}

const Parameter* ParameterList::find(const std::string& name) const {
    for (const Parameter& p : m_parameters)
        if (p.name == name) {
            p.used = true;
            return &p;
        }
    return nullptr;
}

bool ParameterList::has(const std::string& name) const {
    for (const Parameter& p : m_parameters)
        if (p.name == name) return true;
    return false;
}

void ParameterList::ignore(const std::string& name) const {
    find(name);
}

const Parameter* ParameterList::firstUnused() const {
    for (const Parameter& p : m_parameters)
        if (!p.used) return &p;
    return nullptr;
}

const Parameter& ParameterList::expect(const Parameter& p, std::initializer_list<const char*> types,
                                       const char* what) const {
    for (const char* type : types)
        if (p.type == type) return p;
    failAt(p.location, absl::StrFormat("\"%s\" must be %s, not a %s", p.name, what, p.type));
}

namespace {

float toFloat(const Parameter& p, double value) {
    const float f = static_cast<float>(value);
    if (!std::isfinite(f))
        failAt(p.location,
               absl::StrFormat("\"%s\": %g is beyond the float range", p.describe(), value));
    return f;
}

void expectCount(const Parameter& p, size_t count, size_t given) {
    if (given != count)
        failAt(p.location, absl::StrFormat("\"%s\" takes %d value%s, %d given", p.describe(), count,
                                           count == 1 ? "" : "s", given));
}

}  // namespace

float ParameterList::getFloat(const std::string& name, float defaultValue) const {
    const Parameter* p = find(name);
    if (!p) return defaultValue;
    expect(*p, {"float"}, "a float");
    expectCount(*p, 1, p->numbers.size());
    return toFloat(*p, p->numbers[0]);
}

int ParameterList::getInteger(const std::string& name, int defaultValue) const {
    const Parameter* p = find(name);
    if (!p) return defaultValue;
    expect(*p, {"integer"}, "an integer");
    expectCount(*p, 1, p->numbers.size());
    return static_cast<int>(p->numbers[0]);
}

bool ParameterList::getBool(const std::string& name, bool defaultValue) const {
    const Parameter* p = find(name);
    if (!p) return defaultValue;
    expect(*p, {"bool"}, "a bool");
    expectCount(*p, 1, p->bools.size());
    return p->bools[0];
}

std::string ParameterList::getString(const std::string& name,
                                     const std::string& defaultValue) const {
    const Parameter* p = find(name);
    if (!p) return defaultValue;
    expect(*p, {"string"}, "a string");
    expectCount(*p, 1, p->strings.size());
    return p->strings[0];
}

std::optional<Vector3f> ParameterList::getPoint3(const std::string& name) const {
    std::vector<float> v = getTriples(name, "point3");
    if (v.empty()) return std::nullopt;
    if (v.size() != 3) expectCount(*find(name), 3, v.size());
    return Vector3f(v[0], v[1], v[2]);
}

std::optional<Vector3f> ParameterList::getVector3(const std::string& name) const {
    std::vector<float> v = getTriples(name, "vector3");
    if (v.empty()) return std::nullopt;
    if (v.size() != 3) expectCount(*find(name), 3, v.size());
    return Vector3f(v[0], v[1], v[2]);
}

std::vector<float> ParameterList::getFloats(const std::string& name) const {
    const Parameter* p = find(name);
    if (!p) return {};
    expect(*p, {"float"}, "floats");
    std::vector<float> out;
    out.reserve(p->numbers.size());
    for (double v : p->numbers) out.push_back(toFloat(*p, v));
    return out;
}

std::vector<int> ParameterList::getIntegers(const std::string& name) const {
    const Parameter* p = find(name);
    if (!p) return {};
    expect(*p, {"integer"}, "integers");
    return {p->numbers.begin(), p->numbers.end()};
}

std::vector<std::string> ParameterList::getStrings(const std::string& name) const {
    const Parameter* p = find(name);
    if (!p) return {};
    expect(*p, {"string"}, "strings");
    return p->strings;
}

std::vector<float> ParameterList::getTriples(const std::string& name,
                                             const std::string& type) const {
    const Parameter* p = find(name);
    if (!p) return {};
    if (p->type != type)
        failAt(p->location, absl::StrFormat("\"%s\" must be a %s, not a %s", name, type, p->type));
    if (p->numbers.size() % 3 != 0)
        failAt(p->location, absl::StrFormat("\"%s\" has %d values, not a multiple of 3",
                                            p->describe(), p->numbers.size()));
    std::vector<float> out;
    out.reserve(p->numbers.size());
    for (double v : p->numbers) out.push_back(toFloat(*p, v));
    return out;
}

std::vector<float> ParameterList::getPairs(const std::string& name, const std::string& type) const {
    const Parameter* p = find(name);
    if (!p) return {};
    if (p->type != type)
        failAt(p->location, absl::StrFormat("\"%s\" must be a %s, not a %s", name, type, p->type));
    if (p->numbers.size() % 2 != 0)
        failAt(p->location, absl::StrFormat("\"%s\" has %d values, not a multiple of 2",
                                            p->describe(), p->numbers.size()));
    std::vector<float> out;
    out.reserve(p->numbers.size());
    for (double v : p->numbers) out.push_back(toFloat(*p, v));
    return out;
}

std::string ParameterList::textureName(const std::string& name) const {
    for (const Parameter& p : m_parameters)
        if (p.name == name && p.type == "texture") {
            p.used = true;
            expectCount(p, 1, p.strings.size());
            return p.strings[0];
        }
    return "";
}

std::optional<Color3f> ParameterList::getColor(const std::string& name, SpectrumKind kind) const {
    const Parameter* p = find(name);
    if (!p) return std::nullopt;
    const SpectrumUse use = kind == SpectrumKind::Reflectance ? SpectrumUse::Reflectance
                            : kind == SpectrumKind::Unbounded ? SpectrumUse::Unbounded
                                                              : SpectrumUse::Illuminant;
    Color3f color;
    if (p->type == "rgb") {
        expectCount(*p, 3, p->numbers.size());
        color = Color3f(toFloat(*p, p->numbers[0]), toFloat(*p, p->numbers[1]),
                        toFloat(*p, p->numbers[2]));
        // pbrt-v4 reads an emitter's rgb as that colour times its colour space's white, which
        // it normalises to luminance 1: the rgb values themselves.
        return color;
    }
    if (p->type == "float") {
        expectCount(*p, 1, p->numbers.size());
        return Color3f(toFloat(*p, p->numbers[0]));
    }
    if (p->type == "blackbody") {
        expectCount(*p, 1, p->numbers.size());
        const float kelvin = toFloat(*p, p->numbers[0]);
        if (!(kelvin > 0.0f))
            failAt(p->location,
                   absl::StrFormat("\"%s\": a temperature must be > 0 kelvin", p->describe()));
        color = blackbodyRgb(kelvin);
    } else if (p->type == "spectrum") {
        if (!p->strings.empty()) {
            expectCount(*p, 1, p->strings.size());
            std::optional<Color3f> named = namedSpectrumRgb(p->strings[0], use);
            if (!named)
                failAt(p->location,
                       absl::StrFormat("\"%s\": \"%s\" is not a named spectrum Alphorn knows; "
                                       "give an \"rgb\" value",
                                       p->describe(), p->strings[0]));
            color = *named;
        } else {
            if (p->numbers.size() < 4 || p->numbers.size() % 2 != 0)
                failAt(p->location,
                       absl::StrFormat("\"%s\" needs (wavelength, value) pairs, at least two; "
                                       "%d numbers given",
                                       p->describe(), p->numbers.size()));
            std::vector<float> lambda, values;
            for (size_t i = 0; i < p->numbers.size(); i += 2) {
                lambda.push_back(toFloat(*p, p->numbers[i]));
                values.push_back(toFloat(*p, p->numbers[i + 1]));
                if (i > 0 && !(lambda.back() > lambda[lambda.size() - 2]))
                    failAt(p->location,
                           absl::StrFormat("\"%s\": wavelengths must increase", p->describe()));
            }
            color = sampledSpectrumRgb(lambda, values, use);
        }
    } else {
        failAt(p->location,
               absl::StrFormat("\"%s\" must be an rgb, spectrum or blackbody value, not a %s", name,
                               p->type));
    }
    // pbrt-v4 normalises an emitter's spectrum to luminance 1 (its "scale" sets the level).
    if (kind == SpectrumKind::Illuminant) {
        const float y = color.luminance();
        if (!(y > 0.0f))
            failAt(p->location, absl::StrFormat("\"%s\" has no luminance", p->describe()));
        color = color / y;
    }
    return color;
}

}  // namespace alphorn::pbrt
