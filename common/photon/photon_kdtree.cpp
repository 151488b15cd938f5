#include "common/photon/photon_kdtree.h"

namespace alphorn {

namespace {

// k nearest neighbours within a maximum radius, kept sorted by insertion (k is small: tens).
// Unlike nanoflann's KNNResultSet it starts with worstDist() = maxRadius², so the search
// never descends into cells beyond the radius while fewer than k photons are found.
class BoundedKnnResultSet {
  public:
    BoundedKnnResultSet(size_t k, float maxRadius2, PhotonNeighbor* out)
        : m_k(k), m_maxRadius2(maxRadius2), m_out(out) {}
    size_t size() const { return m_count; }
    bool full() const { return m_count == m_k; }
    float worstDist() const { return full() ? m_out[m_k - 1].distance2 : m_maxRadius2; }
    bool addPoint(float distance2, uint32_t index) {
        // nanoflann reads worstDist() once per leaf, so within a leaf it may offer photons that
        // no longer beat the k-th: those must not enter.
        if (full() && !(distance2 < m_out[m_k - 1].distance2)) return true;
        size_t i = full() ? m_k - 1 : m_count++;
        while (i > 0 && m_out[i - 1].distance2 > distance2) {
            m_out[i] = m_out[i - 1];
            --i;
        }
        m_out[i] = PhotonNeighbor{index, distance2};
        return true;
    }

  private:
    size_t m_k, m_count = 0;
    float m_maxRadius2;
    PhotonNeighbor* m_out;
};

}  // namespace

PhotonKdTree::Impl::Impl(const Photon* photons, size_t count, size_t leafSize)
    : adaptor{photons, count},
      tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(leafSize)) {}

PhotonKdTree::PhotonKdTree(const Photon* photons, size_t count, size_t leafSize)
    : m_impl(std::make_unique<Impl>(photons, count, leafSize)) {}

size_t PhotonKdTree::nearest(const Point3f& x, size_t k, float maxRadius,
                             PhotonNeighbor* out) const {
    if (!m_impl || m_impl->adaptor.count == 0 || k == 0) return 0;
    BoundedKnnResultSet result(k, maxRadius * maxRadius, out);
    m_impl->tree.findNeighbors(result, x.data(), nanoflann::SearchParams());
    return result.size();
}

}  // namespace alphorn
