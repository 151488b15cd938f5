// Direct light in the photon mappers by photons or by next-event estimation (`directLight`
// "photons" vs "nee"): error against a long reference at equal time, on scenes/cbox/cbox_ppm.xml
// and scenes/caustic/caustic.xml as they are (progressive photonmapper), or any photon-mapper
// scenes given. Both variants render the whole image pass by pass through renderUnit,
// interleaved (a pass of one, then the same pass of the other), each timed on its own; at every
// power of two of passes the RMS error of each against the reference is printed with its time
// so far, and the efficiency ratio nee / photons = (MSE · seconds)_photons / (MSE · seconds)_nee
// (above 1: next-event estimation wins at equal time; the square root is the ratio of errors
// at equal time).
//
// The reference is the mean of both variants at `referencePasses` passes with another seed: both
// converge to the same limit as the radius shrinks, and averaging them favours neither. Its own
// noise adds the same amount to both variants' MSE, so it can only pull the ratio towards 1.
//
// With referencePasses = 0 it only times the two variants (wall and process CPU time per variant):
// the errors are a pure function of the seed, so a timing run on a quieter machine completes an
// earlier run's figures.
//
// usage: bench_photon_direct_light [passes=64] [referencePasses=512] [scene.xml ...]
#include "common/core/image.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <sys/resource.h>

#include <chrono>
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

double cpuSeconds() {
    rusage usage{};
    getrusage(RUSAGE_SELF, &usage);
    return double(usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) +
           1e-6 * double(usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// The scene with `directLight` set on its integrator: a copy of the file beside it (meshes are
// named relative to it), loaded and removed.
std::shared_ptr<Scene> loadWithDirectLight(const std::string& path, const std::string& mode) {
    std::ifstream in(path);
    std::stringstream text;
    text << in.rdbuf();
    std::string xml = text.str();
    // A mode the scene names itself is dropped first (a second property would be an error).
    xml = std::regex_replace(xml, std::regex(R"(<string name="directLight" value="[a-z]*"/>)"), "");
    const std::string tag = "photonmapper\">";
    const size_t at = xml.find(tag);
    if (at == std::string::npos) throw std::runtime_error(path + ": no photon-mapper integrator");
    xml.insert(at + tag.size(), "<string name=\"directLight\" value=\"" + mode + "\"/>");
    const std::filesystem::path copy =
        std::filesystem::path(path).parent_path() / (".bench_direct_light_" + mode + ".xml");
    std::ofstream(copy) << xml;
    std::shared_ptr<Scene> scene;
    try {
        scene = loadScene(copy.string());
    } catch (...) {
        std::filesystem::remove(copy);
        throw;
    }
    std::filesystem::remove(copy);
    return scene;
}

struct Progressive {
    const Scene* scene;
    Tile tile;
    FilmBlock block;
    double seconds = 0.0, cpu = 0.0;  // wall and process CPU time of this variant's passes

    Progressive(const Scene& s)
        : scene(&s),
          tile{0, 0, s.camera()->outputSize().x(), s.camera()->outputSize().y()},
          block(makeUnitBlock(s, tile)) {}

    void renderPass(uint64_t seed, uint32_t pass) {
        const auto start = std::chrono::steady_clock::now();
        const double cpuStart = cpuSeconds();
        const auto data = preparePasses(*scene, seed, pass, pass + 1);
        renderUnit(*scene, seed, RenderUnit{pass, pass + 1, tile}, data, block);
        seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        cpu += cpuSeconds() - cpuStart;
    }

    std::vector<double> image() const {
        const Image resolved = resolveImage(block, tile.x1, tile.y1);
        return std::vector<double>(resolved.rgb.begin(), resolved.rgb.end());
    }
};

double rmse(const std::vector<double>& a, const std::vector<double>& b) {
    double sum = 0.0;
    for (size_t i = 0; i < a.size(); ++i) sum += (a[i] - b[i]) * (a[i] - b[i]);
    return std::sqrt(sum / double(a.size()));
}

// The caustic and the sphere's shadow in scenes/caustic/caustic.xml (bench/caustic_convergence's
// crop): where next-event estimation must leave the light focused by the glass to the photons.
const Tile kCausticCrop{224, 160, 352, 256};

// The mean of the crop's pixel values in an image `width` pixels wide (RGB).
double cropMean(const std::vector<double>& rgb, int width, const Tile& crop) {
    double sum = 0.0;
    for (int y = crop.y0; y < crop.y1; ++y)
        for (int x = crop.x0; x < crop.x1; ++x)
            for (int c = 0; c < 3; ++c) sum += rgb[3 * (size_t(y) * width + x) + c];
    return sum / (3.0 * crop.width() * crop.height());
}

void runScene(const std::string& path, uint32_t passes, uint32_t referencePasses) {
    auto photons = loadWithDirectLight(path, "photons");
    auto nee = loadWithDirectLight(path, "nee");
    std::printf("%s: %dx%d, %s\n", path.c_str(), photons->camera()->outputSize().x(),
                photons->camera()->outputSize().y(), photons->integrator()->toString().c_str());

    if (referencePasses == 0) {  // timing only: the errors are a pure function of the seed
        Progressive a(*photons), b(*nee);
        for (uint32_t pass = 0; pass < passes; ++pass) {
            a.renderPass(1, pass);
            b.renderPass(1, pass);
            if (((pass + 1) & pass) != 0) continue;
            std::printf(
                "  %5u passes  photons %8.2f s wall %8.2f s CPU   nee %8.2f s wall %8.2f s CPU   "
                "time nee / photons: wall %.3f, CPU %.3f\n",
                pass + 1, a.seconds, a.cpu, b.seconds, b.cpu, b.seconds / a.seconds, b.cpu / a.cpu);
        }
        return;
    }
    Progressive refPhotons(*photons), refNee(*nee);
    for (uint32_t pass = 0; pass < referencePasses; ++pass) {
        refPhotons.renderPass(1000, pass);
        refNee.renderPass(1000, pass);
    }
    std::vector<double> reference = refPhotons.image();
    const std::vector<double> other = refNee.image();
    for (size_t i = 0; i < reference.size(); ++i) reference[i] = 0.5 * (reference[i] + other[i]);
    std::printf(
        "  reference: mean of both at %u passes, seed 1000 (%.1f s photons, %.1f s nee); they "
        "differ by RMS %.5f\n",
        referencePasses, refPhotons.seconds, refNee.seconds, rmse(refPhotons.image(), other));

    Progressive a(*photons), b(*nee);
    const double cpuStart = cpuSeconds();
    for (uint32_t pass = 0; pass < passes; ++pass) {
        a.renderPass(1, pass);
        b.renderPass(1, pass);
        if (((pass + 1) & pass) != 0) continue;
        const double ea = rmse(a.image(), reference), eb = rmse(b.image(), reference);
        std::printf(
            "  %5u passes  photons %8.2f s (CPU %.2f s) RMS %.5f   nee %8.2f s (CPU %.2f s) RMS "
            "%.5f   efficiency nee / photons: wall %.2f, CPU %.2f\n",
            pass + 1, a.seconds, a.cpu, ea, b.seconds, b.cpu, eb,
            (ea * ea * a.seconds) / (eb * eb * b.seconds), (ea * ea * a.cpu) / (eb * eb * b.cpu));
    }
    if (path.ends_with("caustic.xml")) {
        const int width = a.tile.x1;
        std::printf(
            "  caustic crop (%d,%d)-(%d,%d) mean: reference %.5f, photons %.5f, nee %.5f (the "
            "two references %.5f and %.5f)\n",
            kCausticCrop.x0, kCausticCrop.y0, kCausticCrop.x1, kCausticCrop.y1,
            cropMean(reference, width, kCausticCrop), cropMean(a.image(), width, kCausticCrop),
            cropMean(b.image(), width, kCausticCrop),
            cropMean(refPhotons.image(), width, kCausticCrop),
            cropMean(other, width, kCausticCrop));
    }
    const double wall = a.seconds + b.seconds;
    std::printf("  timed runs: wall %.1f s, CPU %.1f s (CPU / wall %.2f)\n", wall,
                cpuSeconds() - cpuStart, (cpuSeconds() - cpuStart) / wall);
}

}  // namespace

int main(int argc, char** argv) {
    std::setvbuf(stdout, nullptr, _IOLBF, 0);  // progress lines while it runs (it runs long)
    const uint32_t passes = argc > 1 ? uint32_t(std::stoul(argv[1])) : 64;
    const uint32_t referencePasses = argc > 2 ? uint32_t(std::stoul(argv[2])) : 512;
    std::vector<std::string> scenes;
    for (int i = 3; i < argc; ++i) scenes.push_back(argv[i]);
    if (scenes.empty())
        scenes = {sourcePath("scenes/cbox/cbox_ppm.xml"), sourcePath("scenes/caustic/caustic.xml")};
    for (const std::string& scene : scenes) runScene(scene, passes, referencePasses);
    return 0;
}
