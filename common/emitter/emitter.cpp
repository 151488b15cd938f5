#include "common/emitter/emitter.h"

namespace alphorn {

void EmitterQueryRecord::aimAt(const Point3f& point, const Normal3f& normal) {
    p = point;
    n = normal;
    Vector3f d = p - ref;
    float dist = d.norm();
    wi = dist > 0.0f ? Vector3f(d / dist) : Vector3f::Zero();
    pdf = 0.0f;
    shadowRay = Ray3f(ref, wi, Epsilon, dist - Epsilon);
}

}  // namespace alphorn
