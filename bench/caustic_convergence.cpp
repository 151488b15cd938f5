// Error against wall time for path_mis and the progressive photon mapper on the caustic scene:
// both render the same crop around the caustic, pass by pass, through renderUnit; at every power of
// two of passes the RMS error against a long reference is recorded with the wall time so far.
// Writes a CSV and a log-log chart (PNG: x = seconds, y = RMS error, one decade per grid line; red
// = path_mis, blue = photonmapper).
//
// The reference is the progressive photon mapper itself at many more passes with another seed:
// it converges to the same limit as path_mis (the radius shrinks to zero), and path_mis at any
// affordable pass count is far noisier on a caustic.
//
// usage: bench_caustic_convergence [maxPasses=256] [referencePasses=2048] [outDir=out/bench]
#include "common/farm/job_scene.h"
#include "common/render/image_io.h"
#include "common/render/unit.h"
#include "common/scene/scene.h"

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

void plot(const std::string& path, const std::vector<std::vector<Point>>& series) {
    double xMin = 1e30, xMax = 0, yMin = 1e30, yMax = 0;
    for (const auto& s : series)
        for (const Point& p : s) {
            xMin = std::min(xMin, p.seconds), xMax = std::max(xMax, p.seconds);
            yMin = std::min(yMin, p.rmse), yMax = std::max(yMax, p.rmse);
        }
    const double lx0 = std::floor(std::log10(xMin)), lx1 = std::ceil(std::log10(xMax));
    const double ly0 = std::floor(std::log10(yMin)), ly1 = std::ceil(std::log10(yMax));
    const int w = 640, h = 480, margin = 40;
    Image image(w, h);
    for (float& v : image.rgb) v = 1.0f;
    auto toPixel = [&](double seconds, double rmse) {
        const double fx = (std::log10(seconds) - lx0) / std::max(1.0, lx1 - lx0);
        const double fy = (std::log10(rmse) - ly0) / std::max(1.0, ly1 - ly0);
        return Point2f(float(margin + fx * (w - 2 * margin)),
                       float(h - margin - fy * (h - 2 * margin)));
    };
    auto dot = [&](float x, float y, const Color3f& c, int r) {
        for (int dy = -r; dy <= r; ++dy)
            for (int dx = -r; dx <= r; ++dx) {
                const int px = int(std::lround(x)) + dx, py = int(std::lround(y)) + dy;
                if (px >= 0 && py >= 0 && px < w && py < h) image.set(px, py, c);
            }
    };
    const Color3f grid(0.8f), axis(0.0f);
    for (double d = lx0; d <= lx1; ++d)  // one vertical line per decade of seconds
        for (int y = margin; y <= h - margin; ++y)
            dot(toPixel(std::pow(10.0, d), std::pow(10.0, ly0)).x(), float(y),
                d == lx0 ? axis : grid, 0);
    for (double d = ly0; d <= ly1; ++d)  // one horizontal line per decade of error
        for (int x = margin; x <= w - margin; ++x)
            dot(float(x), toPixel(std::pow(10.0, lx0), std::pow(10.0, d)).y(),
                d == ly0 ? axis : grid, 0);
    const Color3f colours[] = {Color3f(0.85f, 0.1f, 0.1f), Color3f(0.1f, 0.2f, 0.85f)};
    for (size_t s = 0; s < series.size(); ++s)
        for (size_t i = 0; i < series[s].size(); ++i) {
            const Point2f a = toPixel(series[s][i].seconds, series[s][i].rmse);
            dot(a.x(), a.y(), colours[s % 2], 3);
            if (i == 0) continue;
            const Point2f b = toPixel(series[s][i - 1].seconds, series[s][i - 1].rmse);
            for (int k = 0; k <= 100; ++k)
                dot(b.x() + (a.x() - b.x()) * k / 100.0f, b.y() + (a.y() - b.y()) * k / 100.0f,
                    colours[s % 2], 1);
        }
    writePNG(path, image);
    std::printf("chart: %s (x: 1e%g .. 1e%g s, y: 1e%g .. 1e%g RMS error, log-log)\n", path.c_str(),
                lx0, lx1, ly0, ly1);
}

}  // namespace

int main(int argc, char** argv) {
    const uint32_t maxPasses = argc > 1 ? uint32_t(std::stoul(argv[1])) : 256;
    const uint32_t referencePasses = argc > 2 ? uint32_t(std::stoul(argv[2])) : 2048;
    const std::string outDir = argc > 3 ? argv[3] : "out/bench";
    const std::string scenePath = std::string(ALPHORN_SOURCE_DIR) + "/scenes/caustic/caustic.xml";
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
    std::printf("csv: %s/caustic_convergence.csv\n", outDir.c_str());
    plot(outDir + "/caustic_convergence.png", series);
    return 0;
}
