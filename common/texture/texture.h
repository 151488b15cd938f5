// Textures: spatially varying colours. Every texture is evaluated with both a surface point's uv
// and its world position, and picks whichever it is defined on (2D textures read uv, 3D
// textures read the position through their own `toWorld`), so any parent can pass both without
// knowing the kind. A texture drives the parameter of its parent named by the child's XML
// "name" attribute (<texture type="checkerboard2d" name="albedo">).
//
// Media evaluate densities with a position only and need a majorant: is3D() says a texture
// ignores uv, and lowerBound()/upperBound() are true per-channel bounds over the whole domain
// (every texture computes real ones, so a majorant is never guessed; bounds that overflow to
// infinity are refused by the medium).
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"

namespace alphorn {

class Texture : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Texture; }

    // The value at surface coordinates `uv` and world position `p`.
    virtual Color3f eval(const Point2f& uv, const Point3f& p) const = 0;
    // The value at a world position, for media; only meaningful when is3D().
    Color3f eval3D(const Point3f& p) const { return eval(Point2f::Zero(), p); }
    // True when eval() depends on the position alone (usable as a medium density).
    virtual bool is3D() const = 0;

    // Per-channel bounds of eval() over every possible input.
    virtual Color3f lowerBound() const = 0;
    virtual Color3f upperBound() const = 0;

    // The parent parameter this texture drives (the XML "name" attribute), set by the parent.
    const std::string& parameterName() const { return m_parameterName; }
    void setParameterName(std::string name) { m_parameterName = std::move(name); }

  private:
    std::string m_parameterName;
};

}  // namespace alphorn
