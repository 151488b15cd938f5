#include "common/photon/photon_map.h"

#include "common/core/error.h"

namespace alphorn {

PhotonMap::PhotonMap(Photons photons, Lookup lookup, float radius)
    : m_photons(std::move(photons)), m_lookup(lookup) {
    // The k-d tree points into m_photons' buffer, which a move of the map keeps in place (the
    // hash grid keeps its own copy of the photons).
    if (lookup == Lookup::Radius)
        m_grid = PhotonHashGrid(m_photons.data(), m_photons.size(), radius);
    else
        m_tree = PhotonKdTree(m_photons.data(), m_photons.size());
}

size_t PhotonMap::nearest(const Point3f& x, size_t k, float maxRadius, PhotonNeighbor* out) const {
    if (m_lookup != Lookup::Nearest) fail("photon map: nearest() on a fixed-radius map");
    return m_tree.nearest(x, k, maxRadius, out);
}

}  // namespace alphorn
