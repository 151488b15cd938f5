// Error against wall time for path_mis and the progressive photon mapper on the caustic scene:
// both render the same crop around the caustic, pass by pass, through renderUnit; at every power of
// two of passes the RMS error against a long reference is recorded with the wall time so far.
// Writes a CSV; bench/atlas/plot_convergence.py draws it (matplotlib, log-log).
//
// The reference is the progressive photon mapper itself at many more passes with another seed:
// it converges to the same limit as path_mis (the radius shrinks to zero), and path_mis at any
// affordable pass count is far noisier on a caustic.
//
// usage: bench_caustic_convergence [maxPasses=256] [referencePasses=2048] [outDir=out/bench]
#include "common/farm/job_scene.h"
#include "common/render/unit.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

using namespace alphorn;

namespace {

// The caustic and the sphere's shadow in scenes/caustic/caustic.xml (384 x 288).
const Tile kCrop{224, 160, 352, 256};

// The crop's pixel values, as the film resolves them for an image.
std::vector<double> resolve(const FilmBlock& block) {
    const Image image = resolveImage(block, kCrop.x1, kCrop.y1);
    std::vector<double> rgb;
    for (int y = kCrop.y0; y < kCrop.y1; ++y)
        for (int x = kCrop.x0; x < kCrop.x1; ++x)
            for (int c = 0; c < 3; ++c) rgb.push_back(image.get(x, y)[c]);
    return rgb;
}

struct Point {
    uint32_t passes;
    double seconds, rmse;
};

// Renders passes [0, passes) with `seed`, calling `record` after every power of two; stops early
// when it returns false.
template <typename Record>
void render(const Scene& scene, uint64_t seed, uint32_t passes, Record record) {
    FilmBlock block = makeUnitBlock(scene, kCrop);
    double seconds = 0;
    for (uint32_t pass = 0; pass < passes; ++pass) {
        const auto start = std::chrono::steady_clock::now();
        const auto data = preparePasses(scene, seed, pass, pass + 1);
        renderUnit(scene, seed, RenderUnit{pass, pass + 1, kCrop}, data, block);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        if (((pass + 1) & pass) == 0 && !record(pass + 1, seconds, block)) return;
    }
}

}  // namespace

int main(int argc, char** argv) {
    const uint32_t maxPasses = argc > 1 ? uint32_t(std::stoul(argv[1])) : 256;
    const uint32_t referencePasses = argc > 2 ? uint32_t(std::stoul(argv[2])) : 2048;
    const std::string outDir = argc > 3 ? argv[3] : "out/bench";
    const std::string scenePath = sourcePath("scenes/caustic/caustic.xml");
    std::filesystem::create_directories(outDir);

    auto photonScene = farm::loadSceneWithIntegrator(scenePath, "");
    auto pathScene = farm::loadSceneWithIntegrator(scenePath, "path_mis");
    std::printf("reference: photonmapper, %u passes, seed 1000, crop %dx%d\n", referencePasses,
                kCrop.width(), kCrop.height());
    std::vector<double> reference;
    render(*photonScene, 1000, referencePasses,
           [&](uint32_t passes, double seconds, const FilmBlock& block) {
               if (passes == referencePasses) reference = resolve(block);
               std::fprintf(stderr, "  reference %u passes, %.1f s\n", passes, seconds);
               return true;
           });
    if (reference.empty()) {
        std::fprintf(stderr, "referencePasses must be a power of two\n");
        return 2;
    }

    std::ofstream csv(outDir + "/caustic_convergence.csv");
    csv << "integrator,passes,seconds,rmse\n";
    // The photon mapper runs maxPasses; path_mis, about 7x cheaper per pass, runs until it has
    // used the same wall time, so the two are compared at equal time as well as by their curves.
    std::vector<std::vector<Point>> series(2);
    double budget = 0;
    for (int which : {1, 0}) {
        const char* name = which == 0 ? "path_mis" : "photonmapper";
        const Scene& scene = which == 0 ? *pathScene : *photonScene;
        const uint32_t passes = which == 0 ? maxPasses * 64 : maxPasses;
        render(scene, 1, passes, [&](uint32_t done, double seconds, const FilmBlock& block) {
            const std::vector<double> image = resolve(block);
            double sum = 0;
            for (size_t i = 0; i < image.size(); ++i)
                sum += (image[i] - reference[i]) * (image[i] - reference[i]);
            const double rmse = std::sqrt(sum / image.size());
            series[which].push_back({done, seconds, rmse});
            csv << name << ',' << done << ',' << seconds << ',' << rmse << '\n';
            std::printf("%-12s %6u passes %8.3f s  RMS error %.5f\n", name, done, seconds, rmse);
            if (which == 1) budget = seconds;
            return which == 1 || seconds < budget;
        });
    }
    const Point& mis = series[0].back();
    const Point& ppm = series[1].back();
    std::printf(
        "equal time: path_mis %u passes, %.2f s, RMS error %.5f; photonmapper %u passes, "
        "%.2f s, RMS error %.5f; error ratio path_mis / photonmapper %.2f\n",
        mis.passes, mis.seconds, mis.rmse, ppm.passes, ppm.seconds, ppm.rmse, mis.rmse / ppm.rmse);
    std::printf(
        "csv: %s/caustic_convergence.csv (chart: /usr/bin/python3 bench/atlas/plot_convergence.py "
        "%s/caustic_convergence.csv)\n",
        outDir.c_str(), outDir.c_str());
    return 0;
}
