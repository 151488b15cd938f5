// The renderer and error meter of the speed-vs-accuracy atlas (bench/atlas/run_atlas.py drives
// it; docs/accuracy.md shows the results). Four modes:
//
//   bench_atlas_render render SCENE --integrator TYPE [--set KIND:NAME=VALUE]... [--size WxH]
//       [--crop X0,Y0,X1,Y1] [--seed S] --passes N1,N2,... [--cpu-budget SECONDS]
//       [--reference REF.exr] [--write-exr OUT.exr] [--bias-probes NAME,NAME...]
//     Replaces the scene's integrator by TYPE with the given parameters (KIND is int, float, bool
//     or string), then renders the crop once for every pass count of the ladder, each render from
//     pass 0 (so each point costs what a user asking for that many passes would pay). Prints one
//     CSV row per render: passes, wall seconds, CPU seconds of the whole process (all threads),
//     the relative RMSE against REF.exr (empty without a reference) and the film's own predicted
//     relative RMSE. The ladder stops early once the next render would push the total CPU time
//     over the budget (CPU time: the machine may be shared, and wall time then measures the
//     others' load as much as ours). --write-exr writes the image of the last render done
//     (the references). The predicted error of a film that keeps the smaller radius's image (a
//     progressive photon mapper's) includes its two-radii bias; its noise part and that bias are
//     printed too (predicted_noise, film_bias_two_radii; empty bias for other films).
//     --bias-probes (progressive photon mappers) also prints the two bias
//     estimates of error_estimate.h for each render: the temporal one from a second render of
//     half the passes, and the two-radii one from a render with the same seed whose float
//     parameters NAME (the gather radii, given with --set) are divided by sqrt(2); both films
//     are exactly what a renderer keeping those sums would hold.
//
//   bench_atlas_render compare A.exr B.exr      prints the relative RMSE of A against B
//   bench_atlas_render crops IMAGE.exr SIZE     prints the image's mean RGB ("all,R,G,B") and each
//     SIZE x SIZE crop's ("X0,Y0,R,G,B", the last row and column of crops may be smaller): what
//     bench/peers/agree_pbrt_v4.py compares between renderers
//   bench_atlas_render average A.exr B.exr OUT.exr   writes the pixelwise mean of A and B
//   bench_atlas_render difference A.exr B.exr OUT.exr
//     writes the luminance difference (A - B) / mean of B's luminance, the relative RMSE's
//     per-pixel term, as a grey EXR, and prints the relative RMSE and the share of the squared
//     error that the worst 0.1%, 1% and 10% of the pixels carry: where a few pixels dominate
//     (fireflies, or a small feature one image lacks), the map shows which.
//
// Relative RMSE: sqrt(mean over pixels of (Y - Y_ref)²) / mean over pixels of Y_ref, with Y the
// Rec. 709 luminance. Dividing by the mean rather than per pixel keeps near-black pixels from
// dominating, and makes the figure comparable across scenes of different brightness.
#include "common/core/image.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <sys/resource.h>

#include <array>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

using namespace alphorn;

namespace {

[[noreturn]] void usageError(const std::string& problem) {
    std::fprintf(stderr, "bench_atlas_render: %s (see the usage at the top of atlas_render.cpp)\n",
                 problem.c_str());
    std::exit(2);
}

double processCpuSeconds() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    auto toSeconds = [](const timeval& t) { return double(t.tv_sec) + 1e-6 * double(t.tv_usec); };
    return toSeconds(usage.ru_utime) + toSeconds(usage.ru_stime);
}

std::vector<long> parseNumbers(const std::string& text, char separator, const char* what) {
    std::vector<long> numbers;
    std::stringstream stream(text);
    std::string item;
    while (std::getline(stream, item, separator)) {
        char* end = nullptr;
        const long value = std::strtol(item.c_str(), &end, 10);
        if (item.empty() || *end != '\0')
            usageError(std::string(what) + ": bad number \"" + item + "\"");
        numbers.push_back(value);
    }
    return numbers;
}

double relativeRmse(const Image& image, const Image& reference) {
    if (image.width != reference.width || image.height != reference.height)
        usageError("the image is " + std::to_string(image.width) + "x" +
                   std::to_string(image.height) + " but the reference is " +
                   std::to_string(reference.width) + "x" + std::to_string(reference.height));
    double squaredError = 0, referenceSum = 0;
    for (int y = 0; y < image.height; ++y)
        for (int x = 0; x < image.width; ++x) {
            const double value = image.get(x, y).luminance();
            const double expected = reference.get(x, y).luminance();
            squaredError += (value - expected) * (value - expected);
            referenceSum += expected;
        }
    const double pixels = double(image.width) * image.height;
    return std::sqrt(squaredError / pixels) / (referenceSum / pixels);
}

int differenceMode(const std::string& pathA, const std::string& pathB,
                   const std::string& outputPath) {
    const Image a = readEXR(pathA), b = readEXR(pathB);
    if (a.width != b.width || a.height != b.height) usageError("the images differ in size");
    const size_t pixels = size_t(a.width) * a.height;
    double referenceSum = 0;
    for (int y = 0; y < b.height; ++y)
        for (int x = 0; x < b.width; ++x) referenceSum += b.get(x, y).luminance();
    const double referenceMean = referenceSum / double(pixels);
    if (!(referenceMean > 0)) usageError("the second image is black: no relative difference");
    Image difference(a.width, a.height);
    std::vector<double> squared;
    squared.reserve(pixels);
    for (int y = 0; y < a.height; ++y)
        for (int x = 0; x < a.width; ++x) {
            const double d =
                (double(a.get(x, y).luminance()) - b.get(x, y).luminance()) / referenceMean;
            difference.set(x, y, Color3f(float(d)));
            squared.push_back(d * d);
        }
    writeEXR(outputPath, difference);
    std::sort(squared.begin(), squared.end(), std::greater<>());
    const double total = std::accumulate(squared.begin(), squared.end(), 0.0);
    std::printf("relative_rmse %.6g\n", std::sqrt(total / double(pixels)));
    for (const double fraction : {0.001, 0.01, 0.1}) {
        const size_t worst = std::max<size_t>(1, size_t(fraction * double(pixels)));
        const double share =
            total > 0 ? std::accumulate(squared.begin(), squared.begin() + worst, 0.0) / total
                      : 0.0;
        std::printf("worst %g%% of pixels (%zu): %.3f of the squared error\n", 100 * fraction,
                    worst, share);
    }
    return 0;
}

void setParameter(PropertyList& props, const std::string& text) {
    const size_t colon = text.find(':'), equals = text.find('=');
    if (colon == std::string::npos || equals == std::string::npos || equals < colon)
        usageError("--set " + text + ": expected KIND:NAME=VALUE");
    const std::string kind = text.substr(0, colon);
    const std::string name = text.substr(colon + 1, equals - colon - 1);
    const std::string value = text.substr(equals + 1);
    if (kind == "int")
        props.setInteger(name, std::stoi(value));
    else if (kind == "float")
        props.setFloat(name, std::stof(value));
    else if (kind == "bool")
        props.setBoolean(name, value == "true");
    else if (kind == "string")
        props.setString(name, value);
    else
        usageError("--set " + text + ": KIND must be int, float, bool or string");
}

int renderMode(int argc, char** argv) {
    std::string scenePath = argv[2], integratorType, referencePath, outputPath;
    std::vector<std::string> parameters;
    std::vector<long> ladder, crop;
    SceneOverrides overrides;
    uint64_t seed = 0;
    double cpuBudget = 0;
    std::vector<std::string> probedRadii;
    for (int i = 3; i < argc; ++i) {
        const std::string option = argv[i];
        if (i + 1 >= argc) usageError(option + " needs a value");
        const std::string value = argv[++i];
        if (option == "--integrator")
            integratorType = value;
        else if (option == "--set")
            parameters.push_back(value);
        else if (option == "--size") {
            const std::vector<long> size = parseNumbers(value, 'x', "--size");
            if (size.size() != 2) usageError("--size " + value + ": expected WIDTHxHEIGHT");
            overrides.imageSize = Vector2i(int(size[0]), int(size[1]));
        } else if (option == "--crop")
            crop = parseNumbers(value, ',', "--crop");
        else if (option == "--seed")
            seed = std::stoull(value);
        else if (option == "--passes")
            ladder = parseNumbers(value, ',', "--passes");
        else if (option == "--cpu-budget")
            cpuBudget = std::stod(value);
        else if (option == "--reference")
            referencePath = value;
        else if (option == "--write-exr")
            outputPath = value;
        else if (option == "--bias-probes") {
            std::stringstream names(value);
            for (std::string name; std::getline(names, name, ',');) probedRadii.push_back(name);
        } else
            usageError("unknown option " + option);
    }
    if (integratorType.empty() || ladder.empty())
        usageError("--integrator and --passes are needed");

    std::shared_ptr<Scene> scene = loadScene(scenePath, {}, overrides);
    PropertyList props("atlas integrator \"" + integratorType + "\"");
    for (const std::string& parameter : parameters) setParameter(props, parameter);
    const auto makeIntegrator = [&](const PropertyList& properties) {
        auto integrator = std::static_pointer_cast<Integrator>(
            ObjectFactory::create(ObjectKind::Integrator, integratorType, properties));
        integrator->activate();
        return integrator;
    };
    scene->setIntegrator(makeIntegrator(props));
    // The bias probes' second scene: the same, with the named radii divided by sqrt(2).
    std::shared_ptr<Scene> smallerRadiusScene;
    const double alpha = props.getFloat("alpha", 0.5f);
    if (!probedRadii.empty()) {
        PropertyList smaller("atlas integrator \"" + integratorType + "\", smaller radii");
        for (const std::string& parameter : parameters) {
            const std::string name = parameter.substr(0, parameter.find('='));
            bool probed = false;
            for (const std::string& radius : probedRadii) probed |= name == "float:" + radius;
            if (probed)
                smaller.setFloat(name.substr(6), props.getFloat(name.substr(6)) / std::sqrt(2.0f));
            else
                setParameter(smaller, parameter);
        }
        for (const std::string& radius : probedRadii)
            if (!props.has(radius)) usageError("--bias-probes " + radius + ": give it with --set");
        smallerRadiusScene = loadScene(scenePath, {}, overrides);
        smallerRadiusScene->setIntegrator(makeIntegrator(smaller));
    }

    const Vector2i size = scene->camera()->outputSize();
    Tile window{0, 0, size.x(), size.y()};
    if (!crop.empty()) {
        if (crop.size() != 4) usageError("--crop: expected X0,Y0,X1,Y1");
        window = Tile{int(crop[0]), int(crop[1]), int(crop[2]), int(crop[3])};
        if (window.x0 < 0 || window.y0 < 0 || window.x1 > size.x() || window.y1 > size.y() ||
            window.width() <= 0 || window.height() <= 0)
            usageError("--crop lies outside the image");
    }
    std::optional<Image> reference;
    if (!referencePath.empty()) reference = readEXR(referencePath);

    std::printf(
        "passes,wall_seconds,cpu_seconds,relative_rmse,predicted_relative_rmse,"
        "predicted_bias_temporal,predicted_bias_two_radii,predicted_noise,film_bias_two_radii\n");
    double totalCpuSeconds = 0, lastCpuSeconds = 0;
    long lastPasses = 0;
    for (const long passes : ladder) {
        // Stop before a render that would overrun the budget, guessing its CPU time from the
        // last one in proportion to passes (each render starts from pass 0).
        if (cpuBudget > 0 && lastPasses > 0 &&
            totalCpuSeconds + lastCpuSeconds * double(passes) / double(lastPasses) > cpuBudget)
            break;
        RenderSettings settings;
        settings.seed = seed;
        settings.passes = uint32_t(passes);
        settings.crop = window;
        const double cpuStart = processCpuSeconds();
        const auto wallStart = std::chrono::steady_clock::now();
        const FilmBlock film = renderLocal(*scene, settings);
        const double wall =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - wallStart).count();
        const double cpu = processCpuSeconds() - cpuStart;
        const Image whole = resolveImage(film, size.x(), size.y());
        Image image(window.width(), window.height());
        for (int y = window.y0; y < window.y1; ++y)
            for (int x = window.x0; x < window.x1; ++x)
                image.set(x - window.x0, y - window.y0, whole.get(x, y));
        std::string error;
        if (reference) error = std::to_string(relativeRmse(image, *reference));
        // The film's own error estimate (its pass-parity halves, over the same window);
        // run_atlas.py draws it beside the true error. Empty where none can be made (1 pass).
        std::string predicted, predictedNoise, filmBias;
        if (const auto estimate = estimateError(film, window, uint32_t(passes))) {
            predicted = std::to_string(estimate->relativeRmse);
            predictedNoise = std::to_string(estimate->relativeNoise());
            if (estimate->relativeBias) filmBias = std::to_string(*estimate->relativeBias);
        }
        std::string biasTemporal, biasTwoRadii;
        if (smallerRadiusScene) {
            settings.passes = uint32_t(passes / 2);
            if (const auto bias = estimateRelativeBiasTemporal(film, renderLocal(*scene, settings),
                                                               window, uint32_t(passes), alpha))
                biasTemporal = std::to_string(*bias);
            settings.passes = uint32_t(passes);
            if (const auto bias = estimateRelativeBiasTwoRadii(
                    film, renderLocal(*smallerRadiusScene, settings), window, uint32_t(passes)))
                biasTwoRadii = std::to_string(*bias);
        }
        std::printf("%ld,%.6f,%.6f,%s,%s,%s,%s,%s,%s\n", passes, wall, cpu, error.c_str(),
                    predicted.c_str(), biasTemporal.c_str(), biasTwoRadii.c_str(),
                    predictedNoise.c_str(), filmBias.c_str());
        std::fflush(stdout);
        if (!outputPath.empty()) writeEXR(outputPath, image);  // the last one done stays
        totalCpuSeconds += cpu;
        lastCpuSeconds = cpu;
        lastPasses = passes;
    }
    return 0;
}

int cropsMode(const std::string& path, int size) {
    if (size < 1) usageError("the crop size must be at least 1 pixel");
    const Image image = readEXR(path);
    auto mean = [&](int x0, int y0, int x1, int y1) {
        double sum[3] = {0, 0, 0};
        for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x)
                for (int c = 0; c < 3; ++c)
                    sum[c] += image.rgb[3 * (size_t(y) * image.width + x) + c];
        const double n = double(x1 - x0) * double(y1 - y0);
        return std::array<double, 3>{sum[0] / n, sum[1] / n, sum[2] / n};
    };
    const auto all = mean(0, 0, image.width, image.height);
    std::printf("all,%.9g,%.9g,%.9g\n", all[0], all[1], all[2]);
    for (int y = 0; y < image.height; y += size)
        for (int x = 0; x < image.width; x += size) {
            const auto m =
                mean(x, y, std::min(x + size, image.width), std::min(y + size, image.height));
            std::printf("%d,%d,%.9g,%.9g,%.9g\n", x, y, m[0], m[1], m[2]);
        }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string mode = argc > 1 ? argv[1] : "";
    try {
        if (mode == "render" && argc >= 3) return renderMode(argc, argv);
        if (mode == "compare" && argc == 4) {
            std::printf("%.6g\n", relativeRmse(readEXR(argv[2]), readEXR(argv[3])));
            return 0;
        }
        if (mode == "difference" && argc == 5) return differenceMode(argv[2], argv[3], argv[4]);
        if (mode == "crops" && argc == 4) return cropsMode(argv[2], std::atoi(argv[3]));
        if (mode == "average" && argc == 5) {
            const Image a = readEXR(argv[2]), b = readEXR(argv[3]);
            if (a.width != b.width || a.height != b.height) usageError("the images differ in size");
            Image mean(a.width, a.height);
            for (size_t i = 0; i < mean.rgb.size(); ++i) mean.rgb[i] = 0.5f * (a.rgb[i] + b.rgb[i]);
            writeEXR(argv[4], mean);
            return 0;
        }
    } catch (const std::exception& error) {
        std::fprintf(stderr, "bench_atlas_render: %s\n", error.what());
        return 1;
    }
    usageError("expected a mode: render, compare, average or difference");
}
