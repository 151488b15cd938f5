// Lights at infinity (environment, directional): what they share. They have no position, so a
// query's point is a stand-in far along the direction (twice the scene's radius from the
// receiver) and its shadow ray runs to infinity. Photons enter the scene through a disk of the
// scene's bounding radius that faces the light direction and touches the bounding sphere, so every
// photon starts outside the scene and every point of the scene can be reached.
#pragma once

#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/emitter/emitter.h"

namespace alphorn {

class InfiniteEmitter : public Emitter {
  public:
    bool isInfinite() const final { return true; }

    // Nested in a mesh, the light would be looked up wherever a ray hits the mesh's surface.
    void setMesh(const Mesh*) override {
        fail(
            "a light at infinity (environment) cannot be nested in a <mesh>; give it in the "
            "<scene>");
    }

    void setSceneBounds(const Point3f& centre, float radius) override {
        m_centre = centre.allFinite() ? centre : Point3f::Zero();
        // An empty scene has no extent; any positive radius then gives the same (unused) light.
        m_radius = radius > 0.0f && std::isfinite(radius) ? radius : 1.0f;
    }

    // The query seen from rec.ref towards unit world direction `wi` (pointing to the light).
    void aimAtDirection(EmitterQueryRecord& rec, const Vector3f& wi) const {
        rec.wi = wi;
        rec.n = -wi;
        rec.p = rec.ref + (2.0f * m_radius) * wi;
        rec.pdf = 0.0f;
        rec.shadowRay = Ray3f(rec.ref, wi, Epsilon, Infinity);
    }

    // The query of a ray from `origin` along unit direction `dir` that left the scene.
    EmitterQueryRecord escapeQuery(const Point3f& origin, const Vector3f& dir) const {
        EmitterQueryRecord rec(origin);
        aimAtDirection(rec, dir);
        return rec;
    }

  protected:
    // A photon ray travelling against `wi` (wi points to the light), from a point of the disk
    // chosen uniformly with `u`: density 1 / diskArea() over the disk.
    Ray3f diskRay(const Vector3f& wi, const Point2f& u) const {
        const Frame frame(wi);
        const Point2f d = warp::squareToUniformDisk(u);
        const Point3f origin = m_centre + m_radius * (wi + d.x() * frame.s + d.y() * frame.t);
        return Ray3f(origin, -wi);
    }
    float diskArea() const { return Pi * m_radius * m_radius; }

    Point3f m_centre = Point3f::Zero();
    float m_radius = 1.0f;
};

}  // namespace alphorn
