#include "common/photon/sphere_bvh.h"

#include "common/core/error.h"
#include "common/scene/accel.h"

#include <algorithm>
#include <bit>
#include <cstddef>

#include <immintrin.h>
#include <tbb/parallel_invoke.h>

namespace alphorn {

void sortByDistance(std::vector<SphereHit>& hits, size_t from) {
    const auto begin = hits.begin() + static_cast<std::ptrdiff_t>(from);
    // For t >= +0 the bits of (t, index) read as one little-endian 64-bit integer, t's bits high,
    // order exactly as (t, index): sorting those integers is about twice as fast as the
    // comparator below. Negative t (a segment starting before its origin) and -0 (equal to +0
    // but with the sign bit) take the comparator.
    static_assert(sizeof(SphereHit) == sizeof(uint64_t) && offsetof(SphereHit, t) == 4);
    static_assert(std::endian::native == std::endian::little);
    const bool signless =
        std::none_of(begin, hits.end(), [](const SphereHit& h) { return std::signbit(h.t); });
    if (signless) {
        std::sort(begin, hits.end(), [](const SphereHit& a, const SphereHit& b) {
            return std::bit_cast<uint64_t>(a) < std::bit_cast<uint64_t>(b);
        });
        return;
    }
    std::sort(begin, hits.end(), [](const SphereHit& a, const SphereHit& b) {
        return a.t < b.t || (a.t == b.t && a.index < b.index);
    });
}

SphereBvh::SphereBvh(std::vector<Point3f> centres, std::vector<float> radii, uint32_t leafSize)
    : m_centres(std::move(centres)), m_radii(std::move(radii)), m_leafSize(std::max(leafSize, 1u)) {
    if (m_radii.size() != 1 && m_radii.size() != m_centres.size())
        fail("SphereBvh: %d radii for %d spheres", m_radii.size(), m_centres.size());
    if (m_centres.size() >= std::numeric_limits<uint32_t>::max())
        fail("SphereBvh: too many spheres (%d)", m_centres.size());
    if (m_centres.empty()) return;
    const auto count = static_cast<uint32_t>(m_centres.size());
    m_order.resize(count);
    std::vector<Eigen::AlignedBox3f> boxes(count);
    for (uint32_t i = 0; i < count; ++i) {
        m_order[i] = i;
        const float r = std::max(std::sqrt(radius2(i)), 0.0f);
        boxes[i] = Eigen::AlignedBox3f(m_centres[i] - Vector3f::Constant(r),
                                       m_centres[i] + Vector3f::Constant(r));
    }
    std::vector<Node> nodes(subtreeNodes(count));
    build(0, count, 0, boxes, nodes);
    m_leaf.resize(count);
    for (uint32_t k = 0; k < count; ++k) {
        const uint32_t i = m_order[k];
        m_leaf[k] = LeafSphere{m_centres[i], radius2(i), i};
    }
    m_wide.reserve(nodes.size() / 2 + 1);
    collapse(nodes, 0);
}

uint32_t SphereBvh::subtreeNodes(uint32_t spheres) const {
    if (spheres <= m_leafSize) return 1;
    const uint32_t half = spheres / 2;
    // Median splits differ by at most one sphere: most levels need one count, not two.
    const uint32_t left = subtreeNodes(half);
    return 1 + left + (spheres - half == half ? left : subtreeNodes(spheres - half));
}

// Depth first: node `nodeIndex` covers [begin, end) of m_order, its first child is the next node
// and its second follows the first child's subtree, whose size the sphere count alone fixes. So
// every node's place is known before it is built, and large subtrees are built in parallel
// (disjoint ranges of m_order and of `nodes`) with the same result on any number of threads.
// Splits at the median centre along the longest axis of the centres' box: nth_element is
// deterministic for equal input, and ties are broken by sphere index, so the tree is a pure
// function of the spheres.
void SphereBvh::build(uint32_t begin, uint32_t end, uint32_t nodeIndex,
                      const std::vector<Eigen::AlignedBox3f>& boxes, std::vector<Node>& nodes) {
    Eigen::AlignedBox3f bounds, centreBounds;
    for (uint32_t i = begin; i < end; ++i) {
        bounds.extend(boxes[m_order[i]]);
        centreBounds.extend(m_centres[m_order[i]]);
    }
    Node& node = nodes[nodeIndex];
    node.bounds = bounds;
    if (end - begin <= m_leafSize) {
        node.first = begin;
        node.count = end - begin;
        return;
    }
    int axis = 0;
    centreBounds.sizes().maxCoeff(&axis);
    const uint32_t middle = begin + (end - begin) / 2;
    std::nth_element(m_order.begin() + begin, m_order.begin() + middle, m_order.begin() + end,
                     [&](uint32_t a, uint32_t b) {
                         const float ca = m_centres[a][axis], cb = m_centres[b][axis];
                         return ca < cb || (ca == cb && a < b);
                     });
    const uint32_t second = nodeIndex + 1 + subtreeNodes(middle - begin);
    node.first = second;
    node.count = 0;
    // Below this many spheres a task costs more than it saves.
    constexpr uint32_t kParallelSpheres = 16384;
    if (end - begin >= kParallelSpheres)
        tbb::parallel_invoke([&] { build(begin, middle, nodeIndex + 1, boxes, nodes); },
                             [&] { build(middle, end, second, boxes, nodes); });
    else {
        build(begin, middle, nodeIndex + 1, boxes, nodes);
        build(middle, end, second, boxes, nodes);
    }
}

// The wide node for binary node `node` (and, recursively, its subtree); returns its index. A
// leaf root becomes a wide node with one leaf child.
uint32_t SphereBvh::collapse(const std::vector<Node>& nodes, uint32_t node) {
    uint32_t children[4];
    uint32_t count = 0;
    auto pushChildren = [&](uint32_t n) {
        children[count++] = n + 1;
        children[count++] = nodes[n].first;
    };
    if (nodes[node].count > 0) {
        children[count++] = node;
    } else {
        uint32_t pair[2] = {node + 1, nodes[node].first};
        for (uint32_t n : pair) {
            if (nodes[n].count > 0)
                children[count++] = n;
            else
                pushChildren(n);
        }
    }
    const auto wide = static_cast<uint32_t>(m_wide.size());
    m_wide.emplace_back();
    WideNode w{};
    w.children = count;
    for (uint32_t c = 0; c < 4; ++c) {
        // Unused lanes repeat the first child; the query masks them out.
        const Node& child = nodes[children[c < count ? c : 0]];
        for (int a = 0; a < 3; ++a) {
            w.lower[a][c] = child.bounds.min()[a];
            w.upper[a][c] = child.bounds.max()[a];
        }
    }
    for (uint32_t c = 0; c < count; ++c) {
        const Node& child = nodes[children[c]];
        w.count[c] = child.count;
        w.first[c] = child.count > 0 ? child.first : collapse(nodes, children[c]);
    }
    m_wide[wide] = w;
    return wide;
}

void SphereBvh::query(const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
                      std::vector<SphereHit>& hits) const {
    if (m_wide.empty() || !(tMin <= tMax)) return;
    const size_t from = hits.size();
    // Slab tests of four boxes at once. A zero direction component becomes a tiny one of the
    // same sign, so that no 0 * inf NaN reaches the min/max below: the segment then lies in a
    // slab's plane or crosses it, and its box test is only ever more permissive (the sphere test
    // decides). For every other direction the arithmetic is the scalar slab test's.
    __m128 o[3], inverse[3];
    for (int a = 0; a < 3; ++a) {
        float d = direction[a];
        if (d == 0.0f) d = std::copysign(1e-30f, d);
        o[a] = _mm_set1_ps(origin[a]);
        inverse[a] = _mm_set1_ps(1.0f / d);
    }
    const __m128 segmentNear = _mm_set1_ps(tMin), segmentFar = _mm_set1_ps(tMax);
    // Three pushes per level of a tree at most 32 wide levels deep (median splits halve the
    // spheres at every binary level, and 2^64 exceeds any array).
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const WideNode& node = m_wide[stack[--top]];
        __m128 nearT = segmentNear, farT = segmentFar;
        for (int a = 0; a < 3; ++a) {
            const __m128 t0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(node.lower[a]), o[a]), inverse[a]);
            const __m128 t1 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(node.upper[a]), o[a]), inverse[a]);
            nearT = _mm_max_ps(nearT, _mm_min_ps(t0, t1));
            farT = _mm_min_ps(farT, _mm_max_ps(t0, t1));
        }
        const int mask = _mm_movemask_ps(_mm_cmple_ps(nearT, farT)) & ((1 << node.children) - 1);
        for (uint32_t c = 0; c < node.children; ++c) {
            if (!(mask & (1 << c))) continue;
            if (node.count[c] == 0) {
                stack[top++] = node.first[c];
                continue;
            }
            for (uint32_t k = node.first[c]; k < node.first[c] + node.count[c]; ++k) {
                const LeafSphere& sphere = m_leaf[k];
                float t;
                if (segmentCrossesSphere(origin, direction, tMin, tMax, sphere.centre,
                                         sphere.radius2, t))
                    hits.push_back(SphereHit{sphere.index, t});
            }
        }
    }
    sortByDistance(hits, from);
}

void bruteForceSphereQuery(const std::vector<Point3f>& centres, const std::vector<float>& radii,
                           const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
                           std::vector<SphereHit>& hits) {
    const size_t from = hits.size();
    for (size_t i = 0; i < centres.size(); ++i) {
        const float r = radii.size() == 1 ? radii[0] : radii[i];
        float t;
        if (segmentCrossesSphere(origin, direction, tMin, tMax, centres[i], r > 0.0f ? r * r : 0.0f,
                                 t))
            hits.push_back(SphereHit{static_cast<uint32_t>(i), t});
    }
    sortByDistance(hits, from);
}

// ---- Embree ----------------------------------------------------------------------------------

namespace {

// Embree passes the context to the callbacks: the query's segment and output ride along.
struct SphereQueryContext {
    RTCIntersectContext context;  // first member: Embree's pointer is cast back to this struct
    const EmbreeSphereIndex* index;
    Point3f origin;
    Vector3f direction;
    float tMin, tMax;
    std::vector<SphereHit>* hits;
};

void sphereBounds(const RTCBoundsFunctionArguments* args) {
    const auto* index = static_cast<const EmbreeSphereIndex*>(args->geometryUserPtr);
    const Point3f& c = index->centre(args->primID);
    const float r = std::max(index->radius(args->primID), 0.0f);
    args->bounds_o->lower_x = c.x() - r;
    args->bounds_o->lower_y = c.y() - r;
    args->bounds_o->lower_z = c.z() - r;
    args->bounds_o->upper_x = c.x() + r;
    args->bounds_o->upper_y = c.y() + r;
    args->bounds_o->upper_z = c.z() + r;
}

// Records a crossed sphere and reports no hit, so that Embree keeps traversing.
void sphereIntersect(const RTCIntersectFunctionNArguments* args) {
    if (!args->valid[0]) return;
    auto* query = reinterpret_cast<SphereQueryContext*>(args->context);
    const float r = query->index->radius(args->primID);
    float t;
    if (segmentCrossesSphere(query->origin, query->direction, query->tMin, query->tMax,
                             query->index->centre(args->primID), r > 0.0f ? r * r : 0.0f, t))
        query->hits->push_back(SphereHit{args->primID, t});
}

}  // namespace

EmbreeSphereIndex::EmbreeSphereIndex(std::vector<Point3f> centres, std::vector<float> radii)
    : m_centres(std::move(centres)), m_radii(std::move(radii)) {
    if (m_radii.size() != 1 && m_radii.size() != m_centres.size())
        fail("EmbreeSphereIndex: %d radii for %d spheres", m_radii.size(), m_centres.size());
    m_device = newEmbreeDevice();
    m_scene = rtcNewScene(m_device);
    rtcSetSceneBuildQuality(m_scene, RTC_BUILD_QUALITY_HIGH);
    if (!m_centres.empty()) {
        RTCGeometry geometry = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_USER);
        rtcSetGeometryUserPrimitiveCount(geometry, static_cast<unsigned>(m_centres.size()));
        rtcSetGeometryUserData(geometry, this);
        rtcSetGeometryBoundsFunction(geometry, sphereBounds, this);
        rtcSetGeometryIntersectFunction(geometry, sphereIntersect);
        rtcCommitGeometry(geometry);
        rtcAttachGeometry(m_scene, geometry);
        rtcReleaseGeometry(geometry);
    }
    commitEmbreeScene(m_scene);
    const RTCError error = rtcGetDeviceError(m_device);
    if (error != RTC_ERROR_NONE) fail("Embree failed to build the sphere BVH (error %d)", error);
}

EmbreeSphereIndex::~EmbreeSphereIndex() {
    if (m_scene) rtcReleaseScene(m_scene);
    if (m_device) rtcReleaseDevice(m_device);
}

void EmbreeSphereIndex::query(const Point3f& origin, const Vector3f& direction, float tMin,
                              float tMax, std::vector<SphereHit>& hits) const {
    if (m_centres.empty() || !(tMin <= tMax)) return;
    const size_t from = hits.size();
    SphereQueryContext query;
    rtcInitIntersectContext(&query.context);
    query.index = this;
    query.origin = origin;
    query.direction = direction;
    query.tMin = tMin;
    query.tMax = tMax;
    query.hits = &hits;
    RTCRayHit rayhit;
    rayhit.ray.org_x = origin.x();
    rayhit.ray.org_y = origin.y();
    rayhit.ray.org_z = origin.z();
    rayhit.ray.dir_x = direction.x();
    rayhit.ray.dir_y = direction.y();
    rayhit.ray.dir_z = direction.z();
    // Embree needs tnear >= 0; a sphere crossed at t_i >= tMin still overlaps [tMin, tMax].
    rayhit.ray.tnear = std::max(tMin, 0.0f);
    rayhit.ray.tfar = tMax;
    rayhit.ray.time = 0.0f;
    rayhit.ray.mask = 0xffffffffu;
    rayhit.ray.id = 0;
    rayhit.ray.flags = 0;
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    if (!embreeAcceptsRay(rayhit.ray)) return;
    rtcIntersect1(m_scene, &query.context, &rayhit);
    // Embree's traversal order is its own: sort, so the answer is the BVH's to the byte.
    sortByDistance(hits, from);
}

}  // namespace alphorn
