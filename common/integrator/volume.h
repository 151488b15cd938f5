// Volumetric path tracing shared by volume_path_mats and volume_path_mis (and the volumetric
// photon mapper's camera paths): light sampling through media, equiangular sampling towards
// point-like lights, and the path loop itself. Both integrators are one algorithm; they differ
// only in whether lights are also sampled (next-event estimation with MIS), so the loop lives
// here once and each plugin file only chooses. Walking rays through the scene's media and null
// boundaries (the medium bookkeeping, transmittance) is common/scene/media_traversal.h.
#pragma once

#include "common/integrator/direct.h"
#include "common/medium/equiangular.h"
#include "common/scene/media_traversal.h"

namespace alphorn {

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

Color3f sampleLightThroughMedia(const Scene& scene, Sampler& sampler, const ScatteringVertex& v,
                                const Eigen::AlignedBox3f& bounds, bool mis);

// The volumetric path tracer. Without `mis` (volume_path_mats) light is found only by
// phase/BSDF sampling hitting emitters; with it (volume_path_mis) every non-delta scattering
// vertex also samples a light, and both strategies are weighted by the balance heuristic.
// Russian roulette from the fourth scattering vertex on, as in path_mats; no depth cap.
// `mediaBox` is mediaBounds(scene), computed once per scene by the integrator.
Color3f volumePathLi(const Scene& scene, Sampler& sampler, const Ray3f& cameraRay,
                     const Eigen::AlignedBox3f& mediaBox, bool mis, bool equiangular = false);

}  // namespace alphorn
