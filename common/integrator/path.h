// The surface path tracer behind path_mats, path_ems and path_mis: one loop, three ways of
// finding direct light. Paths end by Russian roulette from the fourth vertex on (no depth cap,
// which would bias low), with continuation probability min(0.99, max throughput * eta^2): the
// eta^2 undoes the 1/eta^2 radiance scaling of refraction so paths inside glass are not killed
// for a change of units.
#pragma once

#include "common/core/color.h"
#include "common/core/properties.h"
#include "common/core/ray.h"

namespace alphorn {

class Scene;
class Sampler;

enum class DirectLight {
    BSDFSampling,     // emission counted wherever the path hits it (path_mats)
    EmitterSampling,  // one emitter sample per non-delta vertex; hits count after delta bounces
                      // only
    MIS,              // both, combined by the balance heuristic (path_mis)
};

// Radiance along `ray`. maxDepth: bounces, -1 for unlimited.
Color3f tracePath(const Scene& scene, Sampler& sampler, const Ray3f& ray, int maxDepth,
                  DirectLight strategy);

// The optional `maxDepth` property (bounces; -1 = unlimited, the default), for debugging only.
int maxDepthProperty(const PropertyList& props);

}  // namespace alphorn
