#include "common/scene/accel.h"
#include "common/scene/accel_counters.h"

#include "common/core/error.h"

#include <tbb/task_arena.h>

#include <atomic>
#include <map>

namespace alphorn {

static thread_local uint64_t t_rayCount = 0;
static thread_local uint64_t t_shadowRayCount = 0;

uint64_t raysTracedByThisThread() {
    return t_rayCount;
}

uint64_t shadowRaysTracedByThisThread() {
    return t_shadowRayCount;
}

RTCDevice newEmbreeDevice() {
    RTCDevice device = rtcNewDevice(kEmbreeDeviceConfig);
    if (!device) fail("Embree could not create a device (error %d)", rtcGetDeviceError(nullptr));
    return device;
}

std::string renderPlatform() {
#if defined(__x86_64__)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
        __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2"))
        return "x86-64 avx2";
    if (__builtin_cpu_supports("avx")) return "x86-64 avx";
    if (__builtin_cpu_supports("sse4.2") && __builtin_cpu_supports("popcnt"))
        return "x86-64 sse4.2";
    return "x86-64 sse2";
#elif defined(__aarch64__)
    return "aarch64";
#else
    return "unknown";
#endif
}

void commitEmbreeScene(RTCScene scene) {
    tbb::task_arena oneThread(1);
    oneThread.execute([&] { rtcCommitScene(scene); });
}

Accel::~Accel() {
    release();
}

void Accel::release() {
    for (GroupScene& group : m_groups)
        if (group.scene) rtcReleaseScene(group.scene);
    m_groups.clear();
    m_instances.clear();
    if (m_scene) rtcReleaseScene(m_scene);
    if (m_device) rtcReleaseDevice(m_device);
    m_scene = nullptr;
    m_device = nullptr;
}

unsigned attachTriangles(RTCDevice device, RTCScene scene, const Mesh& mesh) {
    RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
    float* vertices = static_cast<float*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                3 * sizeof(float), mesh.vertexCount()));
    std::copy_n(mesh.positions().data(), 3 * mesh.vertexCount(), vertices);
    uint32_t* indices = static_cast<uint32_t*>(
        rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(uint32_t), mesh.triangleCount()));
    std::copy_n(mesh.faces().data(), 3 * mesh.triangleCount(), indices);
    rtcCommitGeometry(geometry);
    const unsigned id = rtcAttachGeometry(scene, geometry);
    rtcReleaseGeometry(geometry);
    return id;
}

namespace {
std::atomic<uint64_t> g_embreeScenesBuilt{0};
}  // namespace

uint64_t embreeScenesBuilt() {
    return g_embreeScenesBuilt.load();
}

void Accel::boundMeshes(const std::vector<std::shared_ptr<Mesh>>& meshes,
                        const std::vector<Instance>& instances) {
    release();
    m_meshes.clear();
    m_bounds.setEmpty();
    // The meshes and instances build() attaches, in its order, so that the bounds are the same
    // floats.
    for (const auto& mesh : meshes)
        if (mesh->triangleCount() != 0) m_bounds.extend(mesh->bounds());
    for (const Instance& instance : instances)
        if (instance.group().triangleCount() != 0) m_bounds.extend(instance.worldBounds());
}

void Accel::build(const std::vector<std::shared_ptr<Mesh>>& meshes,
                  const std::vector<Instance>& instances) {
    ++g_embreeScenesBuilt;
    release();
    m_device = newEmbreeDevice();
    m_scene = rtcNewScene(m_device);
    rtcSetSceneBuildQuality(m_scene, RTC_BUILD_QUALITY_HIGH);
    m_meshes.clear();
    m_bounds.setEmpty();
    for (const auto& mesh : meshes) {
        if (mesh->triangleCount() == 0) continue;
        const unsigned id = attachTriangles(m_device, m_scene, *mesh);
        if (id != m_meshes.size()) fail("Embree assigned an unexpected geometry id");
        m_meshes.push_back(mesh.get());
        m_bounds.extend(mesh->bounds());
    }
    // Each group's BVH, in the order of the first instance that places it (the map only finds
    // them), committed as the scene's own: one thread, so it is the same on every machine.
    std::map<const MeshGroup*, size_t> groupIndex;
    for (const Instance& instance : instances) {
        const MeshGroup& group = instance.group();
        if (group.triangleCount() == 0 || groupIndex.count(&group)) continue;
        groupIndex.emplace(&group, m_groups.size());
        ++g_embreeScenesBuilt;
        GroupScene& built = m_groups.emplace_back();  // released with the Accel from here on
        built.scene = rtcNewScene(m_device);
        rtcSetSceneBuildQuality(built.scene, RTC_BUILD_QUALITY_HIGH);
        for (const auto& mesh : group.meshes()) {
            if (mesh->triangleCount() == 0) continue;
            const unsigned id = attachTriangles(m_device, built.scene, *mesh);
            if (id != built.meshes.size()) fail("Embree assigned an unexpected geometry id");
            built.meshes.push_back(mesh.get());
        }
        commitEmbreeScene(built.scene);
    }
    m_instances.reserve(groupIndex.empty() ? 0 : instances.size());
    for (const Instance& instance : instances) {
        const auto found = groupIndex.find(&instance.group());
        if (found == groupIndex.end()) continue;
        const GroupScene& group = m_groups[found->second];
        RTCGeometry geometry = rtcNewGeometry(m_device, RTC_GEOMETRY_TYPE_INSTANCE);
        rtcSetGeometryInstancedScene(geometry, group.scene);
        // Embree's 3x4 layout, column by column: the linear part's columns, then the translation.
        const Matrix4f& m = instance.toWorld().matrix();
        float columns[12];
        for (int column = 0; column < 4; ++column)
            for (int row = 0; row < 3; ++row) columns[3 * column + row] = m(row, column);
        rtcSetGeometryTransform(geometry, 0, RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR, columns);
        rtcCommitGeometry(geometry);
        const unsigned id = rtcAttachGeometry(m_scene, geometry);
        rtcReleaseGeometry(geometry);
        if (id != m_meshes.size() + m_instances.size())
            fail("Embree assigned an unexpected geometry id");
        m_instances.push_back({&instance, &group.meshes});
        m_bounds.extend(instance.worldBounds());
    }
    commitEmbreeScene(m_scene);
    RTCError error = rtcGetDeviceError(m_device);
    if (error != RTC_ERROR_NONE) fail("Embree failed to build the scene BVH (error %d)", error);
}

static RTCRay toEmbree(const Ray3f& ray) {
    RTCRay r;
    r.org_x = ray.o.x();
    r.org_y = ray.o.y();
    r.org_z = ray.o.z();
    r.dir_x = ray.d.x();
    r.dir_y = ray.d.y();
    r.dir_z = ray.d.z();
    r.tnear = ray.mint;
    r.tfar = ray.maxt;
    r.time = 0.0f;
    r.mask = 0xffffffffu;
    r.id = 0;
    r.flags = 0;
    return r;
}

bool Accel::intersect(const Ray3f& ray, Intersection& its) const {
    ++t_rayCount;
    if (m_meshes.empty() && m_instances.empty()) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRayHit rayhit;
    rayhit.ray = toEmbree(ray);
    rayhit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rayhit.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    if (!embreeAcceptsRay(rayhit.ray)) return false;
    rtcIntersect1(m_scene, &context, &rayhit);
    if (rayhit.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
    its.t = rayhit.ray.tfar;
    // Embree leaves the ray's direction unscaled in object space, so t is the world distance
    // parameter for instance hits too.
    if (rayhit.hit.instID[0] == RTC_INVALID_GEOMETRY_ID) {
        m_meshes[rayhit.hit.geomID]->fillIntersection(rayhit.hit.primID, rayhit.hit.u, rayhit.hit.v,
                                                      its);
    } else {
        const InstanceHit& hit = m_instances[rayhit.hit.instID[0] - m_meshes.size()];
        (*hit.meshes)[rayhit.hit.geomID]->fillIntersection(rayhit.hit.primID, rayhit.hit.u,
                                                           rayhit.hit.v, *hit.instance, its);
    }
    return true;
}

bool Accel::occluded(const Ray3f& ray) const {
    ++t_rayCount;
    ++t_shadowRayCount;
    if (m_meshes.empty() && m_instances.empty()) return false;
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    RTCRay r = toEmbree(ray);
    // A ray Embree cannot trace carries no light.
    if (!embreeAcceptsRay(r)) return true;
    rtcOccluded1(m_scene, &context, &r);
    // Embree marks an occluded ray by setting tfar to -inf.
    return r.tfar < 0.0f;
}

}  // namespace alphorn
