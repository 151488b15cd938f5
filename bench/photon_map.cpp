// Photon map benchmark: how fast photons are traced and stored, how the two photon map indexes
// compare on the same fixed-radius gathers, how fast k-nearest-neighbour gathers run, and how a
// progressive pass splits its time between the photon pass and the camera pass.
//
// Indexes compared on identical photons and identical query points (the first non-delta hits of
// camera rays, as in a render), single-threaded, alternating in each round:
//   - nanoflann's k-d tree (Debian's libnanoflann-dev), leaves of 8, 16 and 32 photons;
//   - our hashed grid (common/photon/photon_hash_grid.h), cells of twice the radius.
// Both must find exactly the same photons (checked: the counts and the power sums must agree),
// and the ratio of their query rates is printed per round: these machines are noisy, so only
// ratios measured in the same run are worth comparing.
//
// usage: bench_photon_map [SCENE.xml] [photons] [rounds]
#include "bench/timing.h"
#include "common/integrator/direct.h"
#include "common/photon/density_estimate.h"
#include "common/photon/photon_hash_grid.h"
#include "common/photon/photon_kdtree.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/radius_schedule.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/global_control.h>
#include <tbb/info.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <string>

using namespace alphorn;
using bench::median;
using bench::seconds;

namespace {

// The first non-delta surface point of camera rays through random image positions.
std::vector<Point3f> queryPoints(const Scene& scene, size_t count) {
    const Camera& camera = *scene.camera();
    const Vector2f size = camera.outputSize().cast<float>();
    std::vector<Point3f> points;
    for (uint64_t i = 0; points.size() < count && i < 20 * count; ++i) {
        Rng rng(99, 0, i, StreamPurpose::Test);
        Ray3f ray;
        const float u = rng.nextFloat(), v = rng.nextFloat();
        camera.sampleRay(ray, Point2f(u * size.x(), v * size.y()), Point2f(0.5f, 0.5f));
        for (int depth = 0; depth < 8; ++depth) {
            Intersection its;
            if (!scene.rayIntersect(ray, its)) break;
            const BSDF& bsdf = *its.mesh->bsdf();
            if (bsdf.isDiffuse()) {
                points.push_back(its.p);
                break;
            }
            BSDFQueryRecord rec = makeBSDFQuery(its, its.toLocal(-ray.d.normalized()));
            if (bsdf.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).isBlack()) break;
            ray = Ray3f(its.p, its.toWorld(rec.wo));
        }
    }
    return points;
}

struct GatherResult {
    double seconds = 0.0;
    uint64_t found = 0;
    double power = 0.0;
};

// Sums the luminance of the photons within `radius` of every query point.
template <typename Index>
GatherResult gather(const Index& index, const Photons& photons, const std::vector<Point3f>& points,
                    float radius) {
    GatherResult r;
    const auto start = std::chrono::steady_clock::now();
    for (const Point3f& x : points) {
        index.forEachWithin(x, radius, [&](uint32_t i, float) {
            ++r.found;
            r.power += photons[i].power.luminance();
        });
    }
    r.seconds = seconds(start);
    return r;
}

std::shared_ptr<Integrator> makePhotonMapper(uint64_t photons, float radius) {
    PropertyList props("bench photonmapper");
    props.setInteger("photonCount", static_cast<int>(photons));
    props.setFloat("surfacePhotonRadius", radius);
    props.setBoolean("progressive", true);
    auto integrator = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, "photonmapper", props));
    integrator->activate();
    return integrator;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string scenePath = argc > 1 ? argv[1] : sourcePath("scenes/cbox/cbox.xml");
    const uint64_t photonCount = argc > 2 ? std::stoull(argv[2]) : 1000000;
    const int rounds = argc > 3 ? std::stoi(argv[3]) : 3;
    try {
        std::shared_ptr<Scene> scene = loadScene(scenePath);
        const int cores = tbb::info::default_concurrency();
        const float diagonal = scene->bounds().diagonal().norm();
        std::printf("scene %s, %llu photons per map, %d rounds, %d cores\n", scenePath.c_str(),
                    static_cast<unsigned long long>(photonCount), rounds, cores);

        // 1. Photon tracing, on one core and on all.
        TracedPhotons traced;
        for (int threads : {1, cores}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            std::vector<double> rates;
            for (int round = 0; round < rounds; ++round) {
                const auto start = std::chrono::steady_clock::now();
                traced = tracePhotons(*scene, 1, round, photonCount);
                const double s = seconds(start);
                rates.push_back(photonCount / s / threads);
                std::printf(
                    "trace, %d thread(s), round %d: %.3f s, %.2f M emitted/s/core, %.2f M "
                    "stored/s/core (%.2f stored per emitted)\n",
                    threads, round, s, photonCount / s / threads * 1e-6,
                    traced.surface.size() / s / threads * 1e-6,
                    double(traced.surface.size()) / photonCount);
            }
            std::printf("trace, %d thread(s): median %.2f M photons emitted/s/core\n", threads,
                        median(rates) * 1e-6);
        }
        const Photons& photons = traced.surface;
        const std::vector<Point3f> points = queryPoints(*scene, 100000);
        std::printf("%zu stored photons, %zu query points\n", photons.size(), points.size());

        // 2. Fixed-radius gathers: k-d tree (three leaf sizes) against the hashed grid. Within a
        //    round the four indexes take turns on blocks of 5000 queries, so that a change in
        //    the machine's load hits all of them alike.
        for (float radius : {diagonal / 500.0f, diagonal / 100.0f}) {
            std::vector<double> ratios[3], gridRates, gridBuild, treeBuild;
            uint64_t found = 0;
            const size_t leaves[3] = {8, 16, 32};
            for (int round = 0; round < rounds; ++round) {
                auto start = std::chrono::steady_clock::now();
                PhotonHashGrid grid(photons.data(), photons.size(), radius);
                gridBuild.push_back(seconds(start));
                std::vector<std::unique_ptr<PhotonKdTree>> trees;
                for (size_t leaf : leaves) {
                    start = std::chrono::steady_clock::now();
                    trees.push_back(
                        std::make_unique<PhotonKdTree>(photons.data(), photons.size(), leaf));
                    if (leaf == 16) treeBuild.push_back(seconds(start));
                }
                GatherResult g, t[3];
                constexpr size_t kBlock = 5000;
                for (size_t b = 0; b < points.size(); b += kBlock) {
                    const std::vector<Point3f> block(
                        points.begin() + b, points.begin() + std::min(points.size(), b + kBlock));
                    const GatherResult gb = gather(grid, photons, block, radius);
                    g.seconds += gb.seconds, g.found += gb.found, g.power += gb.power;
                    for (int l = 0; l < 3; ++l) {
                        const GatherResult tb = gather(*trees[l], photons, block, radius);
                        t[l].seconds += tb.seconds, t[l].found += tb.found, t[l].power += tb.power;
                    }
                }
                found = g.found;
                for (int l = 0; l < 3; ++l) {
                    if (t[l].found != g.found || std::abs(t[l].power - g.power) > 1e-6 * g.power) {
                        std::fprintf(stderr, "MISMATCH: k-d tree found %llu photons, grid %llu\n",
                                     (unsigned long long)t[l].found, (unsigned long long)g.found);
                        return 1;
                    }
                    ratios[l].push_back(g.seconds / t[l].seconds);
                }
                gridRates.push_back(points.size() / g.seconds);
                std::printf(
                    "radius %.4g, round %d: grid %.0f queries/s; k-d tree / grid rate: "
                    "leaf 8 %.3f, leaf 16 %.3f, leaf 32 %.3f\n",
                    radius, round, gridRates.back(), ratios[0].back(), ratios[1].back(),
                    ratios[2].back());
            }
            std::printf(
                "radius %.4g (%.1f photons per gather): grid median %.0f queries/s; median k-d "
                "tree / grid query rate: leaf 8 %.3f, leaf 16 %.3f, leaf 32 %.3f; build grid %.1f "
                "ms, k-d tree %.1f ms\n",
                radius, double(found) / points.size(), median(gridRates), median(ratios[0]),
                median(ratios[1]), median(ratios[2]), median(gridBuild) * 1e3,
                median(treeBuild) * 1e3);
        }

        // 3. k nearest neighbours (k-d tree only: a grid has no natural kNN query).
        {
            PhotonKdTree tree(photons.data(), photons.size());
            for (size_t k : {10, 50, 100}) {
                std::vector<PhotonNeighbor> out(k);
                std::vector<double> rates;
                for (int round = 0; round < rounds; ++round) {
                    const auto start = std::chrono::steady_clock::now();
                    double sum = 0.0;
                    for (const Point3f& x : points)
                        sum += tree.nearest(x, k, diagonal, out.data()) ? out[0].distance2 : 0.0;
                    rates.push_back(points.size() / seconds(start));
                    if (!(sum >= 0.0)) return 1;
                }
                std::printf("kNN k = %zu: median %.0f queries/s (one thread)\n", k, median(rates));
            }
        }

        // 4. A progressive pass of the photon mapper on this scene at 100k photons per pass:
        //    time in preparePass (photon tracing + index) vs the camera pass over the image.
        {
            auto integrator = makePhotonMapper(100000, diagonal / 100.0f);
            scene->setIntegrator(integrator);
            const Vector2i size = scene->camera()->outputSize();
            const std::vector<Tile> tiles = makeTiles(size.x(), size.y(), 64);
            std::vector<double> photonShare;
            for (int round = 0; round < rounds; ++round) {
                auto start = std::chrono::steady_clock::now();
                const auto data = preparePasses(*scene, 3, round, round + 1);
                const double photonSeconds = seconds(start);
                start = std::chrono::steady_clock::now();
                tbb::parallel_for(size_t(0), tiles.size(), [&](size_t i) {
                    RenderUnit unit{uint32_t(round), uint32_t(round + 1), tiles[i]};
                    FilmBlock block = makeUnitBlock(*scene, unit.tile);
                    renderUnit(*scene, 3, unit, data, block);
                });
                const double cameraSeconds = seconds(start);
                photonShare.push_back(photonSeconds / (photonSeconds + cameraSeconds));
                std::printf(
                    "progressive pass %d (100k photons, %dx%d pixels): photon pass %.3f "
                    "s, camera pass %.3f s\n",
                    round, size.x(), size.y(), photonSeconds, cameraSeconds);
            }
            std::printf("progressive pass: median photon share of the time %.3f\n",
                        median(photonShare));
        }
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
