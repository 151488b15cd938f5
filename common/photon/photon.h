// A photon: a sample of the flux arriving at a point. Surface photon maps store them where
// photon paths hit non-delta surfaces; the volume photon map (the beam radiance estimate)
// stores the same record at scattering events in media, so both maps share this type, the
// tracer's output and the index structures in this folder.
#pragma once

#include "common/core/color.h"
#include "common/core/huge_page_allocator.h"

namespace alphorn {

struct Photon {
    Point3f position;
    // Unit vector pointing back along the photon's path (towards where it came from): the
    // "outgoing" direction of a BSDF (or phase function) evaluated in a density estimate.
    Vector3f direction;
    // Flux carried, NOT yet divided by the number of photons emitted in its pass: that count is
    // exact only once the pass is traced, and keeping it out of the record leaves a photon map
    // valid for any normalisation (the estimators multiply by 1 / emitted, in double).
    Color3f power;
};

// A pass's photons: a million of them take tens of MiB, allocated anew every pass, so they live
// on huge pages (huge_page_allocator.h).
using Photons = HugePageVector<Photon>;

}  // namespace alphorn
