// The volume photon map of the volumetric photon mapper: the photons stored at scattering events
// in media, each the centre of a sphere of its own radius, indexed for the beam radiance
// estimate's query "which spheres does this ray segment cross?" (sphere_bvh.h).
//
// Radii: one fixed radius for every photon, or per photon the distance to its k-th nearest
// volume photon (itself counted as the first), found with the k-d tree of photon_kdtree.h when
// the map is built. A photon with fewer than k photons within `maxRadius` (or whose k-th
// neighbour sits on it) gets `maxRadius`. Kernels stay normalised per photon, so adaptive radii
// blur but do not bias the power (no k/(k - 1) correction belongs here; it is for a gather's
// radius, not a photon's).
#pragma once

#include "common/photon/photon.h"
#include "common/photon/sphere_bvh.h"

#include <vector>

namespace alphorn {

class Medium;

class VolumePhotonMap {
  public:
    VolumePhotonMap() = default;
    // Fixed radius for every photon. `media[i]` is the medium photon i scattered in (or empty).
    VolumePhotonMap(Photons photons, std::vector<const Medium*> media, float radius);
    // Per-photon radius from the k nearest volume photons, at most maxRadius, times radiusScale
    // (progressive mode's shrinking factor r_pass / r_0).
    VolumePhotonMap(Photons photons, std::vector<const Medium*> media, size_t k, float maxRadius,
                    float radiusScale = 1.0f);
    VolumePhotonMap(VolumePhotonMap&&) = default;
    VolumePhotonMap& operator=(VolumePhotonMap&&) = default;

    const Photons& photons() const { return m_photons; }
    size_t size() const { return m_photons.size(); }
    bool empty() const { return m_photons.empty(); }
    float radius(uint32_t i) const { return m_radii.size() == 1 ? m_radii[0] : m_radii[i]; }
    const Medium* medium(uint32_t i) const { return m_media.empty() ? nullptr : m_media[i]; }

    // Appends the photons whose spheres the segment o + t d, t in [tMin, tMax] (d unit length)
    // crosses, each with the parameter t of its closest point, sorted by (t, photon index).
    void crossedBy(const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
                   std::vector<SphereHit>& hits) const {
        m_index.query(origin, direction, tMin, tMax, hits);
    }

  private:
    void buildIndex();

    Photons m_photons;
    std::vector<const Medium*> m_media;
    std::vector<float> m_radii;  // one element for a fixed radius
    SphereBvh m_index;
};

}  // namespace alphorn
