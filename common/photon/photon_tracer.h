// Tracing the photons of one pass. Photon i of pass p draws every number from the scene's
// sampler stream (seed, p, i, StreamPurpose::Photon), so the photons of a pass are a pure
// function of (scene, seed, pass, count): the same on every worker and for any thread count.
#pragma once

#include "common/photon/photon.h"

#include <vector>

namespace alphorn {

class Scene;

struct TracedPhotons {
    // Photons stored at non-delta surfaces, in photon-index order (and, for one photon path,
    // in path order). A volume photon map will be filled by the same loop, beside this one.
    std::vector<Photon> surface;
    // Photon paths started, the count every stored power is divided by (64-bit: a progressive
    // render emits far more than 2³² photons over its passes, and farms more still).
    uint64_t emitted = 0;
};

// Emits `count` photons, each from an emitter chosen in proportion to its power and sampled by
// that emitter's own samplePhoton(), and follows them with Russian roulette (no depth cap:
// a cap biases bright closed scenes low). Runs in parallel over fixed chunks of photon indices.
TracedPhotons tracePhotons(const Scene& scene, uint64_t seed, uint64_t pass, uint64_t count);

}  // namespace alphorn
