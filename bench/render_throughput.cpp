// Renderer throughput against raw Embree on the same scene and the same kind of rays.
//
// The renderer renders the scene with its integrator (path_mis for the Cornell box) and counts
// every ray it traces (closest-hit and shadow). The baseline traces, with rtcIntersect1 alone,
// one camera ray per pixel and pass followed by cosine-distributed bounce rays from each hit,
// as many rays per camera sample as the renderer traced on average (bounce rays that leave the
// scene end a path early, so the bounce budget is calibrated until the counts match). Both run on
// all cores in the same process, alternating, and the ratio of rays per second is printed: the
// cost of shading, sampling, filtering and accumulation on top of ray traversal.
//
// That baseline flatters the renderer: a third of the renderer's rays on the Cornell box are
// shadow rays, traced with rtcOccluded1, which stops at the first hit it finds and fills no hit
// record, while every baseline ray is a closest hit. A second baseline traces the renderer's
// mix: as many closest hits per sample as its intersect() calls and, from their hits, as many
// rtcOccluded1 rays towards points on the emitters as its shadow rays (the split is counted in
// a one-pass render on one thread first). Both ratios are printed; the first is the one the
// earlier results in bench/RESULTS.md used.
//
// The ratio is also given per CPU second (the process's CPU time over each half): on a machine
// shared with other work the process may get fewer cores in one half than in the other, which
// moves the wall-time ratio but not this one. Both are printed; their difference shows the load.
//
// usage: bench_render_throughput [SCENE.xml] [passes] [rounds]
#include "bench/embree_ray.h"
#include "bench/timing.h"
#include "common/core/frame.h"
#include "common/core/rng.h"
#include "common/core/warp.h"
#include "common/render/local_render.h"
#include "common/scene/accel_counters.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/blocked_range.h>
#include <tbb/global_control.h>
#include <tbb/parallel_reduce.h>

#include <chrono>
#include <cstdio>
#include <string>

using namespace alphorn;
using bench::makeRayHit;
using bench::median;
using bench::processCpuSeconds;
using bench::seconds;

namespace {

// Rays per camera sample the renderer traces, by kind.
struct RayMix {
    double closestHits = 0.0;
    double shadowRays = 0.0;
};

// The renderer's split of its rays into closest hits and shadow rays, counted in a one-pass render
// on the calling thread alone (the counters are per thread).
RayMix measureRayMix(const Scene& scene) {
    tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
    const uint64_t raysBefore = raysTracedByThisThread();
    const uint64_t shadowBefore = shadowRaysTracedByThisThread();
    RenderSettings settings;
    settings.passes = 1;
    settings.seed = 1000;
    renderLocal(scene, settings, {});
    const double rays = double(raysTracedByThisThread() - raysBefore);
    const double shadowRays = double(shadowRaysTracedByThisThread() - shadowBefore);
    if (rays == 0.0) throw std::runtime_error("the one-thread render traced no ray on this thread");
    const Vector2i size = scene.camera()->outputSize();
    const double samples = double(size.x()) * size.y();
    return {(rays - shadowRays) / samples, shadowRays / samples};
}

// Points on the scene's emitters (a delta light's is its position), the targets of the baseline's
// shadow rays; sampled before timing so that the baseline pays only for the rays.
std::vector<Point3f> emitterPoints(const Scene& scene) {
    std::vector<Point3f> points;
    Rng rng(2, 0, 0, StreamPurpose::Test);
    const Point3f centre = scene.accel().bounds().center();
    for (const auto& emitter : scene.emitters()) {
        for (int i = 0; i < 256; ++i) {
            EmitterQueryRecord rec(centre);
            emitter->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
            points.push_back(rec.p);
        }
    }
    return points;
}

struct RawRays {
    uint64_t closestHits = 0;  // rtcIntersect1 calls
    uint64_t hits = 0;         // of those, the ones that hit something
    uint64_t shadowRays = 0;   // rtcOccluded1 calls
    uint64_t total() const { return closestHits + shadowRays; }
};

// How the baseline walks: bounce rays per camera ray (fractions met on average) and the
// probability of a shadow ray from each hit.
struct Walk {
    double bounces = 0.0;
    double shadowPerHit = 0.0;
};

// Traces camera rays and cosine bounces with raw rtcIntersect1 as `walk` says, and from each hit,
// with probability walk.shadowPerHit, an rtcOccluded1 ray to one of `targets`.
RawRays traceRawEmbree(const Scene& scene, uint32_t passes, const Walk& walk,
                       const std::vector<Point3f>& targets) {
    const Camera& camera = *scene.camera();
    const int width = camera.outputSize().x(), height = camera.outputSize().y();
    RTCScene embree = scene.accel().embreeScene();
    const bool shadows = walk.shadowPerHit > 0.0 && !targets.empty();
    return tbb::parallel_reduce(
        tbb::blocked_range<int>(0, height * int(passes)), RawRays{},
        [&](const tbb::blocked_range<int>& rows, RawRays count) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            for (int item = rows.begin(); item != rows.end(); ++item) {
                const int y = item % height, pass = item / height;
                for (int x = 0; x < width; ++x) {
                    Rng rng(1, pass, uint64_t(y) * width + x, StreamPurpose::Test);
                    Ray3f ray;
                    Point2f pixel(x + rng.nextFloat(), y + rng.nextFloat());
                    camera.sampleRay(ray, pixel, Point2f(0.5f, 0.5f));
                    const double budget = walk.bounces + rng.nextFloat();
                    Point3f o = ray.o;
                    Vector3f d = ray.d;
                    for (int depth = 0;; ++depth) {
                        RTCRayHit rh = makeRayHit(o, d);
                        rtcIntersect1(embree, &context, &rh);
                        ++count.closestHits;
                        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) break;
                        ++count.hits;
                        o = o + rh.ray.tfar * d;
                        if (shadows && rng.nextFloat() < walk.shadowPerHit) {
                            const Point3f& target = targets[std::min(
                                targets.size() - 1, size_t(rng.nextFloat() * targets.size()))];
                            const Vector3f toTarget = target - o;
                            const float distance = toTarget.norm();
                            // None from a hit at the target itself (nor does a light sample at
                            // the shading point give one).
                            if (distance > 2.0f * Epsilon) {
                                RTCRay shadow = makeRayHit(o, toTarget / distance).ray;
                                shadow.tfar = distance - Epsilon;
                                rtcOccluded1(embree, &context, &shadow);
                                ++count.shadowRays;
                            }
                        }
                        if (depth + 1 > budget) break;
                        Vector3f n(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
                        n.normalize();
                        if (n.dot(d) > 0.0f) n = -n;
                        Point2f u(rng.nextFloat(), rng.nextFloat());
                        d = Frame(n).toWorld(warp::squareToCosineHemisphere(u));
                    }
                }
            }
            return count;
        },
        [](RawRays a, const RawRays& b) {
            a.closestHits += b.closestHits;
            a.hits += b.hits;
            a.shadowRays += b.shadowRays;
            return a;
        });
}

// The walk whose rays per sample match `target`: bounce rays that leave the scene end a path
// early, so the bounce budget is raised until the closest hits per sample match (secant steps of
// one-pass runs; in an open scene the printed counts show how near it came), and the shadow-ray
// probability is the target's shadow rays over the hits.
Walk calibrateWalk(const Scene& scene, const RayMix& target, const std::vector<Point3f>& targets) {
    const Vector2i size = scene.camera()->outputSize();
    const double samples = double(size.x()) * size.y();
    Walk walk{std::max(0.0, target.closestHits - 1.0), 0.0};
    double previousBounces = 0.0, previousClosestHits = 0.0;
    for (int iteration = 0; iteration < 12; ++iteration) {
        const RawRays rays = traceRawEmbree(scene, 1, walk, {});
        const double closestHits = rays.closestHits / samples;
        if (rays.hits > 0 && !targets.empty())
            walk.shadowPerHit = std::min(1.0, target.shadowRays / (rays.hits / samples));
        if (std::abs(closestHits - target.closestHits) < 0.005 * target.closestHits) break;
        // Rays added per unit of budget: at most one, fewer the more paths leave the scene.
        double slope = 1.0;
        if (iteration > 0 && walk.bounces != previousBounces)
            slope = (closestHits - previousClosestHits) / (walk.bounces - previousBounces);
        slope = std::clamp(slope, 0.02, 1.0);
        previousBounces = walk.bounces;
        previousClosestHits = closestHits;
        walk.bounces =
            std::clamp(walk.bounces + (target.closestHits - closestHits) / slope, 0.0, 1000.0);
    }
    return walk;
}

// One timed run: rays per wall second and per CPU second.
struct Rate {
    double wall = 0.0, cpu = 0.0, cpuOverWall = 0.0;
};

template <typename Run>
Rate timed(Run&& run) {
    const auto start = std::chrono::steady_clock::now();
    const double cpuStart = processCpuSeconds();
    const double rays = double(run());
    const double wallSeconds = seconds(start);
    const double cpuSeconds = processCpuSeconds() - cpuStart;
    return {rays / wallSeconds, rays / cpuSeconds, cpuSeconds / wallSeconds};
}

}  // namespace

int main(int argc, char** argv) {
    std::string scenePath = argc > 1 ? argv[1] : sourcePath("scenes/cbox/cbox.xml");
    uint32_t passes = argc > 2 ? std::stoul(argv[2]) : 8;
    int rounds = argc > 3 ? std::stoi(argv[3]) : 3;
    try {
        std::shared_ptr<Scene> scene = loadScene(scenePath);
        const Vector2i size = scene->camera()->outputSize();
        const double samples = double(passes) * size.x() * size.y();
        std::printf("scene %s: %dx%d, %u passes, %d rounds\n", scenePath.c_str(), size.x(),
                    size.y(), passes, rounds);
        const RayMix mix = measureRayMix(*scene);
        const std::vector<Point3f> targets = emitterPoints(*scene);
        // The first baseline traces closest hits only, as many as the renderer's rays of both
        // kinds; the second the renderer's mix.
        const Walk closestOnly = calibrateWalk(*scene, {mix.closestHits + mix.shadowRays, 0.0}, {});
        const Walk mixedWalk = calibrateWalk(*scene, mix, targets);
        std::printf(
            "renderer's rays per sample (one pass, one thread): %.2f closest hits, %.2f "
            "shadow rays\n",
            mix.closestHits, mix.shadowRays);
        std::vector<double> ratios, cpuRatios, mixedRatios, mixedCpuRatios;
        for (int round = 0; round < rounds; ++round) {
            RenderSettings settings;
            settings.passes = passes;
            settings.seed = round;
            RenderCounters counters;
            const Rate render = timed([&] {
                renderLocal(*scene, settings, {}, &counters);
                return counters.rays.load();
            });
            const double raysPerSample = counters.rays / samples;
            RawRays closest, mixed;
            const Rate raw = timed([&] {
                closest = traceRawEmbree(*scene, passes, closestOnly, {});
                return closest.total();
            });
            const Rate rawMixed = timed([&] {
                mixed = traceRawEmbree(*scene, passes, mixedWalk, targets);
                return mixed.total();
            });
            ratios.push_back(render.wall / raw.wall);
            cpuRatios.push_back(render.cpu / raw.cpu);
            mixedRatios.push_back(render.wall / rawMixed.wall);
            mixedCpuRatios.push_back(render.cpu / rawMixed.cpu);
            std::printf(
                "round %d: renderer %.2f Mrays/s (%.2f rays/sample, CPU/wall %.2f); "
                "raw rtcIntersect1 %.2f Mrays/s (%.2f rays/sample, CPU/wall %.2f), "
                "ratio %.3f, per CPU second %.3f; raw mix %.2f Mrays/s (%.2f + %.2f "
                "rays/sample, CPU/wall %.2f), ratio %.3f, per CPU second %.3f\n",
                round, render.wall * 1e-6, raysPerSample, render.cpuOverWall, raw.wall * 1e-6,
                closest.total() / samples, raw.cpuOverWall, ratios.back(), cpuRatios.back(),
                rawMixed.wall * 1e-6, mixed.closestHits / samples, mixed.shadowRays / samples,
                rawMixed.cpuOverWall, mixedRatios.back(), mixedCpuRatios.back());
        }
        std::printf("median ratio renderer / raw Embree: %.3f (goal >= 0.7); per CPU second %.3f\n",
                    median(ratios), median(cpuRatios));
        std::printf(
            "median ratio renderer / raw Embree with the renderer's mix of shadow rays: "
            "%.3f; per CPU second %.3f\n",
            median(mixedRatios), median(mixedCpuRatios));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
