// Building blocks shared by the surface integrators: next-event estimation (one emitter sample
// with uniform light selection, as in Nori), emission seen along a ray, and the balance
// heuristic. Keeping them in one place keeps all integrators one-sided and MIS-consistent in
// the same way, so that direct light is counted exactly once.
#pragma once

#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"
#include "common/emitter/emitter.h"
#include "common/sampler/sampler.h"
#include "common/scene/bsdf_query.h"
#include "common/scene/scene.h"

namespace alphorn {

// Balance heuristic weight of a strategy with density `a` against one with density `b`. Robust
// to the infinities a grazing light sample can produce: never NaN.
inline float balanceHeuristic(float a, float b) {
    if (!(a > 0.0f)) return 0.0f;  // also catches NaN
    if (std::isinf(a)) return std::isinf(b) ? 0.5f : 1.0f;
    if (!(b > 0.0f)) return 1.0f;
    if (std::isinf(b)) return 0.0f;
    return a / (a + b);
}

// The emitter query for a ray from `origin` along unit direction `dir` hitting `its`.
inline EmitterQueryRecord makeEmitterHitQuery(const Point3f& origin, const Vector3f& dir,
                                              const Intersection& its) {
    EmitterQueryRecord rec(origin, its.p, its.shFrame.n);
    // The ray direction is exact even when origin and hit nearly coincide.
    rec.wi = dir;
    return rec;
}

// Radiance emitted by the surface `its` back along the ray (zero for non-emitters).
inline Color3f emittedRadiance(const Point3f& origin, const Vector3f& dir,
                               const Intersection& its) {
    if (!its.mesh || !its.mesh->emitter()) return Color3f(0.0f);
    return its.mesh->emitter()->eval(makeEmitterHitQuery(origin, dir, its));
}

// Solid-angle density with which next-event estimation from `origin` would have chosen the
// point `its` on its emitter, light selection included (for MIS of BSDF-sampled hits).
inline float emitterSamplingPdf(const Scene& scene, const Point3f& origin, const Vector3f& dir,
                                const Intersection& its) {
    if (!its.mesh || !its.mesh->emitter()) return 0.0f;
    return its.mesh->emitter()->pdf(makeEmitterHitQuery(origin, dir, its)) * scene.emitterPdf();
}

// Radiance arriving along a ray from `origin` along unit direction `dir` that left the scene:
// the environment lights' (zero without any). With `bsdfPdf` >= 0 (the density of the BSDF or
// phase sample that chose `dir`), each light's radiance carries the balance heuristic weight of
// that sample against the light's own sampling, light selection included; negative: full weight.
inline Color3f escapedRadiance(const Scene& scene, const Point3f& origin, const Vector3f& dir,
                               float bsdfPdf = -1.0f) {
    Color3f result(0.0f);
    for (const Emitter* emitter : scene.environmentEmitters()) {
        EmitterQueryRecord rec(origin);
        rec.wi = dir;
        const Color3f le = emitter->eval(rec);
        if (le.isBlack()) continue;
        result += bsdfPdf < 0.0f
                      ? le
                      : le * balanceHeuristic(bsdfPdf, emitter->pdf(rec) * scene.emitterPdf());
    }
    return result;
}

// One light sample seen from `ref`: an emitter chosen uniformly (Nori's light selection), then
// its own sample() of a point on it. Always draws one 1D and one 2D number so sample dimensions
// stay aligned. `emitter` stays null when nothing usable was sampled.
struct LightSample {
    explicit LightSample(const Point3f& ref) : rec(ref) {}

    const Emitter* emitter = nullptr;
    float selectionPdf = 0.0f;
    EmitterQueryRecord rec;
    Color3f radianceOverPdf = Color3f(0.0f);
};

inline LightSample sampleLight(const Scene& scene, Sampler& sampler, const Point3f& ref) {
    float selection = sampler.next1D();
    const Point2f lightSample = sampler.next2D();
    LightSample light(ref);
    const Emitter* emitter = scene.sampleEmitter(selection, light.selectionPdf);
    if (!emitter || !(light.selectionPdf > 0.0f)) return light;
    light.radianceOverPdf = emitter->sample(light.rec, lightSample);
    if (light.radianceOverPdf.isBlack() || !light.radianceOverPdf.allFinite()) return light;
    light.emitter = emitter;
    return light;
}

// The direct illumination at `its` that the light sample `light` (sampleLight() from its.p)
// carries, with visibility; `wiLocal` and `mis` as for sampleDirect(). A path tracer samples the
// light, then its next bounce, then calls this: the light sample's chain of square roots and
// divisions overlaps with the bounce's sampling instead of stalling the shadow ray.
inline Color3f directLight(const Scene& scene, const Intersection& its, const BSDF& bsdf,
                           const Vector3f& wiLocal, const LightSample& light, bool mis) {
    if (!light.emitter) return Color3f(0.0f);
    const EmitterQueryRecord& lRec = light.rec;
    const Color3f& radianceOverPdf = light.radianceOverPdf;
    const float selectionPdf = light.selectionPdf;

    BSDFQueryRecord bRec = makeBSDFQuery(its, wiLocal);
    bRec.wo = its.toLocal(lRec.wi);
    bRec.measure = Measure::SolidAngle;
    const Color3f f = bsdf.eval(bRec);
    if (f.isBlack()) return Color3f(0.0f);
    // The shadow ray is traced last: it is the expensive part and often unnecessary.
    if (scene.rayOccluded(lRec.shadowRay)) return Color3f(0.0f);

    Color3f result = f * radianceOverPdf * std::abs(Frame::cosTheta(bRec.wo));
    // x / 1 is x: with a single emitter the three divisions are skipped, bytes unchanged.
    if (selectionPdf != 1.0f) result /= selectionPdf;
    if (mis && !light.emitter->isDelta())
        result *= balanceHeuristic(lRec.pdf * selectionPdf, bsdf.pdf(bRec));
    return result;
}

// One sample of direct illumination at `its` from a uniformly chosen emitter, with visibility.
// wiLocal points back towards the previous vertex. With `mis`, the result carries the balance
// heuristic weight against BSDF sampling (delta lights keep weight 1: BSDF sampling cannot
// reach them). Draws what sampleLight() draws.
inline Color3f sampleDirect(const Scene& scene, Sampler& sampler, const Intersection& its,
                            const BSDF& bsdf, const Vector3f& wiLocal, bool mis) {
    return directLight(scene, its, bsdf, wiLocal, sampleLight(scene, sampler, its.p), mis);
}

}  // namespace alphorn
