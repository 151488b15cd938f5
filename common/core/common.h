// Basic types and constants shared by the whole engine. Like Nori, geometry is single precision
// float on Eigen; points, vectors and normals share one type because Eigen keeps them cheap.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

namespace alphorn {

using Vector2f = Eigen::Vector2f;
using Vector3f = Eigen::Vector3f;
using Vector4f = Eigen::Vector4f;
using Point2f = Eigen::Vector2f;
using Point3f = Eigen::Vector3f;
using Normal3f = Eigen::Vector3f;
using Vector2i = Eigen::Vector2i;
using Point2i = Eigen::Vector2i;
using Matrix3f = Eigen::Matrix3f;
using Matrix4f = Eigen::Matrix4f;

inline constexpr float Pi = 3.14159265358979323846f;
inline constexpr float InvPi = 0.31830988618379067154f;
inline constexpr float Inv2Pi = 0.15915494309189533577f;
inline constexpr float Inv4Pi = 0.07957747154594766788f;
inline constexpr float Sqrt2 = 1.41421356237309504880f;
inline constexpr float Epsilon = 1e-4f;
inline constexpr float Infinity = std::numeric_limits<float>::infinity();

inline float degToRad(float deg) {
    return deg * (Pi / 180.0f);
}
inline float radToDeg(float rad) {
    return rad * (180.0f / Pi);
}

template <typename T>
inline T clamp(T value, T lo, T hi) {
    return value < lo ? lo : (value > hi ? hi : value);
}

inline float lerp(float t, float a, float b) {
    return (1.0f - t) * a + t * b;
}

// sqrt that tolerates tiny negative arguments from rounding (e.g. 1 - cos^2).
inline float safeSqrt(float x) {
    return std::sqrt(std::max(0.0f, x));
}

// Nori's spherical coordinate helpers: theta from +z, phi in [0, 2pi) around z.
inline Vector3f sphericalDirection(float theta, float phi) {
    float sinTheta = std::sin(theta), cosTheta = std::cos(theta);
    return Vector3f(sinTheta * std::cos(phi), sinTheta * std::sin(phi), cosTheta);
}

}  // namespace alphorn
