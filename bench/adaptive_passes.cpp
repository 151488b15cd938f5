// Tile-adaptive passes against whole-image stopping, at the same target error, on a few atlas
// scenes (at reduced sizes, so that the run takes minutes).
//
// For each scene: a reference of `referencePasses` passes with another seed (its own noise, from
// its error estimate, is taken out of the measured squared error), then `rounds` rounds that
// each render the scene with --target-error E twice, whole-image stopping (A) and --adaptive
// (B), in the order A B in even rounds and B A in odd ones. Both are deterministic: their images,
// passes and true errors are the same every round; only the time varies, and the ratio of
// process CPU seconds B / A is taken per round and its median printed (wall seconds and
// CPU / wall beside it: the machine is shared).
//
// Equal error: the two stop at different true errors (A at a power of two, often well below the
// target; B when every tile meets it). The figure of merit is the efficiency 1 / (error^2 x CPU
// seconds), which is constant along a Monte Carlo convergence curve: B / A above 1 means
// adaptive reaches the same error in less time, by that factor.
//
// usage: bench_adaptive_passes [rounds] [scene name filter]   (default: 3 rounds, all scenes)
#include "bench/timing.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>
#include <time.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

using namespace alphorn;
using bench::median;
using bench::processCpuSeconds;
using bench::seconds;

namespace {

const std::string kSource = sourceDirectory();

struct BenchScene {
    std::string name, path;
    int width, height;
    double target;
    uint32_t cap, referencePasses;
};

std::vector<double> luminances(const FilmBlock& film, int width, int height) {
    const Image image = resolveImage(film, width, height);
    std::vector<double> values;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) values.push_back(image.get(x, y).luminance());
    return values;
}

struct Outcome {
    uint32_t passes = 0, tilesFinished = 0, tiles = 0;
    uint64_t samples = 0;
    double estimate = 0, truth = 0;
};

}  // namespace

int main(int argc, char** argv) {
    const int rounds = argc > 1 ? std::atoi(argv[1]) : 3;
    const std::string filter = argc > 2 ? argv[2] : "";
    const std::vector<BenchScene> scenes = {
        {"cbox", "scenes/cbox/cbox.xml", 128, 128, 0.1, 256, 512},
        {"veach", "scenes/veach/veach_mis.xml", 192, 128, 0.1, 256, 512},
        {"spotlight_fog", "scenes/seed/spotlight_fog.xml", 160, 96, 0.15, 256, 512},
        {"medium_sphere_scatter", "scenes/seed/medium_sphere_scatter.xml", 120, 90, 0.05, 256, 512},
    };
    std::printf("%-22s %6s %5s %6s %9s %9s %9s %8s %8s %8s\n", "scene", "side", "passes", "tiles",
                "samples", "estimate", "true", "cpu s", "cpu/wall", "");
    for (const BenchScene& entry : scenes) {
        if (!filter.empty() && entry.name.find(filter) == std::string::npos) continue;
        SceneOverrides overrides;
        overrides.imageSize = Vector2i(entry.width, entry.height);
        const std::shared_ptr<Scene> scene = loadScene(kSource + "/" + entry.path, {}, overrides);
        RenderSettings settings;
        settings.seed = 1000;
        settings.passes = entry.referencePasses;
        RenderStatus referenceStatus;
        const std::vector<double> reference =
            luminances(renderLocal(*scene, settings, {}, nullptr, &referenceStatus), entry.width,
                       entry.height);
        double referenceMean = 0.0;
        for (double y : reference) referenceMean += y / double(reference.size());
        const double referenceNoise =
            referenceStatus.estimate ? referenceStatus.estimate->relativeRmse : 0.0;
        std::printf("%-22s reference: %u passes, seed 1000, own noise %.4f (taken out)\n",
                    entry.name.c_str(), entry.referencePasses, referenceNoise);
        Outcome outcomes[2];
        std::vector<double> cpu[2], wall[2], ratios;
        for (int round = 0; round < rounds; ++round) {
            double roundCpu[2] = {0, 0};
            for (int k = 0; k < 2; ++k) {
                const int side = round % 2 == 0 ? k : 1 - k;
                RenderSettings run;
                run.seed = 1;
                run.passes = entry.cap;
                run.targetError = entry.target;
                run.adaptive = side == 1;
                RenderCounters counters;
                RenderStatus status;
                const double cpuStart = processCpuSeconds();
                const auto wallStart = std::chrono::steady_clock::now();
                const FilmBlock film = renderLocal(*scene, run, {}, &counters, &status);
                roundCpu[side] = processCpuSeconds() - cpuStart;
                cpu[side].push_back(roundCpu[side]);
                wall[side].push_back(seconds(wallStart));
                if (round > 0) continue;
                const std::vector<double> image = luminances(film, entry.width, entry.height);
                double squaredError = 0.0;
                for (size_t i = 0; i < image.size(); ++i)
                    squaredError += (image[i] - reference[i]) * (image[i] - reference[i]);
                squaredError /= double(image.size());
                const double noise = referenceNoise * referenceMean;
                Outcome& outcome = outcomes[side];
                outcome.truth =
                    std::sqrt(std::max(0.0, squaredError - noise * noise)) / referenceMean;
                outcome.estimate = status.estimate ? status.estimate->relativeRmse : 0.0;
                outcome.passes = status.passesDone;
                outcome.samples = counters.samples.load();
                outcome.tiles = status.adaptiveTiles;
                outcome.tilesFinished = status.adaptiveTilesFinished;
            }
            ratios.push_back(roundCpu[1] / roundCpu[0]);
        }
        for (int side = 0; side < 2; ++side) {
            const Outcome& o = outcomes[side];
            std::printf(
                "%-22s %6s %5u %6s %9llu %9.4f %9.4f %8.2f %8.2f\n", entry.name.c_str(),
                side == 0 ? "whole" : "adapt", o.passes,
                side == 0 ? "-" : absl::StrFormat("%u/%u", o.tilesFinished, o.tiles).c_str(),
                (unsigned long long)o.samples, o.estimate, o.truth, median(cpu[side]),
                median(cpu[side]) / median(wall[side]));
        }
        const double timeRatio = median(ratios);
        const double efficiency = (outcomes[0].truth * outcomes[0].truth) /
                                  (outcomes[1].truth * outcomes[1].truth) / timeRatio;
        std::printf(
            "%-22s target %.3g: CPU adaptive / whole %.3f (median of %d rounds), samples "
            "%.3f, efficiency adaptive / whole %.3f (>1: adaptive reaches equal error "
            "sooner)\n",
            entry.name.c_str(), entry.target, timeRatio, rounds,
            double(outcomes[1].samples) / double(outcomes[0].samples), efficiency);
        std::fflush(stdout);
    }
    return 0;
}
