// A pbrt-v4 directive's parameter list ("float radius" [ 2 ] "rgb reflectance" [ .5 .5 .5 ]):
// typed, named values as the file wrote them, with where each was written. The object creation
// reads them by name and type and then asks which were never read: pbrt-v4 refuses a scene with
// a parameter it does not use, and so does Alphorn, naming it.
#pragma once

#include "common/core/color.h"
#include "common/pbrt/tokenizer.h"

#include <optional>
#include <string>
#include <vector>

namespace alphorn::pbrt {

struct Parameter {
    std::string type;  // as written, with "point" read as "point3", "normal" as "normal3", etc.
    std::string name;
    std::vector<double> numbers;
    std::vector<std::string> strings;
    std::vector<bool> bools;
    Location location;
    mutable bool used = false;

    // "float radius", for messages.
    std::string describe() const { return type + " " + name; }
};

// How a spectrum parameter is read (the same numbers mean different things).
enum class SpectrumKind {
    Reflectance,  // an albedo, within [0, 1]
    Unbounded,    // an index of refraction or absorption coefficient
    Illuminant,   // an emission: a named or blackbody spectrum is normalised to luminance 1
};

class ParameterList {
  public:
    void add(Parameter parameter) { m_parameters.push_back(std::move(parameter)); }
    bool empty() const { return m_parameters.empty(); }
    const std::vector<Parameter>& all() const { return m_parameters; }

    // The parameter of that name, any type (marked used), or null.
    const Parameter* find(const std::string& name) const;
    bool has(const std::string& name) const;

    // Single values; a parameter of another type or with another count is an error naming it.
    float getFloat(const std::string& name, float defaultValue) const;
    int getInteger(const std::string& name, int defaultValue) const;
    bool getBool(const std::string& name, bool defaultValue) const;
    std::string getString(const std::string& name, const std::string& defaultValue) const;
    std::optional<Vector3f> getPoint3(const std::string& name) const;
    std::optional<Vector3f> getVector3(const std::string& name) const;

    // Arrays (empty when absent).
    std::vector<float> getFloats(const std::string& name) const;
    std::vector<int> getIntegers(const std::string& name) const;
    std::vector<std::string> getStrings(const std::string& name) const;
    // Point3, vector3 or normal3 values of `type` ("point3", "normal3"), flattened.
    std::vector<float> getTriples(const std::string& name, const std::string& type) const;
    std::vector<float> getPairs(const std::string& name, const std::string& type) const;

    // A colour from an "rgb", "spectrum" or "blackbody" parameter (or a "float" one, as grey);
    // empty when absent. The "texture" form is the caller's to check first (textureName).
    std::optional<Color3f> getColor(const std::string& name, SpectrumKind kind) const;
    // The texture a "texture" parameter names, or empty.
    std::string textureName(const std::string& name) const;

    // The first parameter never read, or null.
    const Parameter* firstUnused() const;
    // Marks a parameter read without reading it (one pbrt-v4 accepts and Alphorn ignores).
    void ignore(const std::string& name) const;

  private:
    const Parameter& expect(const Parameter& p, std::initializer_list<const char*> types,
                            const char* what) const;
    std::vector<Parameter> m_parameters;
};

// Throws Error("LOCATION: message").
[[noreturn]] void failAt(const Location& location, const std::string& message);

}  // namespace alphorn::pbrt
