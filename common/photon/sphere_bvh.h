// The beam radiance estimate's query (Jarosz, Zwicker, Jensen 2008): every photon sphere that a
// ray segment crosses. Sphere i (centre c_i, radius r_i) is crossed by o + t d (d unit length,
// t in [tMin, tMax]) when the point of the ray closest to c_i,
//
//     t_i = (c_i − o) · d,
//
// lies in [tMin, tMax] and |c_i − (o + t_i d)|² < r_i²: the photon's disc, facing the ray, is
// hit within the segment. Clipping by t_i (not by the sphere's entry point) is what keeps photons
// behind the surface that ends the segment out of the estimate.
//
// Two indexes answer it with exactly the same sphere sets (sphere_bvh_test.cpp checks both
// against brute force): our own bounding volume hierarchy (SphereBvh, used by the integrator)
// and Embree's BVH over user-geometry spheres (EmbreeSphereIndex). bench/beam_estimate.cpp
// measures both; the BVH was faster there (bench/RESULTS.md), so Embree stays for comparison.
//
// Order: both indexes return the crossed spheres sorted by (t, index), the order in which the
// beam estimate walks them along the ray (one transmittance walk serves them all). This is a
// total order of the answer set, so the hits and any sum over them in that order are pure
// functions of the sphere array, whatever the traversal order or the tree.
//
// Determinism: the BVH's median splits and node layout are fixed by the sphere array alone;
// subtrees are built in parallel into places computed beforehand.
#pragma once

#include "common/core/common.h"

#include <embree3/rtcore.h>

#include <vector>

namespace alphorn {

// A sphere crossed by a segment: its index and the ray parameter of its closest point.
// (Layout: index first, then t; sortByDistance() relies on it.)
struct SphereHit {
    uint32_t index;
    float t;
};

// Sorts hits[from, end) by (t, index).
void sortByDistance(std::vector<SphereHit>& hits, size_t from = 0);

// True when sphere (centre, radius²) is crossed by the segment; sets t to t_i. The one test both
// indexes and the brute-force reference use, so their answers agree to the last bit.
[[gnu::always_inline]] inline bool segmentCrossesSphere(const Point3f& origin,
                                                        const Vector3f& direction, float tMin,
                                                        float tMax, const Point3f& centre,
                                                        float radius2, float& t) {
    const Vector3f toCentre = centre - origin;
    t = toCentre.dot(direction);
    if (!(t >= tMin && t <= tMax)) return false;
    return (toCentre - t * direction).squaredNorm() < radius2;
}

class SphereBvh {
  public:
    SphereBvh() = default;
    // Indexes spheres[i] = (centres[i], radii[i]); a single radius applies to all when `radii`
    // has one element. Spheres of radius <= 0 are never crossed. Leaves hold up to `leafSize`
    // spheres: 8 was the fastest of 2, 4 and 8 in bench/beam_estimate.cpp (bench/RESULTS.md).
    SphereBvh(std::vector<Point3f> centres, std::vector<float> radii, uint32_t leafSize = 8);

    size_t size() const { return m_centres.size(); }

    // Appends to `hits` every sphere the segment crosses, sorted by (t, index).
    void query(const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
               std::vector<SphereHit>& hits) const;

  private:
    // The binary tree as built (median splits); queries use the 4-wide tree collapsed from it.
    struct Node {
        Eigen::AlignedBox3f bounds;
        // Leaves: [first, first + count) of m_order; inner nodes: count 0, children at
        // this + 1 and `first` (the second child's node index).
        uint32_t first = 0;
        uint32_t count = 0;
    };
    // Up to four children whose boxes one query tests together (SSE, one lane per child):
    // a binary node's children, each replaced by its own two children when it is inner.
    struct WideNode {
        float lower[3][4], upper[3][4];  // [axis][child]
        // Child c: a leaf, [first[c], first[c] + count[c]) of m_leaf, when count[c] > 0, else
        // the wide node first[c].
        uint32_t first[4], count[4];
        uint32_t children;  // 1 to 4
    };
    uint32_t subtreeNodes(uint32_t spheres) const;
    void build(uint32_t begin, uint32_t end, uint32_t nodeIndex,
               const std::vector<Eigen::AlignedBox3f>& boxes, std::vector<Node>& nodes);
    uint32_t collapse(const std::vector<Node>& nodes, uint32_t node);
    float radius2(uint32_t i) const {
        const float r = m_radii.size() == 1 ? m_radii[0] : m_radii[i];
        return r > 0.0f ? r * r : 0.0f;
    }

    // A sphere as a leaf stores it: leaves scan contiguous runs of these, not the input arrays
    // by index (a cache miss per sphere).
    struct LeafSphere {
        Point3f centre;
        float radius2;
        uint32_t index;
    };

    std::vector<Point3f> m_centres;
    std::vector<float> m_radii;
    std::vector<uint32_t> m_order;   // sphere indices, leaves' ranges point into it
    std::vector<LeafSphere> m_leaf;  // m_order's spheres, in its order
    std::vector<WideNode> m_wide;    // the root first
    uint32_t m_leafSize = 8;
};

// The same query over Embree's BVH: the spheres are user geometry whose intersection callback
// applies segmentCrossesSphere() and records the sphere without reporting a hit, so that
// traversal visits every crossed sphere. Built by one thread (commitEmbreeScene: deterministic),
// without capping the process's threads.
class EmbreeSphereIndex {
  public:
    EmbreeSphereIndex(std::vector<Point3f> centres, std::vector<float> radii);
    ~EmbreeSphereIndex();
    EmbreeSphereIndex(const EmbreeSphereIndex&) = delete;
    EmbreeSphereIndex& operator=(const EmbreeSphereIndex&) = delete;

    void query(const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
               std::vector<SphereHit>& hits) const;

    // For Embree's callbacks.
    const Point3f& centre(uint32_t i) const { return m_centres[i]; }
    float radius(uint32_t i) const { return m_radii.size() == 1 ? m_radii[0] : m_radii[i]; }

  private:
    std::vector<Point3f> m_centres;
    std::vector<float> m_radii;
    RTCDevice m_device = nullptr;
    RTCScene m_scene = nullptr;
};

// Reference answer by testing every sphere (tests and the benchmark's check), sorted by
// (t, index).
void bruteForceSphereQuery(const std::vector<Point3f>& centres, const std::vector<float>& radii,
                           const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
                           std::vector<SphereHit>& hits);

}  // namespace alphorn
