// A k-d tree over photon positions: nanoflann (Debian's libnanoflann-dev, header-only), used
// for k-nearest-neighbour queries, and measured against the hashed grid for fixed-radius ones
// (bench/photon_map.cpp; figures in bench/RESULTS.md).
//
// The tree is a deterministic function of the photon array (nanoflann splits at the middle of
// the bounding box, with no randomness), so equal photon arrays give equal trees and equal
// query results on every machine, whatever the thread count.
#pragma once

#include "common/photon/photon.h"

#include <nanoflann.hpp>

#include <memory>

namespace alphorn {

// One neighbour found by a query: the photon's index and its squared distance to the query.
struct PhotonNeighbor {
    uint32_t index;
    float distance2;
};

class PhotonKdTree {
  public:
    PhotonKdTree() = default;
    // Indexes photons[0, count); the array must outlive the tree and stay where it is. Leaves
    // hold up to `leafSize` photons: in bench/photon_map.cpp leaves of 8, 16 and 32 came within
    // 15% of each other on fixed-radius gathers (32 slightly ahead); kNN, the tree's use here,
    // was not tuned further.
    PhotonKdTree(const Photon* photons, size_t count, size_t leafSize = 16);

    size_t size() const { return m_impl ? m_impl->adaptor.count : 0; }

    // Calls f(index, distance²) for every photon with distance² < radius², in tree order.
    template <typename F>
    void forEachWithin(const Point3f& x, float radius, F&& f) const {
        if (!m_impl || m_impl->adaptor.count == 0) return;
        CallbackResultSet<F> result{radius * radius, f};
        m_impl->tree.findNeighbors(result, x.data(), nanoflann::SearchParams());
    }

    // The up to k photons nearest to x with distance² < maxRadius², closest first, in out[0, n);
    // returns n. Ties in distance keep the order in which the tree reaches them.
    size_t nearest(const Point3f& x, size_t k, float maxRadius, PhotonNeighbor* out) const;

  private:
    // nanoflann's dataset interface over the photon array.
    struct Adaptor {
        const Photon* photons = nullptr;
        size_t count = 0;
        size_t kdtree_get_point_count() const { return count; }
        float kdtree_get_pt(uint32_t i, size_t dim) const { return photons[i].position[dim]; }
        template <class BBox>
        bool kdtree_get_bbox(BBox&) const {
            return false;  // let nanoflann compute it
        }
    };
    using Tree = nanoflann::KDTreeSingleIndexAdaptor<
        nanoflann::L2_Simple_Adaptor<float, Adaptor, float, uint32_t>, Adaptor, 3, uint32_t>;

    // nanoflann keeps a reference to the adaptor, so both live together at a fixed address.
    struct Impl {
        Adaptor adaptor;
        Tree tree;
        Impl(const Photon* photons, size_t count, size_t leafSize);
    };

    // Streams every photon inside the radius to the callback without collecting them.
    template <typename F>
    struct CallbackResultSet {
        float radius2;
        F& f;
        bool full() const { return true; }
        float worstDist() const { return radius2; }
        bool addPoint(float distance2, uint32_t index) {
            // nanoflann tests distance² < worstDist() before calling: the strict inequality
            // the hashed grid uses too, so both indexes find the same photons.
            f(index, distance2);
            return true;
        }
    };

    std::unique_ptr<Impl> m_impl;
};

}  // namespace alphorn
