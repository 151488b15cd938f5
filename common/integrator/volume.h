// Volumetric path tracing shared by volume_path_mats and volume_path_mis (and usable from photon
// tracing): walking a ray through media and index-matched (null) boundaries, transmittance for
// shadow rays, and the path loop itself. Both integrators are one algorithm; they differ only in
// whether lights are also sampled (next-event estimation with MIS), so the loop lives here once
// and each plugin file only chooses.
//
// Medium bookkeeping: the path carries the medium it is in, starting with the camera's. At a
// surface the medium after the hit is mesh.mediumTowards(hit, new direction, current), which
// handles entering, leaving, reflecting and refracting alike; meshes without media keep the
// current one. Null surfaces (bsdf `null`, or a dielectric with equal indices) are crossed
// without a scattering event, a random number or a counted bounce.
//
// Rays that leave every surface behind have no end; media along them end where the ray leaves
// the box around the scene's meshes and the camera, so that delta tracking in a medium that thins
// out to nothing cannot wander forever. (A homogeneous fog around an open scene therefore ends
// at that box too; enclose fog by a mesh for a well-defined extent.)
#pragma once

#include "common/emitter/delta_light.h"
#include "common/integrator/direct.h"
#include "common/medium/medium.h"

#include <optional>

namespace alphorn {

// True when `medium` can interact with light (non-null and not vacuum).
inline bool isParticipating(const Medium* medium) {
    return medium && !medium->isVacuum();
}

// Whether anything in the scene needs the volumetric path loop: a participating medium (at the
// camera or on a mesh) or a null surface to cross. Without, the volumetric path tracers run the
// surface path tracer itself (path.h), so that a scene pays nothing for media it does not have:
// the same film as path_mats / path_mis, byte for byte, at their cost (bench_feature_cost).
inline bool needsVolumetricPaths(const Scene& scene) {
    if (isParticipating(scene.camera()->medium())) return true;
    for (const auto& mesh : scene.meshes())
        if (mesh->bsdf()->isNull() || isParticipating(mesh->insideMedium()) ||
            isParticipating(mesh->outsideMedium()))
            return true;
    return false;
}

// The distance along `ray` (unit direction) at which it leaves `box`; 0 when it never is inside.
inline float exitDistance(const Eigen::AlignedBox3f& box, const Ray3f& ray) {
    float tNear = 0.0f, tFar = Infinity;
    for (int axis = 0; axis < 3; ++axis) {
        const float inv = 1.0f / ray.d[axis];
        float t0 = (box.min()[axis] - ray.o[axis]) * inv;
        float t1 = (box.max()[axis] - ray.o[axis]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        // NaN (0 * inf on a slab face) compares false and leaves the bounds unchanged.
        if (t0 > tNear) tNear = t0;
        if (t1 < tFar) tFar = t1;
    }
    return tNear <= tFar ? std::max(tFar, 0.0f) : 0.0f;
}

// The box that media end at along rays that hit nothing: the scene's meshes, its lights (a
// spotlight above an open floor is outside the meshes' box) and the camera, 1% larger so that a
// medium filling a closed mesh is never cut by it. Camera ray origins are added per path
// (volumePathLi), which also covers thin-lens apertures.
inline Eigen::AlignedBox3f mediaBounds(const Scene& scene) {
    Eigen::AlignedBox3f box = scene.bounds();
    for (const auto& emitter : scene.emitters()) {
        // An emitted ray starts on the light: its position for point-like lights.
        Ray3f ray;
        emitter->samplePhoton(ray, Point2f(0.5f, 0.5f), Point2f(0.5f, 0.5f));
        if (ray.o.allFinite()) box.extend(ray.o);
    }
    Ray3f cameraRay;
    const Vector2f centre = 0.5f * scene.camera()->outputSize().cast<float>();
    scene.camera()->sampleRay(cameraRay, centre, Point2f(0.5f, 0.5f));
    if (cameraRay.o.allFinite()) box.extend(cameraRay.o);
    if (box.isEmpty()) return box;
    const Vector3f margin = 0.01f * box.sizes() + Vector3f::Constant(Epsilon);
    return Eigen::AlignedBox3f(box.min() - margin, box.max() + margin);
}

// The medium at point `p`, from the first medium boundary a ray from p meets: the medium on the
// side it arrives from. For lights inside media (photon emission needs the medium a photon
// starts in) and tests; nullptr (vacuum) when no boundary encloses p. Assumes closed,
// consistently declared boundaries, like the rest of the bookkeeping.
inline const Medium* mediumAt(const Scene& scene, const Point3f& p) {
    // An oblique direction, so that the ray does not run along the faces of axis-aligned boxes.
    Ray3f ray(p, Vector3f(0.5376f, 0.6132f, 0.5787f).normalized(), 0.0f, Infinity);
    for (;;) {
        Intersection its;
        if (!scene.rayIntersect(ray, its)) return nullptr;
        if (its.mesh->hasMediumInterface()) return its.mesh->mediumTowards(its, -ray.d, nullptr);
        ray = Ray3f(its.p, ray.d, Epsilon, Infinity);
    }
}

// Transmittance along `ray` (unit direction, over [ray.mint, ray.maxt]) starting in `medium`:
// the product over the media between null surfaces; zero when any other surface blocks it.
// Ratio tracking in heterogeneous media draws from `sampler`; homogeneous media draw nothing.
inline Color3f transmittanceAlong(const Scene& scene, Sampler& sampler, Ray3f ray,
                                  const Medium* medium, const Eigen::AlignedBox3f& bounds) {
    Color3f result(1.0f);
    for (;;) {
        Intersection its;
        const bool hit = scene.rayIntersect(ray, its);
        if (isParticipating(medium)) {
            const float end = hit ? its.t : std::min(ray.maxt, exitDistance(bounds, ray));
            result *= medium->transmittance(Ray3f(ray.o, ray.d), end, sampler);
            if (result.isBlack()) return result;
        }
        if (!hit) return result;
        if (!its.mesh->bsdf()->isNull()) return Color3f(0.0f);
        medium = its.mesh->mediumTowards(its, ray.d, medium);
        ray = Ray3f(its.p, ray.d, Epsilon, ray.maxt - its.t);
    }
}

// ---- Equiangular sampling (Kulla and Fajardo, "Importance Sampling Techniques for Path Tracing
// in Participating Media", 2012) ----
// Free-flight sampling puts scattering points where the medium is dense, not where a light is
// near: in fog under a spotlight the few next-event estimates taken close to the light carry
// huge 1/d² weights (fireflies). Equiangular sampling draws a point on the segment with density
// proportional to 1/(D² + (t − Δ)²) towards a chosen point-like light (uniform in the angle the
// segment subtends at the light), which cancels the 1/d². The two are combined per light by
// the balance heuristic; free-flight sampling remains the one that continues the path. Used in
// grey homogeneous media, whose free-flight density σt e^(−σt t) is known in closed form.

// A segment of a path through one medium: t in [0, end] from `origin` along unit `direction`.
struct EquiangularSegment {
    Point3f origin;
    Vector3f direction;
    float end;
    float sigmaT;  // the medium's grey extinction
};

// A light as seen from a segment: Δ, the parameter of the point closest to it, its distance D
// from the line, and the angles at the light of the segment's two ends.
struct EquiangularFrame {
    float delta, distance, thetaA, thetaB;
    bool valid;  // false for a light on the line: free-flight sampling alone then
};

inline EquiangularFrame equiangularFrame(const EquiangularSegment& segment, const Point3f& light) {
    EquiangularFrame frame;
    const Vector3f toLight = light - segment.origin;
    frame.delta = toLight.dot(segment.direction);
    frame.distance = (toLight - frame.delta * segment.direction).norm();
    frame.thetaA = std::atan2(-frame.delta, frame.distance);
    frame.thetaB = std::atan2(segment.end - frame.delta, frame.distance);
    frame.valid =
        frame.distance > 1e-6f * (std::abs(frame.delta) + 1.0f) && frame.thetaB > frame.thetaA;
    return frame;
}

inline float equiangularPdf(const EquiangularFrame& frame, float t) {
    if (!frame.valid) return 0.0f;
    const float x = t - frame.delta;
    return frame.distance /
           ((frame.thetaB - frame.thetaA) * (frame.distance * frame.distance + x * x));
}

// The density with which free-flight sampling scatters at t on the segment.
inline float freeFlightPdf(const EquiangularSegment& segment, float t) {
    return segment.sigmaT * std::exp(-segment.sigmaT * t);
}

// One equiangular estimate of the light that a uniformly chosen point-like light scatters into
// the segment towards its origin, MIS-weighted against free-flight sampling. Always draws
// 1D + 1D + 2D numbers (plus what ratio tracking on the shadow ray needs).
inline Color3f sampleEquiangular(const Scene& scene, Sampler& sampler,
                                 const EquiangularSegment& segment, const Medium& medium,
                                 const Color3f& sigmaS, const Eigen::AlignedBox3f& bounds) {
    float selection = sampler.next1D();
    const float u = sampler.next1D();
    const Point2f lightSample = sampler.next2D();
    float selectionPdf = 0.0f;
    const auto* light =
        dynamic_cast<const DeltaPositionLight*>(scene.sampleEmitter(selection, selectionPdf));
    if (!light || !(selectionPdf > 0.0f)) return Color3f(0.0f);
    const EquiangularFrame frame = equiangularFrame(segment, light->position());
    if (!frame.valid) return Color3f(0.0f);
    const float t = std::clamp(
        frame.delta + frame.distance * std::tan(frame.thetaA + u * (frame.thetaB - frame.thetaA)),
        0.0f, segment.end);
    const float pdf = equiangularPdf(frame, t);
    if (!(pdf > 0.0f) || !std::isfinite(t)) return Color3f(0.0f);

    EmitterQueryRecord lRec(segment.origin + t * segment.direction);
    const Color3f radianceOverPdf = light->sample(lRec, lightSample);
    if (radianceOverPdf.isBlack()) return Color3f(0.0f);
    const float phase = medium.phase().eval(-segment.direction, lRec.wi);
    if (!(phase > 0.0f)) return Color3f(0.0f);
    const Color3f tr = transmittanceAlong(scene, sampler, lRec.shadowRay, &medium, bounds);
    if (tr.isBlack()) return Color3f(0.0f);
    const float weight = balanceHeuristic(pdf, freeFlightPdf(segment, t));
    return sigmaS * std::exp(-segment.sigmaT * t) * phase * tr * radianceOverPdf * weight /
           (pdf * selectionPdf);
}

// One light sample for a scattering vertex at `p` in `medium` (phase function) or at a surface
// (BSDF, `its` non-null), with transmittance through media. Draws 1D + 2D numbers always, plus
// whatever ratio tracking needs. With `mis` the result carries the balance heuristic weight
// against phase/BSDF sampling (delta lights keep weight 1).
struct ScatteringVertex {
    Point3f p;
    const Intersection* its = nullptr;  // surface vertices only
    const BSDF* bsdf = nullptr;         // surface vertices only
    Vector3f wi;                        // world direction back along the path
    const Medium* medium = nullptr;     // the medium the vertex lies in (media vertices)
    // Media vertices on a segment where equiangular sampling runs too: the segment, and the
    // vertex's parameter on it (delta lights then share their weight with that strategy).
    const EquiangularSegment* segment = nullptr;
    float t = 0.0f;

    // A vertex on a surface, reached along `dir` inside `medium`.
    static ScatteringVertex onSurface(const Intersection& its, const BSDF& bsdf,
                                      const Vector3f& dir, const Medium* medium) {
        ScatteringVertex v;
        v.p = its.p;
        v.its = &its;
        v.bsdf = &bsdf;
        v.wi = -dir;
        v.medium = medium;
        return v;
    }
};

inline Color3f sampleLightThroughMedia(const Scene& scene, Sampler& sampler,
                                       const ScatteringVertex& v, const Eigen::AlignedBox3f& bounds,
                                       bool mis) {
    const LightSample light = sampleLight(scene, sampler, v.p);
    if (!light.emitter) return Color3f(0.0f);
    const Emitter* emitter = light.emitter;
    const EmitterQueryRecord& lRec = light.rec;
    const Color3f& radianceOverPdf = light.radianceOverPdf;
    const float selectionPdf = light.selectionPdf;

    Color3f f;
    float scatterPdf;
    const Medium* shadowMedium = v.medium;
    if (v.its) {
        BSDFQueryRecord bRec = makeBSDFQuery(*v.its, v.its->toLocal(v.wi));
        bRec.wo = v.its->toLocal(lRec.wi);
        bRec.measure = Measure::SolidAngle;
        f = v.bsdf->eval(bRec) * std::abs(Frame::cosTheta(bRec.wo));
        scatterPdf = v.bsdf->pdf(bRec);
        shadowMedium = v.its->mesh->mediumTowards(*v.its, lRec.wi, v.medium);
    } else {
        f = Color3f(v.medium->phase().eval(v.wi, lRec.wi));
        scatterPdf = v.medium->phase().pdf(v.wi, lRec.wi);
    }
    if (f.isBlack()) return Color3f(0.0f);
    // The shadow ray is traced last: it is the expensive part and often unnecessary.
    const Color3f tr = transmittanceAlong(scene, sampler, lRec.shadowRay, shadowMedium, bounds);
    if (tr.isBlack()) return Color3f(0.0f);

    Color3f result = f * tr * radianceOverPdf / selectionPdf;
    if (mis && !emitter->isDelta()) result *= balanceHeuristic(lRec.pdf * selectionPdf, scatterPdf);
    if (emitter->isDelta() && v.segment)
        result *= balanceHeuristic(freeFlightPdf(*v.segment, v.t),
                                   equiangularPdf(equiangularFrame(*v.segment, lRec.p), v.t));
    return result;
}

// The volumetric path tracer. Without `mis` (volume_path_mats) light is found only by
// phase/BSDF sampling hitting emitters; with it (volume_path_mis) every non-delta scattering
// vertex also samples a light, and both strategies are weighted by the balance heuristic.
// Russian roulette from the fourth scattering vertex on, as in path_mats; no depth cap.
// `mediaBox` is mediaBounds(scene), computed once per scene by the integrator.
inline Color3f volumePathLi(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                            const Eigen::AlignedBox3f& mediaBox, bool mis,
                            bool equiangular = false) {
    Color3f result(0.0f);
    // Throughput under spectral MIS for chromatic media (see MediumSample).
    SpectralThroughput path;
    Color3f& throughput = path.throughput;
    float etaScale = 1.0f;
    // Unit direction: media measure distances in world units.
    const float length = cameraRay.d.norm();
    if (!(length > 0.0f)) return result;
    Ray3f ray(cameraRay.o, cameraRay.d / length, cameraRay.mint * length, cameraRay.maxt * length);
    const Medium* medium = scene.camera()->medium();
    Eigen::AlignedBox3f bounds = mediaBox;
    bounds.extend(cameraRay.o);
    // Density of the phase/BSDF sample that produced the current ray, for MIS of emitter hits;
    // negative for the camera ray and after delta bounces (emission then counts fully).
    float scatterPdf = -1.0f;
    Point3f lastVertex = ray.o;  // where that sample was taken (null crossings do not move it)
    for (int depth = 0;;) {
        Intersection its;
        const bool hit = scene.rayIntersect(ray, its);
        if (isParticipating(medium)) {
            const float end = hit ? its.t : std::min(ray.maxt, exitDistance(bounds, ray));
            std::optional<EquiangularSegment> segment;
            if (equiangular) {
                const auto grey = medium->greyHomogeneous();
                if (grey && grey->sigmaT > 0.0f && !grey->sigmaS.isBlack()) {
                    segment = EquiangularSegment{ray.o, ray.d, end, grey->sigmaT};
                    result += throughput * sampleEquiangular(scene, sampler, *segment, *medium,
                                                             grey->sigmaS, bounds);
                }
            }
            const MediumSample ms =
                medium->sampleDistance(Ray3f(ray.o, ray.d), end, sampler, path.hero);
            if (ms.event == MediumSample::Event::Absorbed) break;
            path.apply(ms);
            // A purely absorbing medium "scatters" with weight sigmaS = 0: the path ends.
            if (throughput.isBlack()) break;
            if (ms.event == MediumSample::Event::Scattered) {
                if (depth >= 3) {
                    const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
                    if (sampler.next1D() >= q) break;
                    throughput /= q;
                }
                ++depth;
                const Vector3f wi = -ray.d;
                if (mis) {
                    ScatteringVertex v;
                    v.p = ms.p;
                    v.wi = wi;
                    v.medium = medium;
                    v.segment = segment ? &*segment : nullptr;
                    v.t = ms.t;
                    result += throughput * sampleLightThroughMedia(scene, sampler, v, bounds, true);
                }
                Vector3f wo;
                const float weight = medium->phase().sample(wi, wo, sampler.next2D());
                if (!(weight > 0.0f)) break;
                throughput *= weight;
                scatterPdf = medium->phase().pdf(wi, wo);
                lastVertex = ms.p;
                // A scattering point is not on a surface: the next ray may start at 0.
                ray = Ray3f(ms.p, wo, 0.0f, Infinity);
                continue;
            }
        }
        if (!hit) break;

        const Vector3f dir = ray.d;
        const Color3f le = emittedRadiance(lastVertex, dir, its);
        if (!le.isBlack()) {
            const float w =
                !mis || scatterPdf < 0.0f
                    ? 1.0f
                    : balanceHeuristic(scatterPdf, emitterSamplingPdf(scene, lastVertex, dir, its));
            result += throughput * le * w;
        }

        const BSDF& bsdf = *its.mesh->bsdf();
        if (bsdf.isNull()) {
            medium = its.mesh->mediumTowards(its, dir, medium);
            ray = Ray3f(its.p, dir, Epsilon, ray.maxt - its.t);
            continue;
        }

        if (depth >= 3) {
            const float q = std::min(throughput.maxCoeff() * etaScale, 0.99f);
            if (sampler.next1D() >= q) break;
            throughput /= q;
        }
        ++depth;

        const Vector3f wiLocal = its.toLocal(-dir);
        if (mis && bsdf.isDiffuse()) {
            const ScatteringVertex v = ScatteringVertex::onSurface(its, bsdf, dir, medium);
            result += throughput * sampleLightThroughMedia(scene, sampler, v, bounds, true);
        }

        BSDFQueryRecord bRec = makeBSDFQuery(its, wiLocal);
        const Color3f weight = bsdf.sample(bRec, sampler.next2D());
        if (weight.isBlack() || !weight.allFinite()) break;
        scatterPdf = bRec.measure == Measure::Discrete ? -1.0f : bsdf.pdf(bRec);
        lastVertex = its.p;
        throughput *= weight;
        etaScale *= bRec.eta * bRec.eta;
        const Vector3f wo = its.toWorld(bRec.wo).normalized();
        medium = its.mesh->mediumTowards(its, wo, medium);
        ray = Ray3f(its.p, wo);
    }
    return result;
}

}  // namespace alphorn
