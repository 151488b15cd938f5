#include "common/photon/volume_photon_map.h"

#include "common/core/error.h"
#include "common/photon/photon_kdtree.h"

#include <tbb/parallel_for.h>

namespace alphorn {

VolumePhotonMap::VolumePhotonMap(Photons photons, std::vector<const Medium*> media, float radius)
    : m_photons(std::move(photons)), m_media(std::move(media)), m_radii{radius} {
    buildIndex();
}

VolumePhotonMap::VolumePhotonMap(Photons photons, std::vector<const Medium*> media, size_t k,
                                 float maxRadius, float radiusScale)
    : m_photons(std::move(photons)), m_media(std::move(media)) {
    m_radii.assign(m_photons.size(), maxRadius);
    if (m_photons.size() >= k && k > 0) {
        const PhotonKdTree tree(m_photons.data(), m_photons.size());
        // Each radius is a pure function of the photon array: any chunking gives the same radii.
        tbb::parallel_for(size_t(0), m_photons.size(), [&](size_t i) {
            thread_local std::vector<PhotonNeighbor> neighbors;
            if (neighbors.size() < k) neighbors.resize(k);
            const size_t found =
                tree.nearest(m_photons[i].position, k, maxRadius, neighbors.data());
            if (found == k && neighbors[k - 1].distance2 > 0.0f)
                m_radii[i] = std::sqrt(neighbors[k - 1].distance2);
        });
    }
    if (radiusScale != 1.0f)
        for (float& radius : m_radii) radius *= radiusScale;
    buildIndex();
}

void VolumePhotonMap::buildIndex() {
    if (!m_media.empty() && m_media.size() != m_photons.size())
        fail("VolumePhotonMap: %d media for %d photons", m_media.size(), m_photons.size());
    std::vector<Point3f> centres(m_photons.size());
    for (size_t i = 0; i < m_photons.size(); ++i) centres[i] = m_photons[i].position;
    m_index = SphereBvh(std::move(centres), m_radii);
}

}  // namespace alphorn
