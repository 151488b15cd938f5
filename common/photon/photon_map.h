// A photon map: the photons of one pass and the one index its queries need. Fixed-radius maps
// (the progressive mode included: the radius of a pass is known before its photons are traced)
// and k-nearest-neighbour maps are indexed differently, each by the structure that measured
// faster for it (bench/photon_map.cpp, bench/RESULTS.md); a map builds only what its queries
// use.
//
// Density estimates over a map (density_estimate.h) see photons only through forEachWithin()
// and nearest(), so a volume photon map for the beam radiance estimate can join as a second map
// of the same Photon records with a ray query of its own, without changing this one.
#pragma once

#include "common/photon/photon.h"
#include "common/photon/photon_hash_grid.h"
#include "common/photon/photon_kdtree.h"

#include <vector>

namespace alphorn {

class PhotonMap {
  public:
    enum class Lookup {
        Radius,   // fixed-radius queries, radius at most the map's radius
        Nearest,  // k nearest neighbours (and fixed-radius queries of any radius)
    };

    PhotonMap() = default;
    // Takes the photons (their order is kept) and indexes them for `lookup`; `radius` is the
    // largest query radius of a Radius map (ignored for Nearest).
    PhotonMap(Photons photons, Lookup lookup, float radius = 0.0f);
    PhotonMap(PhotonMap&&) = default;
    PhotonMap& operator=(PhotonMap&&) = default;

    const Photons& photons() const { return m_photons; }
    size_t size() const { return m_photons.size(); }
    bool empty() const { return m_photons.empty(); }
    Lookup lookup() const { return m_lookup; }

    // Calls f(photon, distance²) for every photon with distance² < radius².
    template <typename F>
    void forEachWithin(const Point3f& x, float radius, F&& f) const {
        if (m_lookup == Lookup::Radius) {
            m_grid.forEachPhotonWithin(x, radius, f);
            return;
        }
        m_tree.forEachWithin(
            x, radius, [&](uint32_t index, float distance2) { f(m_photons[index], distance2); });
    }

    // The up to k photons nearest to x with distance² < maxRadius², closest first (Nearest
    // maps only); returns how many were found.
    size_t nearest(const Point3f& x, size_t k, float maxRadius, PhotonNeighbor* out) const;

  private:
    Photons m_photons;
    Lookup m_lookup = Lookup::Nearest;
    PhotonHashGrid m_grid;  // Radius maps
    PhotonKdTree m_tree;    // Nearest maps
};

}  // namespace alphorn
