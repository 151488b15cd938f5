// Renderer throughput against raw Embree on the same scene and the same kind of rays.
//
// The renderer renders the scene with its integrator (path_mis for the Cornell box) and counts
// every ray it traces (closest-hit and shadow). The baseline traces, with rtcIntersect1 alone,
// one camera ray per pixel and pass followed by cosine-distributed bounce rays from each hit,
// as many rays per camera sample as the renderer traced on average. Both run on all cores in the
// same process, alternating, and the ratio of rays per second is printed: the cost of shading,
// sampling, filtering and accumulation on top of ray traversal.
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
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <tbb/blocked_range.h>
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

// Traces camera rays and cosine bounces with raw rtcIntersect1; returns the number of rays.
uint64_t traceRawEmbree(const Scene& scene, uint32_t passes, double raysPerSample) {
    const Camera& camera = *scene.camera();
    const int width = camera.outputSize().x(), height = camera.outputSize().y();
    RTCScene embree = scene.accel().embreeScene();
    // Bounces per camera ray so that the total ray count matches the renderer's.
    const double bounces = std::max(0.0, raysPerSample - 1.0);
    return tbb::parallel_reduce(
        tbb::blocked_range<int>(0, height * int(passes)), uint64_t(0),
        [&](const tbb::blocked_range<int>& rows, uint64_t count) {
            RTCIntersectContext context;
            rtcInitIntersectContext(&context);
            for (int item = rows.begin(); item != rows.end(); ++item) {
                const int y = item % height, pass = item / height;
                for (int x = 0; x < width; ++x) {
                    Rng rng(1, pass, uint64_t(y) * width + x, StreamPurpose::Test);
                    Ray3f ray;
                    Point2f pixel(x + rng.nextFloat(), y + rng.nextFloat());
                    camera.sampleRay(ray, pixel, Point2f(0.5f, 0.5f));
                    // Fractional bounce counts are met on average.
                    double budget = bounces + rng.nextFloat();
                    Point3f o = ray.o;
                    Vector3f d = ray.d;
                    for (int depth = 0;; ++depth) {
                        RTCRayHit rh = makeRayHit(o, d);
                        rtcIntersect1(embree, &context, &rh);
                        ++count;
                        if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID || depth + 1 > budget) break;
                        Vector3f n(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z);
                        n.normalize();
                        if (n.dot(d) > 0.0f) n = -n;
                        o = o + rh.ray.tfar * d;
                        Point2f u(rng.nextFloat(), rng.nextFloat());
                        d = Frame(n).toWorld(warp::squareToCosineHemisphere(u));
                    }
                }
            }
            return count;
        },
        std::plus<uint64_t>());
}

}  // namespace

int main(int argc, char** argv) {
    std::string scenePath = argc > 1 ? argv[1] : ALPHORN_SOURCE_DIR "/scenes/cbox/cbox.xml";
    uint32_t passes = argc > 2 ? std::stoul(argv[2]) : 8;
    int rounds = argc > 3 ? std::stoi(argv[3]) : 3;
    try {
        std::shared_ptr<Scene> scene = loadScene(scenePath);
        const Vector2i size = scene->camera()->outputSize();
        const double samples = double(passes) * size.x() * size.y();
        std::printf("scene %s: %dx%d, %u passes, %d rounds\n", scenePath.c_str(), size.x(),
                    size.y(), passes, rounds);
        std::vector<double> ratios, cpuRatios;
        for (int round = 0; round < rounds; ++round) {
            RenderSettings settings;
            settings.passes = passes;
            settings.seed = round;
            RenderCounters counters;
            auto start = std::chrono::steady_clock::now();
            double cpuStart = processCpuSeconds();
            renderLocal(*scene, settings, {}, &counters);
            const double renderSeconds = seconds(start);
            const double renderCpuSeconds = processCpuSeconds() - cpuStart;
            const double renderRate = counters.rays / renderSeconds;
            const double raysPerSample = counters.rays / samples;

            start = std::chrono::steady_clock::now();
            cpuStart = processCpuSeconds();
            const uint64_t rawRays = traceRawEmbree(*scene, passes, raysPerSample);
            const double rawSeconds = seconds(start);
            const double rawCpuSeconds = processCpuSeconds() - cpuStart;
            const double rawRate = rawRays / rawSeconds;
            ratios.push_back(renderRate / rawRate);
            cpuRatios.push_back((counters.rays / renderCpuSeconds) / (rawRays / rawCpuSeconds));
            std::printf(
                "round %d: renderer %.2f Mrays/s (%.2f rays/sample, CPU/wall %.2f), raw "
                "rtcIntersect1 %.2f Mrays/s (CPU/wall %.2f), ratio %.3f, per CPU second %.3f\n",
                round, renderRate * 1e-6, raysPerSample, renderCpuSeconds / renderSeconds,
                rawRate * 1e-6, rawCpuSeconds / rawSeconds, ratios.back(), cpuRatios.back());
        }
        std::printf("median ratio renderer / raw Embree: %.3f (goal >= 0.7); per CPU second %.3f\n",
                    median(ratios), median(cpuRatios));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
