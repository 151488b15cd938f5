// volume_path_mats against volume_path_mis on fog scenes: time per pass, variance per
// pass, and the efficiency ratio 1 / (variance x time) of mis over mats, measured in one run.
//
// For each scene both integrators render the same centre crop, one pass at a time, through
// renderUnit (the function the renderer and the workers use). The variance of a pixel is the
// sample variance of its per-pass values (channel mean); the scene's figure is the mean over the
// crop. An integrator that cannot reach the scene's lights (mats with delta lights) renders
// black: its efficiency is reported as zero rather than as a division by zero.
//
// Each scene also compares volume_path_mis with and without equiangular sampling (equiangular.h).
//
// usage: bench_volume_efficiency [passes] [crop] [SCENE.xml ...]
#include "common/farm/job_scene.h"
#include "common/integrator/integrator.h"
#include "common/render/unit.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

using namespace alphorn;

namespace {

struct Figures {
    double secondsPerPass = 0, meanVariance = 0, meanValue = 0;
};

// `props` configure the integrator `integrator` that replaces the scene's.
Figures measure(const std::string& path, const std::string& integrator, uint32_t passes, int crop,
                const PropertyList& props = PropertyList("bench")) {
    std::shared_ptr<Scene> scene = farm::loadSceneWithIntegrator(path, "");
    auto replacement = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, integrator, props));
    replacement->activate();
    scene->setIntegrator(std::move(replacement));
    const Vector2i size = scene->camera()->outputSize();
    Tile tile;
    tile.x0 = std::max(0, size.x() / 2 - crop / 2);
    tile.y0 = std::max(0, size.y() / 2 - crop / 2);
    tile.x1 = std::min(size.x(), tile.x0 + crop);
    tile.y1 = std::min(size.y(), tile.y0 + crop);
    const size_t pixels = size_t(tile.width()) * tile.height();
    std::vector<double> sum(pixels, 0.0), sum2(pixels, 0.0);
    double seconds = 0;
    for (uint32_t pass = 0; pass < passes; ++pass) {
        FilmBlock block = makeUnitBlock(*scene, tile);
        const auto start = std::chrono::steady_clock::now();
        auto data = preparePasses(*scene, 1, pass, pass + 1);
        renderUnit(*scene, 1, RenderUnit{pass, pass + 1, tile}, data, block);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        const Image image = resolveImage(block, tile.x1, tile.y1);
        for (int y = tile.y0; y < tile.y1; ++y)
            for (int x = tile.x0; x < tile.x1; ++x) {
                const double v = image.get(x, y).mean();
                const size_t i = size_t(y - tile.y0) * tile.width() + (x - tile.x0);
                sum[i] += v;
                sum2[i] += v * v;
            }
    }
    Figures f;
    f.secondsPerPass = seconds / passes;
    for (size_t i = 0; i < pixels; ++i) {
        const double mean = sum[i] / passes;
        f.meanValue += mean / pixels;
        f.meanVariance += (sum2[i] - passes * mean * mean) / (passes - 1) / pixels;
    }
    return f;
}

}  // namespace

int main(int argc, char** argv) {
    const uint32_t passes = argc > 1 ? static_cast<uint32_t>(std::stoul(argv[1])) : 256;
    const int crop = argc > 2 ? std::stoi(argv[2]) : 32;
    std::vector<std::string> scenes;
    for (int i = 3; i < argc; ++i) scenes.push_back(argv[i]);
    if (scenes.empty())
        for (const char* name :
             {"medium_sphere_chromatic", "medium_sphere_scatter", "spotlight_fog"})
            scenes.push_back(sourcePath("scenes/seed/") + name + ".xml");
    if (passes < 2) {
        std::fprintf(stderr, "need at least 2 passes for a variance\n");
        return 2;
    }
    std::printf("%u passes, %dx%d centre crop, all cores\n", passes, crop, crop);
    for (const std::string& path : scenes) {
        const Figures mats = measure(path, "volume_path_mats", passes, crop);
        const Figures mis = measure(path, "volume_path_mis", passes, crop);
        auto efficiency = [](const Figures& f) {
            return f.meanVariance > 0 ? 1.0 / (f.meanVariance * f.secondsPerPass) : 0.0;
        };
        std::printf("%s\n", path.c_str());
        for (const auto& [name, f] : {std::pair{"mats", mats}, std::pair{"mis ", mis}})
            std::printf("  volume_path_%s %.4f s/pass  variance/pass %.4g  mean %.4g\n", name,
                        f.secondsPerPass, f.meanVariance, f.meanValue);
        if (mats.meanValue == 0 && mis.meanValue > 0)
            std::printf("  efficiency mis / mats: unbounded (mats renders black: delta lights)\n");
        else
            std::printf("  efficiency mis / mats: %.1f (time ratio %.2f, variance ratio %.1f)\n",
                        efficiency(mis) / efficiency(mats),
                        mis.secondsPerPass / mats.secondsPerPass,
                        mats.meanVariance / mis.meanVariance);
        // Equiangular sampling of delta lights in grey homogeneous media: mis with it (the
        // default) against mis without, in the same run.
        PropertyList off("bench: equiangular off");
        off.setBoolean("equiangular", false);
        const Figures free = measure(path, "volume_path_mis", passes, crop, off);
        std::printf(
            "  volume_path_mis, equiangular off %.4f s/pass  variance/pass %.4g  mean %.4g\n",
            free.secondsPerPass, free.meanVariance, free.meanValue);
        if (free.meanVariance > 0 && mis.meanVariance > 0)
            std::printf(
                "  efficiency equiangular on / off: %.2f (time ratio %.2f, variance ratio %.2f)\n",
                efficiency(mis) / efficiency(free), mis.secondsPerPass / free.secondsPerPass,
                free.meanVariance / mis.meanVariance);
    }
    return 0;
}
