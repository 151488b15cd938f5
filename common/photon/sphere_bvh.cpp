#include "common/photon/sphere_bvh.h"

#include "common/core/error.h"
#include "common/scene/accel.h"

#include <algorithm>
#include <bit>
#include <cstddef>

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

namespace {

// Does the segment o + t d, t in [tMin, tMax], meet the box? (Slab test; NaN from 0 * inf on a
// slab face compares false and leaves the interval unchanged.)
bool segmentMeetsBox(const Eigen::AlignedBox3f& box, const Point3f& origin,
                     const Vector3f& inverseDirection, float tMin, float tMax) {
    for (int axis = 0; axis < 3; ++axis) {
        float t0 = (box.min()[axis] - origin[axis]) * inverseDirection[axis];
        float t1 = (box.max()[axis] - origin[axis]) * inverseDirection[axis];
        if (t0 > t1) std::swap(t0, t1);
        if (t0 > tMin) tMin = t0;
        if (t1 < tMax) tMax = t1;
        if (tMin > tMax) return false;
    }
    return true;
}

}  // namespace

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
    m_nodes.reserve(2 * (count / m_leafSize + 1));
    build(0, count, boxes);
    m_leaf.resize(count);
    for (uint32_t k = 0; k < count; ++k) {
        const uint32_t i = m_order[k];
        m_leaf[k] = LeafSphere{m_centres[i], radius2(i), i};
    }
}

// Depth first, so the first child of an inner node is the next node. Splits at the median
// centre along the longest axis of the centres' box: nth_element is deterministic for equal
// input, and ties are broken by sphere index, so the tree is a pure function of the spheres.
uint32_t SphereBvh::build(uint32_t begin, uint32_t end, std::vector<Eigen::AlignedBox3f>& boxes) {
    const auto nodeIndex = static_cast<uint32_t>(m_nodes.size());
    m_nodes.emplace_back();
    Eigen::AlignedBox3f bounds, centreBounds;
    for (uint32_t i = begin; i < end; ++i) {
        bounds.extend(boxes[m_order[i]]);
        centreBounds.extend(m_centres[m_order[i]]);
    }
    m_nodes[nodeIndex].bounds = bounds;
    if (end - begin <= m_leafSize) {
        m_nodes[nodeIndex].first = begin;
        m_nodes[nodeIndex].count = end - begin;
        return nodeIndex;
    }
    int axis = 0;
    centreBounds.sizes().maxCoeff(&axis);
    const uint32_t middle = begin + (end - begin) / 2;
    std::nth_element(m_order.begin() + begin, m_order.begin() + middle, m_order.begin() + end,
                     [&](uint32_t a, uint32_t b) {
                         const float ca = m_centres[a][axis], cb = m_centres[b][axis];
                         return ca < cb || (ca == cb && a < b);
                     });
    build(begin, middle, boxes);
    const uint32_t second = build(middle, end, boxes);
    m_nodes[nodeIndex].first = second;
    m_nodes[nodeIndex].count = 0;
    return nodeIndex;
}

void SphereBvh::query(const Point3f& origin, const Vector3f& direction, float tMin, float tMax,
                      std::vector<SphereHit>& hits) const {
    if (m_nodes.empty() || !(tMin <= tMax)) return;
    const size_t from = hits.size();
    const Vector3f inverse = direction.cwiseInverse();
    uint32_t stack[64];
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
        const Node& node = m_nodes[stack[--top]];
        if (!segmentMeetsBox(node.bounds, origin, inverse, tMin, tMax)) continue;
        if (node.count > 0) {
            for (uint32_t k = node.first; k < node.first + node.count; ++k) {
                const LeafSphere& sphere = m_leaf[k];
                float t;
                if (segmentCrossesSphere(origin, direction, tMin, tMax, sphere.centre,
                                         sphere.radius2, t))
                    hits.push_back(SphereHit{sphere.index, t});
            }
            continue;
        }
        // A median split halves the spheres at every level: 64 levels cover any array.
        const auto self = static_cast<uint32_t>(&node - m_nodes.data());
        stack[top++] = node.first;
        stack[top++] = self + 1;
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
    rtcIntersect1(m_scene, &query.context, &rayhit);
    // Embree's traversal order is its own: sort, so the answer is the BVH's to the byte.
    sortByDistance(hits, from);
}

}  // namespace alphorn
