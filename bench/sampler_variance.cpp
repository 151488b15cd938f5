// Error at equal samples per pixel of the independent, stratified and sobol samplers on four
// scene classes: a soft shadow (direct_mats), the Cornell box (path_mis), a spotlight in fog
// (volume_path_mis) and the caustic (progressive photon mapper). Every scene renders a centre crop
// through renderUnit, the function the renderer and the workers use.
//
// The reference is the same scene with the independent sampler at many passes and another seed,
// rendered pass by pass so that its own noise can be estimated: the variance of its per-pass
// pixel values over its pass count. That noise adds to every sampler's squared error alike, so
// the table prints the raw mean squared error and the error with the reference noise taken off
// ("MSE - ref"); the ratios use the latter. The photon mapper's passes do not share one
// distribution (the radius shrinks), so its reference-noise estimate is approximate, and its error
// includes the progressive estimate's bias, which no sampler changes.
//
// The samplers render interleaved, pass by pass (one pass of each in turn, the first of each
// round rotating), after an untimed warm-up pass each, so that machine load affects their times
// alike; "time" is the render time per pass relative to independent.
// stratified is given sampleCount = spp, the count it stratifies over.
//
// "est/true" checks the error estimate (error_estimate.h) each sampler's film gives: the relative
// RMSE estimated from the film's halves by pass parity over the true one (the luminance's RMSE
// against the reference, its noise taken out, over the reference's mean luminance), the geometric
// mean over the seeds. It is near 1 when the halves are independent replicates of the image; a
// sampler whose halves are complementary strata shows a ratio that grows with spp.
//
// usage: bench_sampler_variance [referencePasses=1024] [crop=128] [seeds=2]
//                               [scenes=shadow,cbox,fog,caustic] [SPP ...] (default SPP: 16 64)
#include "bench/timing.h"
#include "common/render/error_estimate.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

using namespace alphorn;

namespace {

struct SceneCase {
    const char* key;  // its name on the command line
    const char* name;
    const char* path;  // relative to the source tree
    Tile crop;         // empty: the centre crop
};

// The scene file with its sampler replaced, written to a temporary file: file names made
// absolute (they are relative to the original's folder), the <sampler> element swapped.
std::shared_ptr<Scene> loadWithSampler(const std::string& path, const std::string& type,
                                       int sampleCount) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    std::string xml = text.str();
    const std::string folder = std::filesystem::path(path).parent_path().string();
    xml = std::regex_replace(xml, std::regex(R"((name="filename"\s+value=")([^/"]))"),
                             "$1" + folder + "/$2");
    const std::string sampler = "<sampler type=\"" + type +
                                "\"><integer name=\"sampleCount\" value=\"" +
                                std::to_string(sampleCount) + "\"/></sampler>";
    const std::regex existing(R"(<sampler[\s\S]*?</sampler>)");
    if (std::regex_search(xml, existing))
        xml = std::regex_replace(xml, existing, sampler, std::regex_constants::format_first_only);
    else
        xml = std::regex_replace(xml, std::regex(R"(<scene>)"), "<scene>" + sampler,
                                 std::regex_constants::format_first_only);
    const std::filesystem::path temporary =
        std::filesystem::temp_directory_path() / ("bench_sampler_variance_" + type + ".xml");
    std::ofstream(temporary) << xml;
    auto scene = loadScene(temporary.string());
    std::filesystem::remove(temporary);
    return scene;
}

Tile centreCrop(const Scene& scene, int crop) {
    const Vector2i size = scene.camera()->outputSize();
    Tile tile;
    tile.x0 = std::max(0, size.x() / 2 - crop / 2);
    tile.y0 = std::max(0, size.y() / 2 - crop / 2);
    tile.x1 = std::min(size.x(), tile.x0 + crop);
    tile.y1 = std::min(size.y(), tile.y0 + crop);
    return tile;
}

std::vector<double> pixels(const FilmBlock& block, const Tile& tile) {
    const Image image = resolveImage(block, tile.x1, tile.y1);
    std::vector<double> rgb;
    for (int y = tile.y0; y < tile.y1; ++y)
        for (int x = tile.x0; x < tile.x1; ++x)
            for (int c = 0; c < 3; ++c) rgb.push_back(image.get(x, y)[c]);
    return rgb;
}

// Per pixel, from pixels()'s RGB triples, with Color3f::luminance()'s weights.
std::vector<double> luminances(const std::vector<double>& rgb) {
    std::vector<double> values;
    for (size_t i = 0; i + 2 < rgb.size(); i += 3)
        values.push_back(0.212671 * rgb[i] + 0.715160 * rgb[i + 1] + 0.072169 * rgb[i + 2]);
    return values;
}

struct Reference {
    std::vector<double> mean;
    double noise = 0;  // the mean squared error the reference's own noise adds
    // The same for the luminance, and its mean over the crop (the error estimate's units).
    std::vector<double> luminanceMean;
    double luminanceNoise = 0, meanLuminance = 0;
};

Reference renderReference(const Scene& scene, const Tile& tile, uint32_t passes) {
    std::vector<double> sum, sum2, luminanceSum, luminanceSum2;
    for (uint32_t pass = 0; pass < passes; ++pass) {
        FilmBlock block = makeUnitBlock(scene, tile);
        const auto data = preparePasses(scene, 1000, pass, pass + 1);
        renderUnit(scene, 1000, RenderUnit{pass, pass + 1, tile}, data, block);
        const std::vector<double> image = pixels(block, tile);
        const std::vector<double> luminance = luminances(image);
        sum.resize(image.size(), 0.0);
        sum2.resize(image.size(), 0.0);
        luminanceSum.resize(luminance.size(), 0.0);
        luminanceSum2.resize(luminance.size(), 0.0);
        for (size_t i = 0; i < image.size(); ++i) {
            sum[i] += image[i];
            sum2[i] += image[i] * image[i];
        }
        for (size_t i = 0; i < luminance.size(); ++i) {
            luminanceSum[i] += luminance[i];
            luminanceSum2[i] += luminance[i] * luminance[i];
        }
    }
    Reference r;
    for (size_t i = 0; i < sum.size(); ++i) {
        const double mean = sum[i] / passes;
        r.mean.push_back(mean);
        r.noise += (sum2[i] - passes * mean * mean) / (passes - 1) / passes / sum.size();
    }
    for (size_t i = 0; i < luminanceSum.size(); ++i) {
        const double mean = luminanceSum[i] / passes;
        r.luminanceMean.push_back(mean);
        r.meanLuminance += mean / luminanceSum.size();
        r.luminanceNoise +=
            (luminanceSum2[i] - passes * mean * mean) / (passes - 1) / passes / luminanceSum.size();
    }
    return r;
}

}  // namespace

int main(int argc, char** argv) {
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress while it runs, also into a file
    const uint32_t referencePasses = argc > 1 ? uint32_t(std::stoul(argv[1])) : 1024;
    const int crop = argc > 2 ? std::stoi(argv[2]) : 128;
    const int seeds = argc > 3 ? std::stoi(argv[3]) : 2;
    const std::string chosen = argc > 4 ? argv[4] : "shadow,cbox,fog,caustic";
    std::vector<uint32_t> spps;
    for (int i = 5; i < argc; ++i) spps.push_back(uint32_t(std::stoul(argv[i])));
    if (spps.empty()) spps = {16, 64};
    const bool tooFewSpp = std::any_of(spps.begin(), spps.end(), [](uint32_t n) { return n < 2; });
    if (referencePasses < 2 || seeds < 1 || tooFewSpp) {
        std::fprintf(stderr, "need at least 2 reference passes, 1 seed and 2 spp\n");
        return 2;
    }
    const SceneCase scenes[] = {
        // Direct light only: a soft shadow under an area light
        // (scenes/seed/sampler_stratified.xml's subject).
        {"shadow", "soft shadow (direct_mats)", "scenes/seed/sampler_independent.xml", Tile{}},
        {"cbox", "cbox (path_mis)", "scenes/cbox/cbox.xml", Tile{}},
        {"fog", "spotlight_fog (volume_path_mis)", "scenes/seed/spotlight_fog.xml", Tile{}},
        // The caustic and the sphere's shadow (bench_caustic_convergence's crop).
        {"caustic", "caustic (photonmapper, progressive)", "scenes/caustic/caustic.xml",
         Tile{224, 160, 352, 256}},
    };
    const char* samplers[] = {"independent", "stratified", "sobol"};
    std::printf(
        "reference: independent, %u passes, seed 1000; %dx%d centre crop (caustic: 128x96 "
        "around the caustic); %d seeds per figure; all cores\n",
        referencePasses, crop, crop, seeds);
    for (const SceneCase& sceneCase : scenes) {
        if (("," + chosen + ",").find("," + std::string(sceneCase.key) + ",") == std::string::npos)
            continue;
        const std::string path = sourcePath(sceneCase.path);
        const auto referenceScene = loadWithSampler(path, "independent", 1);
        const Tile tile =
            sceneCase.crop.width() > 0 ? sceneCase.crop : centreCrop(*referenceScene, crop);
        const auto start = std::chrono::steady_clock::now();
        const Reference reference = renderReference(*referenceScene, tile, referencePasses);
        std::printf("\n%s: reference %.1f s, its noise (MSE) %.3g\n", sceneCase.name,
                    bench::seconds(start), reference.noise);
        std::printf("  %4s  %-12s %10s %12s %12s %10s %8s %12s %9s\n", "spp", "sampler", "RMSE",
                    "MSE", "MSE - ref", "MSE ratio", "time", "var/spp", "est/true");
        for (uint32_t spp : spps) {
            std::vector<std::shared_ptr<Scene>> variants;
            for (const char* sampler : samplers)
                variants.push_back(loadWithSampler(path, sampler, int(spp)));
            std::vector<double> mse(variants.size(), 0.0), time(variants.size(), 0.0),
                iidMse(variants.size(), 0.0), logEstimateOverTruth(variants.size(), 0.0);
            for (const auto& scene : variants) {  // warm-up, untimed: first-touch costs
                FilmBlock block = makeUnitBlock(*scene, tile);
                renderUnit(*scene, 999, RenderUnit{0, 1, tile}, preparePasses(*scene, 999, 0, 1),
                           block);
            }
            for (int seed = 1; seed <= seeds; ++seed) {
                std::vector<FilmBlock> blocks;
                for (const auto& scene : variants) blocks.push_back(makeUnitBlock(*scene, tile));
                std::vector<std::vector<double>> passSum(variants.size()),
                    passSum2(variants.size());
                for (uint32_t pass = 0; pass < spp; ++pass)
                    for (size_t turn = 0; turn < variants.size(); ++turn) {
                        const size_t s = (pass + turn) % variants.size();  // who goes first rotates
                        const auto passStart = std::chrono::steady_clock::now();
                        const auto data = preparePasses(*variants[s], seed, pass, pass + 1);
                        FilmBlock passBlock = makeUnitBlock(*variants[s], tile);
                        renderUnit(*variants[s], seed, RenderUnit{pass, pass + 1, tile}, data,
                                   passBlock);
                        time[s] += bench::seconds(passStart);
                        blocks[s].add(passBlock);
                        const std::vector<double> image = pixels(passBlock, tile);
                        passSum[s].resize(image.size(), 0.0);
                        passSum2[s].resize(image.size(), 0.0);
                        for (size_t i = 0; i < image.size(); ++i) {
                            passSum[s][i] += image[i];
                            passSum2[s][i] += image[i] * image[i];
                        }
                    }
                for (size_t s = 0; s < variants.size(); ++s) {
                    const std::vector<double> image = pixels(blocks[s], tile);
                    double sum = 0;
                    for (size_t i = 0; i < image.size(); ++i) {
                        const double e = image[i] - reference.mean[i];
                        sum += e * e;
                    }
                    mse[s] += sum / image.size() / seeds;
                    const std::vector<double> luminance = luminances(image);
                    double luminanceSquaredError = 0;
                    for (size_t i = 0; i < luminance.size(); ++i) {
                        const double e = luminance[i] - reference.luminanceMean[i];
                        luminanceSquaredError += e * e;
                    }
                    const double truth =
                        std::sqrt(std::max(0.0, luminanceSquaredError / luminance.size() -
                                                    reference.luminanceNoise)) /
                        reference.meanLuminance;
                    const auto estimate = estimateError(blocks[s], tile, spp);
                    logEstimateOverTruth[s] +=
                        (estimate && truth > 0 ? std::log(estimate->relativeRmse / truth)
                                               : std::nan("")) /
                        seeds;
                    // What the error would be if the passes were independent: the variance of a
                    // pass's pixel values over the spp (a check on the reference and on
                    // independent, whose passes are independent).
                    double variance = 0;
                    for (size_t i = 0; i < image.size(); ++i) {
                        const double mean = passSum[s][i] / spp;
                        variance += (passSum2[s][i] - spp * mean * mean) / (spp - 1);
                    }
                    iidMse[s] += variance / image.size() / spp / seeds;
                }
            }
            for (size_t s = 0; s < variants.size(); ++s) {
                const double corrected = mse[s] - reference.noise;
                std::printf("  %4u  %-12s %10.4g %12.4g %12.4g %10.2f %8.2f %12.4g %9.2f\n", spp,
                            samplers[s], std::sqrt(mse[s]), mse[s], corrected,
                            (mse[0] - reference.noise) / corrected, time[s] / time[0], iidMse[s],
                            std::exp(logEstimateOverTruth[s]));
            }
        }
    }
    std::printf(
        "\nMSE ratio = (MSE - ref) of independent / (MSE - ref) of the sampler: above 1, "
        "the sampler has less error at equal spp. time = render time / independent's. var/spp = "
        "the MSE independent passes with the per-pass variance seen would give. est/true = the "
        "error estimate from the film's halves / the true relative RMSE (luminance), geometric "
        "mean over the seeds.\n");
    return 0;
}
