// `alphorn render SCENE.xml`: renders locally with all cores and writes EXR and PNG.
#include "cli/commands.h"
#include "cli/progress.h"

#include "common/integrator/integrator.h"
#include "common/photon/radius_schedule.h"
#include "common/render/image_io.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <iostream>
#include <optional>

namespace alphorn::cli {

namespace {
struct RenderOptions {
    std::string scene;
    std::string output;
    std::optional<uint32_t> spp, passes;
    int threads = 0;
    uint64_t seed = 0;
    int tile = 64;
    float exposure = 0.0f;
};
}  // namespace

static int runRender(const RenderOptions& options) {
    std::unique_ptr<tbb::global_control> threadLimit;
    if (options.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, options.threads);

    std::shared_ptr<Scene> scene = loadScene(options.scene);
    std::cerr << "loaded " << options.scene << ": " << scene->toString() << "\n";

    RenderSettings settings;
    settings.seed = options.seed;
    settings.tileSize = options.tile;
    // A pass is one sample per pixel: --spp and --passes mean the same, the scene's sampler
    // gives the default.
    settings.passes = options.passes ? *options.passes
                      : options.spp  ? *options.spp
                                     : static_cast<uint32_t>(scene->sampler()->sampleCount());
    if (settings.passes == 0) fail("the number of passes must be positive");

    std::string output = options.output;
    if (output.empty())
        output = (std::filesystem::path("out") /
                  std::filesystem::path(options.scene).filename().replace_extension(".exr"))
                     .string();
    if (auto parent = std::filesystem::path(output).parent_path(); !parent.empty())
        std::filesystem::create_directories(parent);

    ProgressLine progress("render", settings.passes);
    const std::optional<RadiusSchedule> radiusSchedule = scene->integrator()->radiusSchedule();
    auto start = std::chrono::steady_clock::now();
    FilmBlock film = renderLocal(*scene, settings, [&](const RenderStatus& status) {
        double seconds =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        std::string radius;
        if (radiusSchedule)
            radius = absl::StrFormat(
                "  radius %.4g",
                reportedProgressiveRadius(radiusSchedule->initialRadius, radiusSchedule->alpha,
                                          status.passesDone));
        progress.update(status.passesDone,
                        absl::StrFormat("%.2f Mrays/s%s",
                                        seconds > 0 ? status.rays / seconds * 1e-6 : 0.0, radius));
    });
    double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    progress.finish();
    if (film.invalidSamples)
        std::cerr << "warning: " << film.invalidSamples
                  << " samples were NaN, infinite or negative and were left out\n";

    const Vector2i size = scene->camera()->outputSize();
    Image image = resolveImage(film, size.x(), size.y());
    writeEXR(output, image);
    writePNG(pngPathFor(output), image, options.exposure);
    std::cerr << absl::StrFormat("wrote %s and %s (%d passes, %.1f s)\n", output,
                                 pngPathFor(output), settings.passes, seconds);
    return 0;
}

Command addRenderCommand(CLI::App& app) {
    auto options = std::make_shared<RenderOptions>();
    CLI::App* sub = app.add_subcommand("render", "Render a scene on this machine (EXR and PNG).");
    sub->add_option("scene", options->scene, "Nori-format scene file")
        ->required()
        ->check(CLI::ExistingFile);
    sub->add_option("-o,--output", options->output,
                    "Output EXR path; a PNG is written beside it (default: out/SCENE.exr)")
        ->check(kExrOutputPath);
    auto* spp = sub->add_option("--spp", options->spp,
                                "Samples per pixel (= passes; default: the scene's sampleCount)")
                    ->check(kPositiveCount);
    sub->add_option("--passes", options->passes, "Number of passes (one sample per pixel each)")
        ->excludes(spp)
        ->check(kPositiveCount);
    sub->add_option("--threads", options->threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_option("--seed", options->seed, "Random seed; the image is a pure function of it");
    sub->add_option("--tile", options->tile, "Tile size in pixels (does not change the image)")
        ->check(CLI::Range(1, 16384));
    sub->add_option("--exposure", options->exposure, "PNG exposure in stops (EXR is unaffected)");
    return {sub, [options] { return runRender(*options); }};
}

}  // namespace alphorn::cli
