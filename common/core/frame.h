// An orthonormal frame (s, t, n); local coordinates have the normal along +z (Nori's Frame).
#pragma once

#include "common/core/common.h"

namespace alphorn {

// Builds tangents for a unit normal without branches that flip between neighbouring normals
// (Duff et al. 2017, "Building an orthonormal basis, revisited").
inline void coordinateSystem(const Vector3f& n, Vector3f& s, Vector3f& t) {
    float sign = std::copysign(1.0f, n.z());
    float a = -1.0f / (sign + n.z());
    float b = n.x() * n.y() * a;
    s = Vector3f(1.0f + sign * n.x() * n.x() * a, sign * b, -sign * n.x());
    t = Vector3f(b, sign + n.y() * n.y() * a, -n.y());
}

struct Frame {
    Vector3f s, t;
    Normal3f n;

    Frame() : s(Vector3f::UnitX()), t(Vector3f::UnitY()), n(Vector3f::UnitZ()) {}
    Frame(const Vector3f& s, const Vector3f& t, const Normal3f& n) : s(s), t(t), n(n) {}
    explicit Frame(const Normal3f& n) : n(n) { coordinateSystem(n, s, t); }

    Vector3f toLocal(const Vector3f& v) const { return Vector3f(v.dot(s), v.dot(t), v.dot(n)); }
    Vector3f toWorld(const Vector3f& v) const { return s * v.x() + t * v.y() + n * v.z(); }

    static float cosTheta(const Vector3f& v) { return v.z(); }
    static float sinTheta2(const Vector3f& v) { return std::max(0.0f, 1.0f - v.z() * v.z()); }
    static float sinTheta(const Vector3f& v) { return std::sqrt(sinTheta2(v)); }
    static float tanTheta(const Vector3f& v) {
        float sin2 = 1.0f - v.z() * v.z();
        return sin2 <= 0.0f ? 0.0f : std::sqrt(sin2) / v.z();
    }
    static float sinPhi(const Vector3f& v) {
        float st = sinTheta(v);
        return st == 0.0f ? 1.0f : clamp(v.y() / st, -1.0f, 1.0f);
    }
    static float cosPhi(const Vector3f& v) {
        float st = sinTheta(v);
        return st == 0.0f ? 1.0f : clamp(v.x() / st, -1.0f, 1.0f);
    }
};

}  // namespace alphorn
