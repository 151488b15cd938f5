// A hashed uniform grid over photon positions for fixed-radius queries (Teschner et al. 2003):
// cells of side >= 2 r_max, so a query sphere of radius r <= r_max overlaps at most 2 x 2 x 2
// cells; cells map to buckets by a spatial hash, and photons are counting-sorted by bucket.
// Measured against nanoflann's k-d tree in bench/photon_map.cpp (bench/RESULTS.md).
//
// Content is a deterministic function of the photon array and r_max: the buckets are computed
// in parallel, but the counting sort places photons of a bucket in photon-index order.
//
// The grid keeps its own copy of each photon in entry order, so that a gather reads the photons
// it visits from a few contiguous runs: looking them up by index in the map's array cost a cache
// miss per photon, which dominated large gathers (bench/RESULTS.md, "The stage at full
// settings").
#pragma once

#include "common/photon/photon.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace alphorn {

class PhotonHashGrid {
  public:
    PhotonHashGrid() = default;
    // Indexes photons[0, count) for queries of radius at most maxRadius (> 0). The grid copies
    // what it needs: the array may go once it is built.
    PhotonHashGrid(const Photon* photons, size_t count, float maxRadius);

    size_t size() const { return m_order.size(); }
    float maxRadius() const { return m_maxRadius; }

    // Calls f(index, distance²) for every photon with distance² < radius² (radius <= maxRadius),
    // bucket by bucket, in photon-index order within a bucket.
    template <typename F>
    void forEachWithin(const Point3f& x, float radius, F&& f) const {
        forEachEntryWithin(x, radius, [&](uint32_t e, float d2) { f(m_order[e], d2); });
    }

    // The same visit in the same order, calling f(photon, distance²) with the grid's copy of the
    // photon (equal to photons[index]).
    template <typename F>
    void forEachPhotonWithin(const Point3f& x, float radius, F&& f) const {
        forEachEntryWithin(x, radius, [&](uint32_t e, float d2) { f(m_photons[e], d2); });
    }

  private:
    // Calls f(entry, distance²) for the entries within radius of x, in the order documented at
    // forEachWithin().
    template <typename F>
    void forEachEntryWithin(const Point3f& x, float radius, F&& f) const {
        if (m_order.empty()) return;
        // A larger sphere could reach a third cell per axis, which the scan below would miss.
        if (radius > m_maxRadius) radiusTooLarge(radius);
        const float radius2 = radius * radius;
        // The cells the sphere can touch, widened by a sliver so that rounding in the cell
        // computation never drops a photon on the sphere's edge (the sliver costs an extra
        // cell only for queries within 10⁻³ cells of a cell face). Cell coordinates are
        // computed in double, so the sliver covers rounding even in scenes 10⁹ radii wide.
        int lo[3], hi[3];
        for (int a = 0; a < 3; ++a) {
            const double u = cellUnits(x[a], a);
            const double reach = double(radius) * m_invCellSize + 1e-3;
            lo[a] = cellCoordinate(u - reach);
            hi[a] = cellCoordinate(u + reach);
        }
        std::array<uint32_t, 27> buckets;
        size_t bucketCount = 0;
        for (int i = lo[0]; i <= hi[0]; ++i)
            for (int j = lo[1]; j <= hi[1]; ++j)
                for (int k = lo[2]; k <= hi[2]; ++k) {
                    const uint32_t b = bucketOf(i, j, k);
                    // Two cells sharing a bucket must not be scanned twice.
                    bool seen = false;
                    for (size_t s = 0; s < bucketCount; ++s) seen |= buckets[s] == b;
                    if (!seen && bucketCount < buckets.size()) buckets[bucketCount++] = b;
                }
        // Each bucket is scanned in batches: first the distances, collecting the entries
        // inside without a branch (about one photon in five is, at random: a branch per photon
        // mispredicted often enough to cost more than the arithmetic), then f for each. The
        // scan reads only the positions, kept apart from the rest of each photon.
        constexpr uint32_t kBatch = 64;
        uint32_t inside[kBatch];
        float insideDistance2[kBatch];
        for (size_t s = 0; s < bucketCount; ++s) {
            const uint32_t b = buckets[s];
            const uint32_t end = m_bucketStart[b + 1];
            for (uint32_t first = m_bucketStart[b]; first < end; first += kBatch) {
                const uint32_t last = std::min(end, first + kBatch);
                uint32_t count = 0;
                for (uint32_t e = first; e < last; ++e) {
                    const Point3f& p = m_positions[e];
                    // The same arithmetic as nanoflann's L2 metric, term by term.
                    float d2 = 0.0f;
                    for (int a = 0; a < 3; ++a) {
                        const float diff = x[a] - p[a];
                        d2 += diff * diff;
                    }
                    inside[count] = e;
                    insideDistance2[count] = d2;
                    count += d2 < radius2 ? 1u : 0u;
                }
                for (uint32_t i = 0; i < count; ++i) f(inside[i], insideDistance2[i]);
            }
        }
    }

    // A coordinate along axis a in cell units from the grid's origin.
    double cellUnits(float x, int a) const { return (double(x) - m_origin[a]) * m_invCellSize; }
    static int cellCoordinate(double u) {
        // Clamped so that absurd coordinates cannot overflow; such cells merely share buckets.
        return static_cast<int>(std::floor(std::clamp(u, -1e9, 1e9)));
    }
    [[noreturn]] void radiusTooLarge(float radius) const;
    uint32_t bucketOf(int i, int j, int k) const {
        const uint32_t h = (static_cast<uint32_t>(i) * 73856093u) ^
                           (static_cast<uint32_t>(j) * 19349663u) ^
                           (static_cast<uint32_t>(k) * 83492791u);
        return h & m_bucketMask;
    }

    double m_origin[3] = {0.0, 0.0, 0.0};
    double m_invCellSize = 1.0;
    float m_maxRadius = 0.0f;
    uint32_t m_bucketMask = 0;
    // Rebuilt every pass, tens of MiB for a million photons: huge pages, as Photons.
    HugePageVector<uint32_t> m_bucketStart;  // bucket b holds entries [start[b], start[b + 1])
    HugePageVector<uint32_t> m_order;        // photon index of each entry
    Photons m_photons;                       // the photon of each entry (locality)
    HugePageVector<Point3f> m_positions;     // its position, apart: the scan reads only these
};

}  // namespace alphorn
