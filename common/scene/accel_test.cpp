// Embree's BVHs must not limit the threads of the process that builds them: once a scene is
// loaded (its Accel built) and an Embree sphere index built, a render limited to N threads by a
// tbb::global_control (what `--threads N` sets) must still have N threads, and a render without a
// limit must have all cores.
#include "common/scene/accel.h"

#include "common/photon/sphere_bvh.h"
#include "common/scene/accel_counters.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <gtest/gtest.h>
#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>
#include <tbb/partitioner.h>
#include <tbb/task_arena.h>

#include <atomic>
#include <chrono>
#include <thread>

namespace alphorn {
namespace {

// Builds both kinds of Embree BVH the renderer makes and keeps them alive, as a render does.
struct LoadedScene {
    std::shared_ptr<Scene> scene = loadScene(ALPHORN_SOURCE_DIR "/scenes/cbox/cbox.xml");
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

}  // namespace
}  // namespace alphorn
