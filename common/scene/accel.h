// Ray intersection through Embree: one BVH over all meshes of a scene, and the instances of
// mesh groups (common/scene/instance.h), each an Embree instance of its group's own BVH.
#pragma once

#include "common/core/ray.h"
#include "common/scene/instance.h"
#include "common/scene/mesh.h"

#include <embree3/rtcore.h>

namespace alphorn {

class Accel {
  public:
    Accel() = default;
    Accel(const Accel&) = delete;
    Accel& operator=(const Accel&) = delete;
    ~Accel();

    // The top-level BVH holds the meshes (world space) and one Embree instance per element of
    // `instances`; every group they place gets one BVH of its own, built once however many
    // instances place it. Hits record the instance by address: `instances` must outlive the
    // Accel and not move.
    void build(const std::vector<std::shared_ptr<Mesh>>& meshes,
               const std::vector<Instance>& instances = {});
    // Only the bounds build() gives, without Embree: nothing can be traced.
    void boundMeshes(const std::vector<std::shared_ptr<Mesh>>& meshes,
                     const std::vector<Instance>& instances = {});
    bool intersect(const Ray3f& ray, Intersection& its) const;
    bool occluded(const Ray3f& ray) const;
    const Eigen::AlignedBox3f& bounds() const { return m_bounds; }
    // The Embree scene itself, for benchmarks that measure raw Embree throughput.
    RTCScene embreeScene() const { return m_scene; }

  private:
    void release();

    // A group's BVH and its meshes, indexed by their Embree geometry id in it.
    struct GroupScene {
        RTCScene scene = nullptr;
        std::vector<const Mesh*> meshes;
    };
    // What a hit on an instance needs: the instance and its group's meshes.
    struct InstanceHit {
        const Instance* instance;
        const std::vector<const Mesh*>* meshes;
    };

    RTCDevice m_device = nullptr;
    RTCScene m_scene = nullptr;
    std::vector<const Mesh*> m_meshes;  // indexed by Embree geometry id
    // Indexed by Embree geometry id minus m_meshes.size(): the instances follow the meshes.
    std::vector<InstanceHit> m_instances;
    std::vector<GroupScene> m_groups;
    Eigen::AlignedBox3f m_bounds;
};

// Embree scenes (BVHs) that Accel::build made in this process, for tests of what builds them:
// one for the scene and one for each group its instances place.
uint64_t embreeScenesBuilt();

// Rays traced by the calling thread since it started; summed by the renderer for Mrays/s.
uint64_t raysTracedByThisThread();

// An Embree device that leaves the number of threads to oneTBB, i.e. to the caller's
// tbb::global_control or task arena. Embree's "threads=N" setting is not local to its device:
// Embree (built on oneTBB) applies it to the whole process as a tbb::global_control while the
// device lives, so a "threads=1" device makes every render in the process single-threaded.
//
// Its kernels are capped at AVX2 (kEmbreeDeviceConfig). Embree picks its kernels by the CPU it runs
// on, and kernels of two instruction sets round a hit's distance and barycentrics differently
// and build BVHs of another width; capped, a CPU with AVX-512 traces the same bits as one with
// AVX2 alone, so a farm mixing the two renders the image `alphorn render` gives on either.
RTCDevice newEmbreeDevice();
inline constexpr const char* kEmbreeDeviceConfig = "max_isa=avx2";

// Whether Embree accepts the ray: it aborts the process (an assertion left on in Debian's build)
// on a ray whose origin or direction has a component that is NaN or beyond 1.844e18, or whose
// tnear or tfar is NaN. The scene's parameters are bounded so that none arises; this keeps a ray
// that slips through (a NaN from a degenerate sample) from taking the process down with it.
inline bool embreeAcceptsRay(const RTCRay& ray) {
    constexpr float kLarge = 1.844e18f;  // Embree's FLT_LARGE
    return std::abs(ray.org_x) <= kLarge && std::abs(ray.org_y) <= kLarge &&
           std::abs(ray.org_z) <= kLarge && std::abs(ray.dir_x) <= kLarge &&
           std::abs(ray.dir_y) <= kLarge && std::abs(ray.dir_z) <= kLarge &&
           ray.tnear == ray.tnear && ray.tfar == ray.tfar;
}

// The class of CPU a render's bytes depend on: its architecture and the instruction set of the
// Embree kernels it gets under kEmbreeDeviceConfig ("x86-64 avx2", "x86-64 avx", "x86-64 sse4.2",
// "x86-64 sse2"; other architectures by name). One build renders the same bytes on every CPU of
// one platform; the coordinator refuses workers of another platform than its own. Embree's
// choice is mirrored from the CPU's feature flags (its AVX2 kernels need AVX2, FMA, BMI1 and
// BMI2); the glibc maths functions' FMA variants follow the same flags.
std::string renderPlatform();

// Attaches `mesh`'s triangles to `scene` as one geometry made on `device`; returns its id.
unsigned attachTriangles(RTCDevice device, RTCScene scene, const Mesh& mesh);

// rtcCommitScene run by the calling thread alone, inside a task arena of one thread. Embree builds
// in the caller's arena, and its parallel partitioning cuts the primitives into as many ranges as
// the arena has threads: the order of primitives within leaves, hence which of two equally near
// hits a ray reports, would depend on the core count. With one thread the BVH is a pure function
// of the geometry on every machine.
void commitEmbreeScene(RTCScene scene);

}  // namespace alphorn
