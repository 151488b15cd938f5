// Time per pass of a progressive photon-mapping render at chosen pass indices, split into the
// photon pass (tracing and building the maps: preparePasses) and the camera pass (renderUnit over
// the whole image), with wall and CPU time, and an estimate of the whole render.
//
// Why not simply render a few passes and multiply: progressive radii shrink with the pass index
// (radius_schedule.h), and with them the cost of every gather, so the first passes are the
// slowest. The estimate interpolates the measured per-pass wall times linearly in the pass index
// between the measured passes and sums over passes 0 .. total - 1 (the last measured pass should
// be total - 1). It is an extrapolation and is printed as one. On a shared machine the wall
// times follow the load; the same sum over CPU seconds divided by the threads is printed too,
// the wall time the render would take if every thread had a core of its own.
//
// The render is the renderer's own: the same preparePasses and renderUnit that `alphorn render`
// and the workers call, over tiles of 64 pixels in parallel as renderLocal() (`alphorn render`)
// does, on as many threads as given (a tbb::global_control, as --threads sets).
//
// usage: bench_stage_passes [SCENE.xml] [threads] [total passes] [pass,pass,...]
#include "bench/timing.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <sstream>
#include <string>
#include <vector>

using namespace alphorn;
using bench::processCpuSeconds;
using bench::seconds;

namespace {

struct PassTime {
    uint32_t pass;
    double photonWall, photonCpu, cameraWall, cameraCpu;
    double wall() const { return photonWall + cameraWall; }
    double cpu() const { return photonCpu + cameraCpu; }
};

}  // namespace

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : sourcePath("scenes/stage/stage_seed.xml");
    const int threads = argc > 2 ? std::stoi(argv[2]) : 2;
    const uint32_t total = argc > 3 ? static_cast<uint32_t>(std::stoul(argv[3])) : 390;
    std::vector<uint32_t> passes;
    {
        std::stringstream list(argc > 4 ? argv[4] : "0,1,10,100,389");
        for (std::string item; std::getline(list, item, ',');)
            passes.push_back(static_cast<uint32_t>(std::stoul(item)));
    }
    for (size_t i = 1; i < passes.size(); ++i)
        if (passes[i] <= passes[i - 1]) {
            std::fprintf(stderr, "passes must increase\n");
            return 2;
        }
    try {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        std::shared_ptr<Scene> scene = loadScene(path);
        const Vector2i size = scene->camera()->outputSize();
        const std::vector<Tile> tiles = makeTiles(size.x(), size.y(), 64);
        std::printf("%s: %dx%d, %d threads\n", path.c_str(), size.x(), size.y(), threads);
        std::vector<PassTime> times;
        for (uint32_t pass : passes) {
            PassTime t{pass, 0, 0, 0, 0};
            auto start = std::chrono::steady_clock::now();
            double cpu = processCpuSeconds();
            auto data = preparePasses(*scene, 1, pass, pass + 1);
            t.photonWall = seconds(start);
            t.photonCpu = processCpuSeconds() - cpu;
            start = std::chrono::steady_clock::now();
            cpu = processCpuSeconds();
            // Tiles of 64 pixels in parallel, each its own unit, as renderLocal() renders them.
            FilmBlock film(0, 0, size.x(), size.y());
            std::mutex filmMutex;
            tbb::parallel_for(size_t(0), tiles.size(), [&](size_t i) {
                FilmBlock block = makeUnitBlock(*scene, tiles[i]);
                renderUnit(*scene, 1, RenderUnit{pass, pass + 1, tiles[i]}, data, block);
                std::lock_guard lock(filmMutex);
                film.add(block);
            });
            t.cameraWall = seconds(start);
            t.cameraCpu = processCpuSeconds() - cpu;
            std::printf(
                "pass %u: photon pass %.2f s (CPU/wall %.2f), camera pass %.2f s (CPU/wall %.2f), "
                "total %.2f s\n",
                pass, t.photonWall, t.photonCpu / t.photonWall, t.cameraWall,
                t.cameraCpu / t.cameraWall, t.wall());
            std::fflush(stdout);
            times.push_back(t);
        }
        // Piecewise-linear in the pass index through the measured passes, constant beyond them.
        auto interpolated = [&](auto&& seconds) {
            double sum = 0.0;
            size_t k = 0;
            for (uint32_t p = 0; p < total; ++p) {
                while (k + 1 < times.size() && times[k + 1].pass <= p) ++k;
                double w = seconds(times[k]);
                if (p > times[k].pass && k + 1 < times.size()) {
                    const double f =
                        double(p - times[k].pass) / (times[k + 1].pass - times[k].pass);
                    w = (1 - f) * seconds(times[k]) + f * seconds(times[k + 1]);
                }
                sum += w;
            }
            return sum;
        };
        const double wall = interpolated([](const PassTime& t) { return t.wall(); });
        const double cpu = interpolated([](const PassTime& t) { return t.cpu(); });
        std::printf(
            "estimated render of %u passes (interpolated from the passes above): wall %.1f s = "
            "%.1f min; CPU %.1f s, / %d threads = %.1f min\n",
            total, wall, wall / 60.0, cpu, threads, cpu / threads / 60.0);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
    return 0;
}
