// `alphorn render SCENE.xml`: renders locally with all cores and writes EXR and PNG.
#include "cli/commands.h"
#include "cli/farm_client.h"
#include "cli/progress.h"

#include "common/core/image.h"
#include "common/integrator/integrator.h"
#include "common/photon/radius_schedule.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <absl/strings/str_format.h>
#include <fcntl.h>
#include <signal.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <cerrno>
#include <charconv>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <optional>

namespace alphorn::cli {

namespace {
struct RenderOptions {
    std::string scene;
    std::string output;
    std::optional<uint32_t> spp, passes, maxPasses;
    std::optional<double> targetError;  // relative RMSE
    bool adaptive = false;              // tile-adaptive passes (with a target)
    int threads = 0;
    uint64_t seed = 0;
    int tile = 64;
    float exposure = 0.0f;
    double timeLimit = 0.0;            // seconds; 0: none
    std::vector<std::string> defines;  // -D name=value
    std::string size;                  // --size WxH
    std::string crop;                  // --crop x0,y0,x1,y1
    uint64_t maxMemory = 0;            // bytes; 0: the physical memory
};

// --crop x0,y0,x1,y1: pixels [x0, x1) x [y0, y1) of an image of `size`.
Tile cropWindow(const std::string& text, const Vector2i& size) {
    // from_chars, not sscanf: "%d" wrapped 4294967297 to 1 and took " 5" and "+5".
    Tile crop;
    int* const corners[] = {&crop.x0, &crop.y0, &crop.x1, &crop.y1};
    const char* next = text.data();
    const char* const end = text.data() + text.size();
    bool parsed = true;
    for (int i = 0; i < 4 && parsed; ++i) {
        const auto [stop, error] = std::from_chars(next, end, *corners[i]);
        parsed = stop != next && error == std::errc() &&
                 (i < 3 ? stop != end && *stop == ',' : stop == end);
        next = stop + 1;
    }
    if (!parsed)
        fail("--crop %s: expected X0,Y0,X1,Y1 (pixels [X0, X1) x [Y0, Y1), e.g. 0,0,64,32)", text);
    if (crop.x0 < 0 || crop.y0 < 0 || crop.x0 >= crop.x1 || crop.y0 >= crop.y1 ||
        crop.x1 > size.x() || crop.y1 > size.y())
        fail("--crop %s: needs 0 <= X0 < X1 <= %d and 0 <= Y0 < Y1 <= %d (the image is %dx%d)",
             text, size.x(), size.y(), size.x(), size.y());
    return crop;
}

// The film's pixels [x0, x1) x [y0, y1) as an image of the crop's size.
Image resolveCrop(const FilmBlock& film, const Tile& crop) {
    FilmBlock shifted(0, 0, crop.width(), crop.height());
    for (int y = 0; y < crop.height(); ++y)
        for (int x = 0; x < crop.width(); ++x) shifted.at(x, y) = film.at(crop.x0 + x, crop.y0 + y);
    return resolveImage(shifted, crop.width(), crop.height());
}

// -D name=value, --size WxH: the scene as the command line changes it.
SceneOverrides sceneOverrides(const RenderOptions& options) {
    SceneOverrides overrides;
    for (const std::string& define : options.defines) {
        const size_t equals = define.find('=');
        if (equals == std::string::npos || equals == 0) fail("-D %s: expected NAME=VALUE", define);
        const std::string name = define.substr(0, equals);
        for (char c : name)
            if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_')
                fail("-D %s: a parameter name has only letters, digits and _", define);
        if (!overrides.parameters.emplace(name, define.substr(equals + 1)).second)
            fail("-D %s: %s is defined twice", define, name);
    }
    if (!options.size.empty()) {
        // from_chars, not sscanf: "%d" silently wraps 4294967297 to 1.
        const std::string& text = options.size;
        const size_t x = text.find_first_of("xX");
        int width = 0, height = 0;
        const auto parse = [&](size_t begin, size_t end, int& value) {
            const auto [stop, error] =
                std::from_chars(text.data() + begin, text.data() + end, value);
            return begin < end && error == std::errc() && stop == text.data() + end;
        };
        if (x == std::string::npos || !parse(0, x, width) || !parse(x + 1, text.size(), height) ||
            width < 1 || height < 1 || width > 16384 || height > 16384)
            fail("--size %s: expected WIDTHxHEIGHT, each from 1 to 16384 (e.g. 640x360)",
                 options.size);
        overrides.imageSize = Vector2i(width, height);
    }
    return overrides;
}

// How far past --time-limit the render may end without a note saying why.
constexpr double kTimeLimitSlackSeconds = 0.5;

// Set by the first Ctrl-C (SIGINT); rendering stops after the pass in progress.
std::atomic<bool> g_interrupted{false};
std::atomic<bool> g_stop{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");

extern "C" void onInterrupt(int) {
    g_interrupted.store(true);
    g_stop.store(true);
    // Only async-signal-safe calls here. SA_RESETHAND has restored the default action, so a
    // second Ctrl-C ends the process at once, without an image.
    const char message[] =
        "\ninterrupted: finishing the pass in progress, then writing the image of the passes done "
        "(Ctrl-C again quits without writing)\n";
    [[maybe_unused]] ssize_t ignored = ::write(STDERR_FILENO, message, sizeof(message) - 1);
}

// Fails before rendering when the image could not be written where asked: a render of hours
// must not end in a permission error.
void checkOutputWritable(const std::string& output) {
    if (std::filesystem::is_directory(output))
        fail("cannot write the image to %s: it is a directory", output);
    const std::string probe = output + ".probe-" + std::to_string(::getpid());
    const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0)
        fail("cannot write the image to %s: %s (checked before rendering)", output,
             std::strerror(errno));
    ::close(fd);
    ::unlink(probe.c_str());
}

// Writes the EXR and the PNG beside it. When that fails (the disk filled up during the render,
// the folder went away) the render is not lost: the image goes to the temporary folder instead,
// and the error names where.
void writeImages(const std::string& output, const Image& image, float exposure) {
    try {
        writeEXR(output, image);
        writePNG(pngPathFor(output), image, exposure);
    } catch (const Error& error) {
        const std::string fallback = (std::filesystem::temp_directory_path() /
                                      ("alphorn-" + std::to_string(::getpid()) + "-" +
                                       std::filesystem::path(output).filename().string()))
                                         .string();
        try {
            writeEXR(fallback, image);
            writePNG(pngPathFor(fallback), image, exposure);
        } catch (const Error& second) {
            fail("%s; saving the image to %s instead failed too: %s", error.what(), fallback,
                 second.what());
        }
        fail("%s; the image was saved to %s and %s instead", error.what(), fallback,
             pngPathFor(fallback));
    }
}

void stopOnInterrupt() {
    struct sigaction action = {};
    action.sa_handler = onInterrupt;
    action.sa_flags = SA_RESETHAND | SA_RESTART;
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, nullptr);
}
}  // namespace

static int runRender(const RenderOptions& options) {
    std::unique_ptr<tbb::global_control> threadLimit;
    if (options.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, options.threads);

    std::shared_ptr<Scene> scene =
        loadScene(options.scene, {}, sceneOverrides(options), {options.maxMemory, "--max-memory"});
    std::cerr << "loaded " << options.scene << ": " << scene->toString() << "\n";

    RenderSettings settings;
    settings.seed = options.seed;
    settings.tileSize = options.tile;
    settings.maxFilmBytes = options.maxMemory;
    // A pass is one sample per pixel: --spp and --passes mean the same, the scene's sampler
    // gives the default.
    settings.passes = options.passes ? *options.passes
                      : options.spp  ? *options.spp
                                     : static_cast<uint32_t>(scene->sampler()->sampleCount());
    if (settings.passes == 0) fail("the number of passes must be positive");
    if (options.targetError) {
        settings.targetError = options.targetError;
        settings.passes = *options.maxPasses;  // the option parser insists on the cap
        settings.adaptive = options.adaptive;
    }

    std::string output = options.output;
    if (output.empty())
        output = (std::filesystem::path("out") /
                  std::filesystem::path(options.scene).filename().replace_extension(".exr"))
                     .string();
    if (auto parent = std::filesystem::path(output).parent_path(); !parent.empty())
        std::filesystem::create_directories(parent);
    checkOutputWritable(output);
    checkOutputWritable(pngPathFor(output));

    ProgressLine progress("render", settings.passes);
    const std::optional<RadiusSchedule> radiusSchedule = scene->integrator()->radiusSchedule();
    const Vector2i size = scene->camera()->outputSize();
    if (!options.crop.empty()) settings.crop = cropWindow(options.crop, size);
    if (settings.adaptive && settings.crop)
        fail("--adaptive and --crop do not combine (the adaptive tiles cover the whole image)");
    settings.stop = &g_stop;
    stopOnInterrupt();
    uint32_t passesDone = 0;
    RenderStatus finalStatus;
    auto start = std::chrono::steady_clock::now();
    FilmBlock film = renderLocal(
        *scene, settings,
        [&](const RenderStatus& status) {
            double seconds =
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
            passesDone = status.passesDone;
            if (options.timeLimit > 0 && seconds >= options.timeLimit) g_stop.store(true);
            std::string radius;
            if (radiusSchedule)
                radius = absl::StrFormat(
                    "  radius %.4g",
                    reportedProgressiveRadius(radiusSchedule->initialRadius, radiusSchedule->alpha,
                                              status.passesDone));
            progress.update(status.passesDone,
                            errorText(status, settings.targetError) + "  " +
                                speedText(seconds > 0 ? status.samplesDone / seconds : 0.0,
                                          seconds > 0 ? status.rays / seconds : 0.0) +
                                radius);
        },
        nullptr, &finalStatus);
    double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const bool interrupted = g_interrupted.load();
    const bool targetReached = finalStatus.targetReached;
    const bool stoppedEarly = passesDone < settings.passes && !targetReached;
    progress.finish(interrupted     ? "interrupted"
                    : stoppedEarly  ? "time limit reached"
                    : targetReached ? "target error reached"
                                    : "done");
    if (passesDone == 0) {
        std::cerr << "interrupted before the first pass was done: no image written\n";
        return kExitInterrupted;
    }
    if (film.invalidSamples)
        std::cerr << "warning: " << film.invalidSamples
                  << " samples were NaN, infinite or negative and were left out\n";

    Image image =
        settings.crop ? resolveCrop(film, *settings.crop) : resolveImage(film, size.x(), size.y());
    writeImages(output, image, options.exposure);
    if (stoppedEarly && settings.adaptive)
        std::cerr << absl::StrFormat(
            "%s after %u of %u passes: wrote %s and %s with the passes done (%.1f s)\n",
            interrupted ? "interrupted" : "time limit reached", passesDone, settings.passes, output,
            pngPathFor(output), seconds);
    else if (stoppedEarly)
        std::cerr << absl::StrFormat(
            "%s after %u of %u passes: wrote %s and %s with the %u passes done (the same bytes as "
            "--passes %u, %.1f s)\n",
            interrupted ? "interrupted" : "time limit reached", passesDone, settings.passes, output,
            pngPathFor(output), passesDone, passesDone, seconds);
    else
        std::cerr << absl::StrFormat("wrote %s and %s (%d passes, %.1f s)\n", output,
                                     pngPathFor(output), passesDone, seconds);
    // The limit is looked at between passes only (a pass stopped halfway would have to be taken
    // out of the film): a long pass overshoots it, which the user should not have to guess.
    if (stoppedEarly && !interrupted && seconds > options.timeLimit + kTimeLimitSlackSeconds)
        std::cerr << absl::StrFormat(
            "note: the time limit (%g s) is looked at between passes; the pass running when it "
            "passed was finished first, %.1f s after it\n",
            options.timeLimit, seconds - options.timeLimit);
    std::cerr << finalEstimateText(finalStatus, settings.targetError, settings.passes) << "\n";
    return interrupted ? kExitInterrupted : kExitOk;
}

Command addRenderCommand(CLI::App& app) {
    auto options = std::make_shared<RenderOptions>();
    CLI::App* sub = app.add_subcommand("render", "Render a scene on this machine (EXR and PNG).");
    sub->add_option("scene", options->scene, "Scene file: Nori XML, or pbrt-v4 for a .pbrt file")
        ->required()
        ->check(CLI::ExistingFile);
    sub->add_option("-o,--output", options->output,
                    "Output EXR path; a PNG is written beside it (default: out/SCENE.exr)")
        ->check(kExrOutputPath);
    auto* spp = sub->add_option("--spp", options->spp,
                                "Samples per pixel (= passes; default: the scene's sampleCount)")
                    ->check(kPositiveCount);
    auto* passes =
        sub->add_option("--passes", options->passes, "Number of passes (one sample per pixel each)")
            ->excludes(spp)
            ->check(kPositiveCount);
    addTargetErrorOptions(*sub, options->targetError, options->maxPasses, options->adaptive,
                          {spp, passes});
    sub->add_option("--threads", options->threads, "Worker threads (default: all cores)")
        ->check(CLI::Range(0, 1024));
    sub->add_option("--seed", options->seed, "Random seed; the image is a pure function of it")
        ->check(kSeed);
    sub->add_option("--tile", options->tile, "Tile size in pixels (does not change the image)")
        ->check(CLI::Range(1, 16384));
    sub->add_option("--exposure", options->exposure, "PNG exposure in stops (EXR is unaffected)")
        ->check(kFinite);
    sub->add_option("-D,--define", options->defines,
                    "NAME=VALUE: the value of $NAME in the scene's attribute values (repeatable)")
        ->allow_extra_args(false);
    sub->add_option("--size", options->size,
                    "WIDTHxHEIGHT: the image size, replacing the camera's width and height");
    sub->add_option("--crop", options->crop,
                    "X0,Y0,X1,Y1: render only pixels [X0, X1) x [Y0, Y1) into an image of that "
                    "size, the same values as in the whole image");
    sub->add_option("--time-limit", options->timeLimit,
                    "Stop after the pass running when SECONDS have passed and write the image of "
                    "the passes done")
        ->check(kFinite & CLI::PositiveNumber);
    sub->add_option("--max-memory", options->maxMemory,
                    "The most memory the scene's meshes may take, and the film, e.g. 8GB "
                    "(default: the physical memory); a scene or image beyond it is refused "
                    "before it is built")
        ->transform(CLI::AsSizeValue(false))
        // transform() puts a validator first: the sign is checked before the size is read.
        ->transform(farm::kDecimalSize);
    return {sub, [options] { return runRender(*options); }};
}

}  // namespace alphorn::cli
