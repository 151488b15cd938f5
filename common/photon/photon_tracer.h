// Tracing the photons of one pass. Photon i of pass p draws every number from the scene's
// sampler stream (seed, p, i, StreamPurpose::Photon), so the photons of a pass are a pure
// function of (scene, seed, pass, count): the same on every worker and for any thread count.
#pragma once

#include "common/photon/photon.h"

#include <vector>

namespace alphorn {

class Medium;
class Scene;

struct TracedPhotons {
    // Photons stored at non-delta surfaces, in photon-index order (and, for one photon path,
    // in path order).
    Photons surface;
    // Photons stored at scattering events in media (tracePhotonsThroughMedia only), same order,
    // and the medium each scattered in (its phase function serves the beam estimate).
    Photons volume;
    std::vector<const Medium*> volumeMedia;
    // Photon paths whose surface photons were kept, the count every stored surface power is
    // divided by (64-bit: a progressive render emits far more than 2³² photons over its passes,
    // and farms more still).
    uint64_t emitted = 0;
    // The same for the volume photons.
    uint64_t volumeEmitted = 0;
};

// Whether a photon path stores its first surface photon when nothing scattered it on the way
// from the light (light → non-delta surface, through media and null boundaries): integrators
// that compute that direct light by next-event estimation skip it, so that their photons carry
// indirect light only. Light that reaches a surface by a mirror, glass or a scattering event in
// a medium (caustics included) is stored either way.
enum class DirectPhotons { Store, Skip };

// Emits `count` photons, each from an emitter chosen in proportion to its power and sampled by
// that emitter's own samplePhoton(), and follows them with Russian roulette (no depth cap:
// a cap biases bright closed scenes low). Runs in parallel over fixed chunks of photon indices.
TracedPhotons tracePhotons(const Scene& scene, uint64_t seed, uint64_t pass, uint64_t count,
                           DirectPhotons direct = DirectPhotons::Store);

// The same loop through participating media, for the volumetric photon mapper: photons start in
// the medium around their emitter, cross null (index-matched) boundaries without an event, fly
// through media by the medium's own free-flight sampling (closed form or delta tracking, spectral
// MIS for chromatic media) and scatter by its phase function. Path i stores its surface photons
// (non-delta surfaces) when i < surfaceCount and its volume photons (every scattering event in a
// medium, with the power after the event's weight, which carries sigmaS; see
// volumetric_photonmapper.cpp) when i < volumeCount; max(surfaceCount, volumeCount) paths are
// traced. Russian roulette at every event, no depth cap. `emitted` = surfaceCount and
// `volumeEmitted` = volumeCount.
TracedPhotons tracePhotonsThroughMedia(const Scene& scene, uint64_t seed, uint64_t pass,
                                       uint64_t surfaceCount, uint64_t volumeCount,
                                       DirectPhotons direct = DirectPhotons::Store);

}  // namespace alphorn
