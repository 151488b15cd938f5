// Photon tracing through media against raw Embree: how close the volumetric photon mapper's
// tracer (tracePhotonsThroughMedia: emission, free-flight sampling, phase and BSDF sampling,
// Russian roulette, storing) comes to the rate at which Embree alone traces rays in the same
// scene, the limit of any photon tracer built on it.
//
// Each round traces the photon paths of one pass, counting the rays the tracer asks Embree for
// (closest hits, null-boundary crossings and the start-medium search included), then traces as
// many raw rtcIntersect1 rays with nothing else done: origins uniform in the media box (the
// scene's bounds without media), directions uniform on the sphere. One thread for both (the
// tracer's parallel_for runs on the calling thread), alternating within a round, so that a change
// in the machine's load hits both alike; the ratio of their rays per second is printed.
//
// usage: bench_photon_tracing [SCENE.xml] [photon paths] [rounds]
#include "bench/embree_ray.h"
#include "bench/timing.h"
#include "common/core/rng.h"
#include "common/core/warp.h"
#include "common/integrator/volume.h"
#include "common/photon/photon_tracer.h"
#include "common/scene/accel.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/global_control.h>

#include <chrono>
#include <cstdio>
#include <string>

using namespace alphorn;
using bench::median;
using bench::seconds;

namespace {

// Traces `count` raw rays in the box; returns how many hit something (kept so that the loop is
// not optimised away).
uint64_t traceRawEmbree(const Scene& scene, const Eigen::AlignedBox3f& box, uint64_t count,
                        uint64_t round) {
    RTCScene embree = scene.accel().embreeScene();
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    uint64_t hits = 0;
    Rng rng(5, round, 0, StreamPurpose::Test);
    for (uint64_t i = 0; i < count; ++i) {
        const Point3f o = box.min() + box.sizes().cwiseProduct(Vector3f(
                                          rng.nextFloat(), rng.nextFloat(), rng.nextFloat()));
        const Vector3f d = warp::squareToUniformSphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        RTCRayHit rh = bench::makeRayHit(o, d);
        rtcIntersect1(embree, &context, &rh);
        hits += rh.hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }
    return hits;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : sourcePath("scenes/seed/medium_sphere_vpm.xml");
    const uint64_t paths = argc > 2 ? std::stoull(argv[2]) : 200000;
    const int rounds = argc > 3 ? std::stoi(argv[3]) : 5;
    try {
        tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
        std::shared_ptr<Scene> scene = loadScene(path);
        Eigen::AlignedBox3f box = mediaBounds(*scene);
        if (box.isEmpty()) box = scene->bounds();
        std::printf("%s: %llu photon paths per round (surface and volume), one thread\n",
                    path.c_str(), static_cast<unsigned long long>(paths));
        std::vector<double> ratios, pathRates;
        for (int round = 0; round < rounds; ++round) {
            const uint64_t raysBefore = raysTracedByThisThread();
            auto start = std::chrono::steady_clock::now();
            const TracedPhotons traced =
                tracePhotonsThroughMedia(*scene, 1, uint64_t(round), paths, paths);
            const double tracerSeconds = seconds(start);
            const uint64_t rays = raysTracedByThisThread() - raysBefore;
            start = std::chrono::steady_clock::now();
            const uint64_t rawHits = traceRawEmbree(*scene, box, rays, uint64_t(round));
            const double rawSeconds = seconds(start);
            const double tracerRate = rays / tracerSeconds, rawRate = rays / rawSeconds;
            ratios.push_back(tracerRate / rawRate);
            pathRates.push_back(paths / tracerSeconds);
            std::printf(
                "round %d: %.3f M paths/s, %.2f rays/path, %zu surface + %zu volume photons; "
                "tracer %.2f Mrays/s, raw rtcIntersect1 %.2f Mrays/s (%llu hits): ratio %.3f\n",
                round, paths / tracerSeconds * 1e-6, double(rays) / paths, traced.surface.size(),
                traced.volume.size(), tracerRate * 1e-6, rawRate * 1e-6,
                static_cast<unsigned long long>(rawHits), ratios.back());
        }
        std::printf("median: %.3f M photon paths/s; tracer / raw Embree rays per second %.3f\n",
                    median(pathRates) * 1e-6, median(ratios));
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
