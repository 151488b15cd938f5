// Walking rays through the scene's participating media and index-matched (null) boundaries:
// whether a scene has any, the box media end at, the medium around a point, and transmittance
// for shadow rays. Camera paths (common/integrator/volume.h) and photon paths
// (common/photon/photon_tracer.cpp) share it.
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

#include "common/medium/medium.h"
#include "common/scene/scene.h"

namespace alphorn {

// Whether anything in the scene needs the volumetric path loop: a participating medium (at the
// camera or on a mesh) or a null surface to cross. Without, the volumetric path tracers run the
// surface path tracer itself (path.h), so that a scene pays nothing for media it does not have:
// the same film as path_mats / path_mis, byte for byte, at their cost (bench_feature_cost).
bool needsVolumetricPaths(const Scene& scene);

// The stretch [tNear, tFar] (tNear >= 0) of `ray` inside `box`; tNear > tFar when it misses it.
inline void boxInterval(const Eigen::AlignedBox3f& box, const Ray3f& ray, float& tNear,
                        float& tFar) {
    tNear = 0.0f;
    tFar = Infinity;
    for (int axis = 0; axis < 3; ++axis) {
        const float inv = 1.0f / ray.d[axis];
        float t0 = (box.min()[axis] - ray.o[axis]) * inv;
        float t1 = (box.max()[axis] - ray.o[axis]) * inv;
        if (t0 > t1) std::swap(t0, t1);
        // NaN (0 * inf on a slab face) compares false and leaves the bounds unchanged.
        if (t0 > tNear) tNear = t0;
        if (t1 < tFar) tFar = t1;
    }
}

// The distance along `ray` (unit direction) at which it leaves `box`; 0 when it never is inside.
inline float exitDistance(const Eigen::AlignedBox3f& box, const Ray3f& ray) {
    float tNear, tFar;
    boxInterval(box, ray, tNear, tFar);
    return tNear <= tFar ? std::max(tFar, 0.0f) : 0.0f;
}

// The box that media end at along rays that hit nothing: the scene's meshes, its lights (a
// spotlight above an open floor is outside the meshes' box) and the camera, 1% larger so that a
// medium filling a closed mesh is never cut by it. Camera ray origins are added per path
// (volumePathLi), which also covers thin-lens apertures.
Eigen::AlignedBox3f mediaBounds(const Scene& scene);

// The most tentative collisions that tracking may expect along the longest line through the box
// a medium fills (majorant times the box's diagonal): 2^21. The mean step is then at least four
// float spacings of the distances it is added to (at most 2^-23 of the box's size), so rounding
// changes the mean step by under 0.3%; beyond 2^23 the average step is smaller than one spacing
// and tracking stops advancing (t + step == t), and a crossing already costs millions of texture
// evaluations. Light through such a medium is gone (a transmittance of e^-(2^21)).
inline constexpr double kMaxTrackingCollisions = double(1 << 21);

// Refuses a medium whose majorant times the size of the region it fills exceeds
// kMaxTrackingCollisions, naming the medium, its majorant, the size and the limit. The region of
// a mesh's inside medium is the mesh's bounding box; of an outside or the camera's medium, the
// box media end at (mediaBounds).
void checkMediaTrackingWork(const Scene& scene);

// The medium at point `p`, from the first medium boundary a ray from p meets: the medium on the
// side it arrives from. For lights inside media (photon emission needs the medium a photon
// starts in) and tests; nullptr (vacuum) when no boundary encloses p. Assumes closed,
// consistently declared boundaries, like the rest of the bookkeeping.
const Medium* mediumAt(const Scene& scene, const Point3f& p);

// Transmittance along `ray` (unit direction, over [ray.mint, ray.maxt]) starting in `medium`:
// the product over the media between null surfaces; zero when any other surface blocks it.
// Ratio tracking in heterogeneous media draws from `sampler`; homogeneous media draw nothing.
Color3f transmittanceAlong(const Scene& scene, Sampler& sampler, Ray3f ray, const Medium* medium,
                           const Eigen::AlignedBox3f& bounds);

}  // namespace alphorn
