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

namespace alphorn {

class TexturedColor {
  public:
    TexturedColor() = default;
    TexturedColor(const PropertyList& props, const std::string& name, const Color3f& defaultValue)
        : m_name(name), m_value(props.getColor(name, defaultValue)), m_given(props.has(name)) {}

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

    Color3f eval(const Point2f& uv, const Point3f& p) const {
        return m_texture ? m_texture->eval(uv, p) : m_value;
    }
    bool isTextured() const { return m_texture != nullptr; }
    const Texture* texture() const { return m_texture.get(); }
    Color3f lowerBound() const { return m_texture ? m_texture->lowerBound() : m_value; }
    Color3f upperBound() const { return m_texture ? m_texture->upperBound() : m_value; }
    const std::string& name() const { return m_name; }
    std::string toString() const {
        return m_texture ? "texture " + m_texture->toString() : m_value.toString();
    }

  private:
    std::string m_name;
    Color3f m_value;
    bool m_given = false;
    std::shared_ptr<Texture> m_texture;
};

// A float parameter that may be textured: a texture's value is the mean of its three channels
// (a grey texture gives its grey level).
class TexturedFloat {
  public:
    TexturedFloat() = default;
    TexturedFloat(const PropertyList& props, const std::string& name, float defaultValue)
        : m_name(name), m_value(props.getFloat(name, defaultValue)), m_given(props.has(name)) {}

    bool addChild(const std::shared_ptr<Object>& child, const std::string& name,
                  const Object& owner) {
        if (child->kind() != ObjectKind::Texture || name != m_name) return false;
        if (m_given) owner.fail("\"%s\" is given both as a value and as a nested texture", m_name);
        if (m_texture) owner.fail("more than one texture for \"%s\"", m_name);
        m_texture = std::static_pointer_cast<Texture>(child);
        m_texture->setParameterName(m_name);
        return true;
    }

    float eval(const Point2f& uv, const Point3f& p) const {
        return m_texture ? m_texture->eval(uv, p).mean() : m_value;
    }
    bool isTextured() const { return m_texture != nullptr; }
    // The plain value (valid when not textured), for validation in constructors.
    float value() const { return m_value; }
    float lowerBound() const { return m_texture ? m_texture->lowerBound().mean() : m_value; }
    float upperBound() const { return m_texture ? m_texture->upperBound().mean() : m_value; }
    const std::string& name() const { return m_name; }

  private:
    std::string m_name;
    float m_value = 0.0f;
    bool m_given = false;
    std::shared_ptr<Texture> m_texture;
};

}  // namespace alphorn
