// What a photon-mapping integrator shares among all tiles of one pass: the pass's photon map(s)
// and gather radius. Built once per pass by Integrator::preparePass() and read by every tile;
// a pure function of (scene, seed, pass), so every worker that builds it gets the same bytes.
#pragma once

#include "common/core/error.h"
#include "common/integrator/integrator.h"
#include "common/photon/photon_map.h"
#include "common/photon/volume_photon_map.h"

namespace alphorn {

struct PhotonPassData : PassData {
    PhotonMap surface;
    double powerScale = 0.0;  // 1 / photons emitted in the pass (64-bit count, in double)
    uint64_t emitted = 0;
    float surfaceRadius = 0.0f;  // the pass's gather radius, or the kNN search radius
    // Progressive kNN maps: the factor r_pass / r_0 by which each query's kNN radius shrinks.
    float surfaceRadiusScale = 1.0f;
    // The volumetric photon mapper's volume photons with the beam estimate's index (empty for
    // the surface photon mapper and for scenes without media), normalised by their own count.
    VolumePhotonMap volume;
    // 1 / photon paths that fed the volume map (volumePhotonCount: emitted, not only those that
    // stored a photon)
    double volumePowerScale = 0.0;
    uint64_t volumeEmitted = 0;
    float volumeRadius = 0.0f;  // the pass's fixed radius, or the kNN radii's upper bound
};

// `data` as photon pass data; an error when it is anything else (e.g. null: a caller that
// skipped preparePass()).
inline const PhotonPassData& photonPassData(const PassData* data) {
    const auto* photons = dynamic_cast<const PhotonPassData*>(data);
    if (!photons) fail("a photon mapper needs the pass data of its preparePass()");
    return *photons;
}

}  // namespace alphorn
