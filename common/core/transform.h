// A homogeneous transform with its inverse (Nori's Transform).
#pragma once

#include "common/core/common.h"
#include "common/core/ray.h"

namespace alphorn {

class Transform {
  public:
    Transform() : m_transform(Matrix4f::Identity()), m_inverse(Matrix4f::Identity()) {}
    explicit Transform(const Matrix4f& m) : m_transform(m), m_inverse(inverseOf(m)) {}
    Transform(const Matrix4f& m, const Matrix4f& inv) : m_transform(m), m_inverse(inv) {}

    const Matrix4f& matrix() const { return m_transform; }
    const Matrix4f& inverseMatrix() const { return m_inverse; }
    Transform inverse() const { return Transform(m_inverse, m_transform); }
    Transform operator*(const Transform& t) const {
        return Transform(m_transform * t.m_transform, t.m_inverse * m_inverse);
    }

    Vector3f applyVector(const Vector3f& v) const { return m_transform.topLeftCorner<3, 3>() * v; }
    // Normals transform with the inverse transpose.
    Normal3f applyNormal(const Normal3f& n) const {
        return m_inverse.topLeftCorner<3, 3>().transpose() * n;
    }
    Point3f applyPoint(const Point3f& p) const {
        Vector4f r = m_transform * Vector4f(p.x(), p.y(), p.z(), 1.0f);
        return r.head<3>() / r.w();
    }
    Ray3f applyRay(const Ray3f& r) const {
        return Ray3f(applyPoint(r.o), applyVector(r.d), r.mint, r.maxt);
    }
    bool isIdentity() const { return m_transform.isIdentity(0.0f); }
    std::string toString() const;

    // m^-1, in float where float holds it (the same bytes as ever) and in double where the
    // determinant leaves the float range: a uniform scale s has determinant s^3, which is not
    // a normal float beyond about s = 1e12 or below 1e-12, although s^-1 is. Not finite only
    // when m is singular or its inverse exceeds the float range.
    static Matrix4f inverseOf(const Matrix4f& m) {
        if (std::isnormal(m.determinant())) {
            const Matrix4f inverse = m.inverse();
            if (inverse.allFinite()) return inverse;
        }
        return m.cast<double>().inverse().cast<float>();
    }

  private:
    Matrix4f m_transform;
    Matrix4f m_inverse;
};

}  // namespace alphorn
