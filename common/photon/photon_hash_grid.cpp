#include "common/photon/photon_hash_grid.h"

#include "common/core/error.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <bit>

namespace alphorn {

PhotonHashGrid::PhotonHashGrid(const Photon* photons, size_t count, float maxRadius)
    : m_maxRadius(maxRadius) {
    if (!(maxRadius > 0.0f) || !std::isfinite(maxRadius))
        fail("photon hash grid: the radius must be positive and finite, got %g", maxRadius);
    if (count >= (size_t(1) << 31)) fail("photon hash grid: too many photons (%zu)", count);
    if (count == 0) return;
    Point3f origin = photons[0].position;
    for (size_t i = 1; i < count; ++i) origin = origin.cwiseMin(photons[i].position);
    for (int a = 0; a < 3; ++a) m_origin[a] = origin[a];
    // Slightly more than 2 r so that a sphere of radius r spans at most two cells per axis.
    m_invCellSize = 1.0 / (2.0 * double(maxRadius) * 1.0001);
    // About two buckets per photon keeps collisions rare without wasting memory.
    const uint32_t buckets = std::bit_ceil(static_cast<uint32_t>(2 * count));
    m_bucketMask = buckets - 1;

    HugePageVector<uint32_t> bucket(count);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, count, 4096),
                      [&](const tbb::blocked_range<size_t>& range) {
                          for (size_t i = range.begin(); i != range.end(); ++i) {
                              const Point3f& p = photons[i].position;
                              bucket[i] = bucketOf(cellCoordinate(cellUnits(p.x(), 0)),
                                                   cellCoordinate(cellUnits(p.y(), 1)),
                                                   cellCoordinate(cellUnits(p.z(), 2)));
                          }
                      });
    // Counting sort, stable in photon index: the layout does not depend on the thread count.
    m_bucketStart.assign(size_t(buckets) + 1, 0);
    for (uint32_t b : bucket) ++m_bucketStart[b + 1];
    for (size_t b = 0; b < buckets; ++b) m_bucketStart[b + 1] += m_bucketStart[b];
    m_order.resize(count);
    m_photons.resize(count);
    m_positions.resize(count);
    HugePageVector<uint32_t> next(m_bucketStart.begin(), m_bucketStart.end() - 1);
    for (size_t i = 0; i < count; ++i) {
        const uint32_t e = next[bucket[i]]++;
        m_order[e] = static_cast<uint32_t>(i);
        m_photons[e] = photons[i];
        m_positions[e] = photons[i].position;
    }
}

void PhotonHashGrid::radiusTooLarge(float radius) const {
    fail("photon hash grid: query radius %g exceeds the radius %g it was built for", radius,
         m_maxRadius);
}

}  // namespace alphorn
