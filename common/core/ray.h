#pragma once

#include "common/core/common.h"

namespace alphorn {

// A ray segment o + t d for t in [mint, maxt]; d need not be normalised.
struct Ray3f {
    Point3f o = Point3f::Zero();
    Vector3f d = Vector3f::UnitZ();
    float mint = Epsilon;
    float maxt = Infinity;

    Ray3f() = default;
    Ray3f(const Point3f& o, const Vector3f& d, float mint = Epsilon, float maxt = Infinity)
        : o(o), d(d), mint(mint), maxt(maxt) {}

    Point3f operator()(float t) const { return o + t * d; }
};

}  // namespace alphorn
