// Light sources. Area emitters live on meshes; point, spot and projector lights are
// delta-position lights; environment and directional lights sit at infinity (infinite.h). Every
// emitter samples its own emission so photon mappers can use it.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"
#include "common/core/ray.h"

namespace alphorn {

class Mesh;

// A query from a reference point `ref` to a point `p` on the emitter.
struct EmitterQueryRecord {
    Point3f ref = Point3f::Zero();
    Point3f p = Point3f::Zero();
    Normal3f n = Normal3f::Zero();   // emitter surface normal at p (zero for point-like lights)
    Vector3f wi = Vector3f::Zero();  // unit direction from ref to p
    float pdf = 0.0f;                // solid-angle density at ref (1 for delta lights)
    Ray3f shadowRay;                 // from ref towards p, ending just before p

    EmitterQueryRecord() = default;
    explicit EmitterQueryRecord(const Point3f& ref) : ref(ref) {}
    // For evaluating an emitter hit by a ray from ref at p with normal n.
    EmitterQueryRecord(const Point3f& ref, const Point3f& p, const Normal3f& n) : ref(ref) {
        aimAt(p, n);
    }
    // Makes this the record EmitterQueryRecord(ref, p, n) would be, in place: a sampler fills the
    // caller's record without building one and copying it over (the copy's wide loads of the
    // new record's narrow stores stalled on store forwarding).
    void aimAt(const Point3f& p, const Normal3f& n);
};

class Emitter : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Emitter; }

    // Samples a point on the emitter seen from rec.ref, fills p, n, wi, pdf and shadowRay and
    // returns the incident radiance divided by the pdf (zero when the sample is invalid).
    virtual Color3f sample(EmitterQueryRecord& rec, const Point2f& sample) const = 0;
    // Radiance emitted from rec.p towards rec.ref (zero for delta lights).
    virtual Color3f eval(const EmitterQueryRecord& rec) const = 0;
    // Solid-angle density at rec.ref of sample() choosing rec.p (zero for delta lights).
    virtual float pdf(const EmitterQueryRecord& rec) const = 0;

    // Total emitted flux, used to choose lights in proportion to power for photons.
    virtual Color3f power() const = 0;
    // Samples an emitted photon: origin and direction in `ray`; returns its flux (the emission
    // along the ray, radiance times cosine or intensity, over the pdf of the sampled ray), so that
    // N photons each divided by N sum to power() in expectation.
    virtual Color3f samplePhoton(Ray3f& ray, const Point2f& positionSample,
                                 const Point2f& directionSample) const = 0;

    virtual bool isDelta() const { return false; }
    // Lights at infinity (environment, directional) have no position: rays that leave the scene
    // reach them, and their shadow rays never end. They emit photons from a disk as wide as the
    // scene, so the scene tells them its bounding sphere (setSceneBounds) before asking power().
    virtual bool isInfinite() const { return false; }
    virtual void setSceneBounds(const Point3f& /*centre*/, float /*radius*/) {}
    // Area emitters are attached to the mesh that carries them.
    virtual void setMesh(const Mesh* mesh) { m_mesh = mesh; }
    const Mesh* mesh() const { return m_mesh; }

  protected:
    const Mesh* m_mesh = nullptr;
};

}  // namespace alphorn
