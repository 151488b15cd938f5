#include "common/emitter/emitter.h"

namespace alphorn {

EmitterQueryRecord::EmitterQueryRecord(const Point3f& ref, const Point3f& p, const Normal3f& n)
    : ref(ref), p(p), n(n) {
    Vector3f d = p - ref;
    float dist = d.norm();
    wi = dist > 0.0f ? Vector3f(d / dist) : Vector3f::Zero();
    shadowRay = Ray3f(ref, wi, Epsilon, dist - Epsilon);
}

}  // namespace alphorn
