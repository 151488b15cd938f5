// Embree's BVHs must not limit the threads of the process that builds them: once a scene is
// loaded (its Accel built) and an Embree sphere index built, a render limited to N threads by a
// tbb::global_control (what `--threads N` sets) must still have N threads, and a render without a
// limit must have all cores.
#include "common/scene/accel.h"

#include "common/photon/sphere_bvh.h"
#include "common/scene/accel_counters.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <limits>
#include <random>
#include <thread>

namespace alphorn {
namespace {

// Builds both kinds of Embree BVH the renderer makes and keeps them alive, as a render does.
struct LoadedScene {
    std::shared_ptr<Scene> scene = loadScene(sourcePath("scenes/cbox/cbox.xml"));
    EmbreeSphereIndex spheres{{Point3f(0.0f, 0.0f, 0.0f), Point3f(1.0f, 0.0f, 0.0f)}, {0.5f}};
};

size_t allowedParallelism() {
    return tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
}

// True when `count` tasks of one parallel_for run at the same time in `arena`: each waits for
// all to arrive. With fewer threads than tasks the first one waits in vain; the deadline only
// ends that wait (a minute, far beyond any thread start-up), it measures nothing.
bool tasksRunTogether(tbb::task_arena& arena, int count) {
    std::atomic<int> arrived{0};
    std::atomic<bool> allMet{true};
    arena.execute([&] {
        tbb::parallel_for(
            tbb::blocked_range<int>(0, count, 1),
            [&](const tbb::blocked_range<int>&) {
                ++arrived;
                const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(1);
                while (arrived.load() < count) {
                    if (std::chrono::steady_clock::now() > deadline) {
                        allMet = false;
                        return;
                    }
                    std::this_thread::yield();
                }
            },
            tbb::simple_partitioner());
    });
    return allMet;
}

TEST(AccelThreads, ALoadedSceneKeepsTheThreadLimitOfTheRender) {
    tbb::global_control renderThreads(tbb::global_control::max_allowed_parallelism, 2);
    LoadedScene loaded;
    EXPECT_EQ(allowedParallelism(), 2u);
    tbb::task_arena renderArena(2);
    EXPECT_EQ(renderArena.max_concurrency(), 2);
    EXPECT_TRUE(tasksRunTogether(renderArena, 2)) << "the render ran on fewer than 2 threads";
}

TEST(AccelThreads, ALoadedSceneLeavesAllCoresToARenderWithoutALimit) {
    LoadedScene loaded;
    EXPECT_EQ(allowedParallelism(), size_t(tbb::info::default_concurrency()));
    EXPECT_EQ(tbb::this_task_arena::max_concurrency(), tbb::info::default_concurrency());
}

// The throughput benchmark splits the renderer's rays by kind: shadow rays are counted apart,
// and among all rays, closest hits are not counted as shadow rays.
TEST(AccelRayCounts, ShadowRaysAreCountedApartFromClosestHits) {
    const LoadedScene loaded;
    const Accel& accel = loaded.scene->accel();
    const Ray3f ray(Point3f(0.0f, 0.9f, 0.0f), Vector3f(0.0f, -1.0f, 0.0f));
    const uint64_t raysBefore = raysTracedByThisThread();
    const uint64_t shadowBefore = shadowRaysTracedByThisThread();
    Intersection its;
    accel.intersect(ray, its);
    accel.intersect(ray, its);
    accel.occluded(ray);
    EXPECT_EQ(raysTracedByThisThread() - raysBefore, 3u);
    EXPECT_EQ(shadowRaysTracedByThisThread() - shadowBefore, 1u);
}

// A ray Embree would abort on (NaN or beyond its range) is a miss and carries no light, instead of
// taking the process down.
TEST(AccelRays, RaysEmbreeCannotTraceMissAndAreOccluded) {
    const LoadedScene loaded;
    const Accel& accel = loaded.scene->accel();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    for (const Ray3f& ray : {Ray3f(Point3f(nan, 1.0f, 0.0f), Vector3f(0.0f, -1.0f, 0.0f)),
                             Ray3f(Point3f(0.0f, 1.0f, 0.0f), Vector3f(nan, -1.0f, 0.0f)),
                             Ray3f(Point3f(1e30f, 1.0f, 0.0f), Vector3f(-1.0f, 0.0f, 0.0f))}) {
        Intersection its;
        EXPECT_FALSE(accel.intersect(ray, its));
        EXPECT_TRUE(accel.occluded(ray));
    }
    Intersection its;
    EXPECT_TRUE(accel.intersect(Ray3f(Point3f(0.0f, 1.0f, 0.0f), Vector3f(0.0f, -1.0f, 0.0f)), its))
        << "an ordinary ray towards the floor";
}

// Every hit of a fixed set of rays through the Cornell box's meshes (two spheres of 18k triangles
// and the walls), as Embree reports it on a BVH built on `device`: the bits of the distance and
// barycentrics, the triangle and the mesh.
std::vector<std::array<uint32_t, 5>> traceCornellBox(RTCDevice device) {
    EXPECT_NE(device, nullptr) << "Embree could not create the device";
    if (!device) return {};
    const LoadedScene loaded;
    RTCScene scene = rtcNewScene(device);
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_HIGH);
    for (const auto& mesh : loaded.scene->meshes()) attachTriangles(device, scene, *mesh);
    commitEmbreeScene(scene);
    std::mt19937 random(17);
    std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
    std::vector<std::array<uint32_t, 5>> hits;
    for (int i = 0; i < 20000; ++i) {
        RTCIntersectContext context;
        rtcInitIntersectContext(&context);
        RTCRayHit rayHit{};
        rayHit.ray.org_x = 0.9f * uniform(random);
        rayHit.ray.org_y = 1.0f + 0.9f * uniform(random);
        rayHit.ray.org_z = 0.9f * uniform(random);
        rayHit.ray.dir_x = uniform(random);
        rayHit.ray.dir_y = uniform(random);
        rayHit.ray.dir_z = uniform(random);
        rayHit.ray.tfar = Infinity;
        rayHit.ray.mask = 0xffffffffu;
        rayHit.hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &context, &rayHit);
        std::array<uint32_t, 5> hit{};
        std::memcpy(&hit[0], &rayHit.ray.tfar, 4);
        std::memcpy(&hit[1], &rayHit.hit.u, 4);
        std::memcpy(&hit[2], &rayHit.hit.v, 4);
        hit[3] = rayHit.hit.primID;
        hit[4] = rayHit.hit.geomID;
        hits.push_back(hit);
    }
    rtcReleaseScene(scene);
    rtcReleaseDevice(device);
    return hits;
}

size_t differingHits(const std::vector<std::array<uint32_t, 5>>& a,
                     const std::vector<std::array<uint32_t, 5>>& b) {
    EXPECT_EQ(a.size(), b.size());
    size_t differing = 0;
    for (size_t i = 0; i < std::min(a.size(), b.size()); ++i) differing += a[i] != b[i];
    return differing;
}

// The renderer's device traces what a CPU with AVX2 and nothing newer traces (Embree's
// "isa=avx2" forces those kernels), bit for bit, whatever this CPU has beyond AVX2.
TEST(EmbreeKernels, EveryCpuOfThePlatformTracesTheSameBits) {
    if (renderPlatform() != "x86-64 avx2") GTEST_SKIP() << "this CPU has no AVX2 kernels";
    const auto ours = traceCornellBox(newEmbreeDevice());
    const auto avx2Only = traceCornellBox(rtcNewDevice("isa=avx2"));
    ASSERT_EQ(ours.size(), 20000u);
    EXPECT_EQ(differingHits(ours, avx2Only), 0u);
}

// Why the cap is needed: on a CPU with AVX-512, Embree's own choice (its AVX-512 kernels)
// reports other bits for some of the same rays.
TEST(EmbreeKernels, AvxFiveTwelveKernelsWouldTraceOtherBits) {
    __builtin_cpu_init();
    if (!(__builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
          __builtin_cpu_supports("avx512cd") && __builtin_cpu_supports("avx512bw") &&
          __builtin_cpu_supports("avx512vl")))
        GTEST_SKIP() << "this CPU has no AVX-512 kernels";
    const auto ours = traceCornellBox(newEmbreeDevice());
    const auto avx512 = traceCornellBox(rtcNewDevice("isa=avx512"));
    EXPECT_GT(differingHits(ours, avx512), 0u);
}

}  // namespace
}  // namespace alphorn
