// "A colour or a texture" for one named parameter of a plugin (diffuse `albedo`, microfacet
// `kd`, `alpha`, ...). The plain value comes from the PropertyList; a nested
// <texture name="..."> with the same name replaces it. Giving both is an error, because one of
// them would be silently ignored.
//
//   TexturedColor m_albedo{props, "albedo", Color3f(0.5f)};           // in the constructor
//   if (m_albedo.addChild(child, name, *this)) return;                 // in addChild
//   Color3f a = m_albedo.eval(rec.uv, rec.p);                          // when shading
#pragma once

#include "common/texture/texture.h"

#include <string>
#include <type_traits>

namespace alphorn {

// A parameter of type T (Color3f or float) that may be textured. A float reads a texture as
// the mean of its three channels (a grey texture gives its grey level).
template <typename T>
class TexturedParameter {
  public:
    TexturedParameter() = default;
    TexturedParameter(const PropertyList& props, const std::string& name, const T& defaultValue)
        : m_name(name), m_value(read(props, name, defaultValue)), m_given(props.has(name)) {}

    // Takes `child` when it is a texture named like this parameter; returns whether it did.
    bool addChild(const std::shared_ptr<Object>& child, const std::string& name,
                  const Object& owner) {
        if (child->kind() != ObjectKind::Texture || name != m_name) return false;
        if (m_given) owner.fail("\"%s\" is given both as a value and as a nested texture", m_name);
        if (m_texture) owner.fail("more than one texture for \"%s\"", m_name);
        m_texture = std::static_pointer_cast<Texture>(child);
        m_texture->setParameterName(m_name);
        return true;
    }

    T eval(const Point2f& uv, const Point3f& p) const {
        return m_texture ? fromColor(m_texture->eval(uv, p)) : m_value;
    }
    bool isTextured() const { return m_texture != nullptr; }
    const Texture* texture() const { return m_texture.get(); }
    // The plain value (valid when not textured), for validation in constructors.
    const T& value() const { return m_value; }
    T lowerBound() const { return m_texture ? fromColor(m_texture->lowerBound()) : m_value; }
    T upperBound() const { return m_texture ? fromColor(m_texture->upperBound()) : m_value; }
    const std::string& name() const { return m_name; }
    std::string toString() const {
        if (m_texture) return "texture " + m_texture->toString();
        if constexpr (std::is_same_v<T, float>)
            return std::to_string(m_value);
        else
            return m_value.toString();
    }

  private:
    static T read(const PropertyList& props, const std::string& name, const T& defaultValue) {
        if constexpr (std::is_same_v<T, float>)
            return props.getFloat(name, defaultValue);
        else
            return props.getColor(name, defaultValue);
    }
    static T fromColor(const Color3f& color) {
        if constexpr (std::is_same_v<T, float>)
            return color.mean();
        else
            return color;
    }

    std::string m_name;
    T m_value{};
    bool m_given = false;
    std::shared_ptr<Texture> m_texture;
};

using TexturedColor = TexturedParameter<Color3f>;
using TexturedFloat = TexturedParameter<float>;

}  // namespace alphorn
