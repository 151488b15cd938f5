// The two ways an environment map covers the sphere of directions (environment.cpp documents
// them for users): (u, v) in [0, 1]^2, u across the image from the left, v down from the top row,
// to and from unit directions in the light's space. Shared with tests and the pbrt front end.
#pragma once

#include "common/core/common.h"

#include <algorithm>
#include <cmath>

namespace alphorn {

// Latitude-longitude: (u, v) in [0, 1]^2 <-> unit light-space direction.
inline Point2f equirectFromDirection(const Vector3f& d) {
    const float theta = std::acos(std::clamp(d.y(), -1.0f, 1.0f));
    float phi = std::atan2(d.x(), -d.z());
    if (phi < 0.0f) phi += 2.0f * Pi;
    return Point2f(phi * Inv2Pi, theta * InvPi);
}

inline Vector3f equirectToDirection(const Point2f& uv) {
    const float theta = uv.y() * Pi, phi = uv.x() * (2.0f * Pi);
    const float sinTheta = std::sin(theta);
    return Vector3f(sinTheta * std::sin(phi), std::cos(theta), -sinTheta * std::cos(phi));
}

// The equal-area octahedral square. The signs of x and y pick the quadrant of the centred image
// coordinates (2u - 1, 2v - 1); within it, with (a, b) their absolute values, the upper hemisphere
// fills the diamond a + b <= 1. Points of L1 radius r = a + b map to the circle |z| = 1 - r^2
// (equal area: the diamond within r covers r^2 of the quadrant's diamond, the cap above |z| a
// share 1 - |z| of the hemisphere), and the angle around z runs linearly along it, b / r of a
// right angle from x towards y. The lower hemisphere fills the corner triangles, mirrored across
// the diamond's edge: (a, b) -> (1 - b, 1 - a).
inline Point2f octahedralFromDirection(const Vector3f& d) {
    const float ax = std::abs(d.x()), ay = std::abs(d.y());
    const float r = std::sqrt(std::max(0.0f, 1.0f - std::abs(d.z())));
    // Fraction of the right angle from the x axis towards the y axis.
    const float fraction = ax == 0.0f && ay == 0.0f ? 0.0f : std::atan2(ay, ax) * (2.0f * InvPi);
    float b = fraction * r, a = r - b;
    if (d.z() < 0.0f) {
        const float upperA = a;
        a = 1.0f - b;
        b = 1.0f - upperA;
    }
    return Point2f(0.5f * (1.0f + std::copysign(a, d.x())),
                   0.5f * (1.0f + std::copysign(b, d.y())));
}

inline Vector3f octahedralToDirection(const Point2f& uv) {
    const float x = 2.0f * uv.x() - 1.0f, y = 2.0f * uv.y() - 1.0f;
    const float a = std::abs(x), b = std::abs(y);
    const bool upper = a + b <= 1.0f;
    const float r = upper ? a + b : 2.0f - (a + b);
    // On the ring, the fraction of the right angle is b / r above and (1 - a) / r below.
    const float fraction = r > 0.0f ? std::clamp((upper ? b : 1.0f - a) / r, 0.0f, 1.0f) : 0.0f;
    const float phi = fraction * (0.5f * Pi);
    const float z = 1.0f - r * r;
    const float ring = r * std::sqrt(std::max(0.0f, 2.0f - r * r));  // sqrt(1 - z^2)
    return Vector3f(std::copysign(ring * std::cos(phi), x), std::copysign(ring * std::sin(phi), y),
                    upper ? z : -z);
}

}  // namespace alphorn
