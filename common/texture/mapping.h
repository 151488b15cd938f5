// Coordinate mappings shared by the textures: a 2D affine map of uv for 2D textures and a
// world-to-texture transform for 3D ones.
#pragma once

#include "common/core/properties.h"

namespace alphorn {

// floor(x) as an integer lattice index. Converting NaN or a float beyond the int64 range is
// undefined behaviour, so those are pinned (NaN to cell 0).
inline int64_t latticeIndex(float x) {
    if (!(std::abs(x) < 1e18f))
        return std::isnan(x) ? 0 : (x > 0.0f ? int64_t(1) << 60 : -(int64_t(1) << 60));
    return static_cast<int64_t>(std::floor(x));
}

// uv' = (u * uscale + uoffset, v * vscale + voffset) (Mitsuba's parameter names).
struct UVMapping {
    float uscale = 1.0f, vscale = 1.0f, uoffset = 0.0f, voffset = 0.0f;

    UVMapping() = default;
    explicit UVMapping(const PropertyList& props) {
        uscale = props.getFloat("uscale", 1.0f);
        vscale = props.getFloat("vscale", 1.0f);
        uoffset = props.getFloat("uoffset", 0.0f);
        voffset = props.getFloat("voffset", 0.0f);
        // The map only multiplies and adds, so any finite values render: a zero scale holds
        // the lookup at the offset (a texture constant along that axis), a negative one mirrors
        // it. NaN or inf would look the texture up at NaN or infinite coordinates.
        if (!std::isfinite(uscale) || !std::isfinite(vscale))
            props.fail("uscale and vscale must be finite, got %g and %g", uscale, vscale);
        if (!std::isfinite(uoffset) || !std::isfinite(voffset))
            props.fail("uoffset and voffset must be finite, got %g and %g", uoffset, voffset);
    }
    Point2f map(const Point2f& uv) const {
        return Point2f(uv.x() * uscale + uoffset, uv.y() * vscale + voffset);
    }
};

// Texture space of a 3D texture: `toWorld` places the texture in the scene, so the texture
// sees p_local = toWorld^-1 p.
struct SpaceMapping {
    Transform worldToLocal;

    SpaceMapping() = default;
    explicit SpaceMapping(const PropertyList& props)
        : worldToLocal(props.getTransform("toWorld", Transform()).inverse()) {}
    Point3f map(const Point3f& p) const { return worldToLocal.applyPoint(p); }
};

}  // namespace alphorn
