// What a feature costs a scene that does not use it: pairs of renders that differ only in a
// feature the scene has no use for (or in how a scene that needs no general machinery is
// described), timed in the same run.
//
//   volume_path_mis vs path_mis               on the Cornell box, which has no media (the same
//                                             film: volume_path_mis runs path_mis's loop there)
//   volumetric_photonmapper vs photonmapper   on the progressive Cornell box, no media
//   constant heterogeneous vs homogeneous     the chromatic medium sphere written both ways, and
//                                             the heterogeneous one tracked (declared majorant:
//                                             what every constant heterogeneous medium cost
//                                             before it was rendered as a homogeneous one)
//   chromatic vs grey                         the scattering sphere (sigma_s 10) against the same
//                                             sphere with sigma_a (0, 0, 1e-6): physically the
//                                             same medium, through the hero-channel code path
//
// Each pair's two scenes are loaded once; every round renders both, in the order A B in even
// rounds and B A in odd ones (so a drift in the machine's load does not favour one side). The
// ratio is that of the process CPU seconds of B over A in the same round, and its median over
// rounds; wall seconds and CPU / wall are printed beside them (the machine is shared: only
// ratios measured together count). Where the two sides must render the same bytes, the films
// are compared.
//
// Time is half of the cost: a side that is faster per pass but noisier is not cheaper. After the
// rounds, each side renders `varianceRenders` single passes with their own seeds, and the mean
// over pixels of the per-pixel variance of luminance between them is printed beside the time
// ratio, with the efficiency ratio (1 / (variance x CPU time)) of A over B.
//
// usage: bench_feature_cost [rounds] [pass scale] [pair name filter]
//   default: 5 rounds, pass scale 1 (the passes per pair below are multiplied by it), all pairs
//   (a filter keeps the pairs whose name contains it)
#include "bench/timing.h"
#include "common/core/error.h"
#include "common/integrator/integrator.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace alphorn;
using bench::median;
using bench::processCpuSeconds;
using bench::seconds;

namespace {

const std::string kSource = sourceDirectory();

std::string readFile(const std::string& path) {
    std::ifstream in(path);
    if (!in) fail("cannot read %s", path);
    std::stringstream text;
    text << in.rdbuf();
    return text.str();
}

// Replaces the one occurrence of `from` in `text` (a missing one is an error: the scene files
// changed and the variant would silently equal the original).
std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
    const size_t at = text.find(from);
    if (at == std::string::npos || text.find(from, at + 1) != std::string::npos)
        fail("expected exactly one \"%s\" in the scene", from);
    return text.replace(at, from.size(), to);
}

// A variant of a repository scene, written next to it so that its relative paths still resolve.
std::shared_ptr<Scene> loadVariant(const std::string& scene, const std::string& name,
                                   const std::string& from, const std::string& to) {
    const std::filesystem::path original = kSource + "/" + scene;
    const std::filesystem::path path =
        original.parent_path() / absl::StrFormat(".bench_feature_cost_%d_%s.xml", ::getpid(), name);
    std::ofstream(path) << replaceOnce(readFile(original.string()), from, to);
    std::shared_ptr<Scene> loaded;
    try {
        loaded = loadScene(path.string());
    } catch (...) {
        std::filesystem::remove(path);
        throw;
    }
    std::filesystem::remove(path);
    return loaded;
}

struct Side {
    std::string label;
    std::shared_ptr<Scene> scene;
};

struct Pair {
    std::string name;
    Side a, b;
    uint32_t passes;
    double bound;    // the ratio B / A must stay below this (0: no bound, report only)
    bool sameBytes;  // whether both sides must render the same film
};

struct Timing {
    double wall = 0.0, cpu = 0.0;
};

Timing render(const Scene& scene, uint32_t passes, std::string& bytes) {
    RenderSettings settings;
    settings.passes = passes;
    const double cpuStart = processCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    const FilmBlock film = renderLocal(scene, settings);
    const Timing timing{seconds(start), processCpuSeconds() - cpuStart};
    bytes = film.serialize();
    return timing;
}

// Mean over pixels of the variance of luminance between `renders` single-pass renders of
// independent seeds, and the mean CPU seconds of one.
std::pair<double, double> passVariance(const Scene& scene, int renders) {
    const Vector2i size = scene.camera()->outputSize();
    const size_t pixels = size_t(size.x()) * size_t(size.y());
    std::vector<double> sum(pixels, 0.0), sum2(pixels, 0.0);
    double cpu = 0.0;
    for (int k = 0; k < renders; ++k) {
        RenderSettings settings;
        settings.passes = 1;
        settings.seed = 1000 + uint64_t(k);
        const double cpuStart = processCpuSeconds();
        const Image image = resolveImage(renderLocal(scene, settings), size.x(), size.y());
        cpu += processCpuSeconds() - cpuStart;
        for (size_t i = 0; i < pixels; ++i) {
            const double y =
                Color3f(image.rgb[3 * i], image.rgb[3 * i + 1], image.rgb[3 * i + 2]).luminance();
            sum[i] += y;
            sum2[i] += y * y;
        }
    }
    double variance = 0.0;
    for (size_t i = 0; i < pixels; ++i) {
        const double mean = sum[i] / renders;
        variance += std::max(0.0, sum2[i] / renders - mean * mean) * renders / (renders - 1);
    }
    return {variance / double(pixels), cpu / renders};
}

// Returns false when a bound is exceeded or films that must agree differ.
bool measure(const Pair& pair, int rounds, int varianceRenders) {
    std::printf("%s: %s (A) vs %s (B), %u passes, %d rounds\n", pair.name.c_str(),
                pair.a.label.c_str(), pair.b.label.c_str(), pair.passes, rounds);
    std::vector<double> cpuRatios, wallRatios;
    bool identical = true;
    for (int round = 0; round < rounds; ++round) {
        std::string bytesA, bytesB;
        Timing a, b;
        if (round % 2 == 0) {
            a = render(*pair.a.scene, pair.passes, bytesA);
            b = render(*pair.b.scene, pair.passes, bytesB);
        } else {
            b = render(*pair.b.scene, pair.passes, bytesB);
            a = render(*pair.a.scene, pair.passes, bytesA);
        }
        identical = identical && bytesA == bytesB;
        cpuRatios.push_back(b.cpu / a.cpu);
        wallRatios.push_back(b.wall / a.wall);
        std::printf(
            "  round %d: A %.2f s CPU, %.2f s wall (CPU/wall %.2f); B %.2f s CPU, %.2f s wall "
            "(CPU/wall %.2f); B/A CPU %.3f, wall %.3f\n",
            round, a.cpu, a.wall, a.cpu / a.wall, b.cpu, b.wall, b.cpu / b.wall, cpuRatios.back(),
            wallRatios.back());
    }
    const double ratio = median(cpuRatios);
    std::printf("  median B/A: CPU %.3f, wall %.3f", ratio, median(wallRatios));
    bool ok = true;
    if (pair.bound > 0.0) {
        ok = ratio <= pair.bound;
        std::printf("; bound %.2f %s", pair.bound, ok ? "met" : "EXCEEDED");
    }
    std::printf("; films %s%s\n", identical ? "byte-identical" : "differ",
                pair.sameBytes ? (identical ? "" : " (MUST BE IDENTICAL)") : "");
    if (varianceRenders > 1 && !identical) {
        const auto [varianceA, cpuA] = passVariance(*pair.a.scene, varianceRenders);
        const auto [varianceB, cpuB] = passVariance(*pair.b.scene, varianceRenders);
        std::printf(
            "  variance per pass (mean over pixels, %d single-pass renders): A %.4g, B %.4g (B/A "
            "%.3f); efficiency A/B %.3f\n",
            varianceRenders, varianceA, varianceB, varianceB / varianceA,
            (varianceB * cpuB) / (varianceA * cpuA));
    }
    return ok && (identical || !pair.sameBytes);
}

std::shared_ptr<Scene> withIntegrator(const std::string& scene, const std::string& type,
                                      const PropertyList& props) {
    std::shared_ptr<Scene> loaded = loadScene(kSource + "/" + scene);
    auto integrator = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, type, props));
    integrator->activate();
    loaded->setIntegrator(integrator);
    return loaded;
}

}  // namespace

int main(int argc, char** argv) {
    const int rounds = argc > 1 ? std::stoi(argv[1]) : 5;
    const uint32_t scale = argc > 2 ? static_cast<uint32_t>(std::stoul(argv[2])) : 1;
    const std::string filter = argc > 3 ? argv[3] : "";
    const int varianceRenders = 8;
    try {
        std::vector<Pair> pairs;
        {
            const std::string cbox = "scenes/cbox/cbox.xml";  // path_mis
            pairs.push_back({"no media: volume_path_mis vs path_mis",
                             {"path_mis", loadScene(kSource + "/" + cbox)},
                             {"volume_path_mis", withIntegrator(cbox, "volume_path_mis", {})},
                             2 * scale,
                             1.05,
                             true});
        }
        {
            // cbox_ppm's photon mapper (100k photons per pass, radius 0.05, progressive, direct
            // light sampled) against the volumetric one with the same parameters.
            const std::string ppm = "scenes/cbox/cbox_ppm.xml";
            PropertyList props("bench_feature_cost (volumetric_photonmapper)");
            props.setInteger("photonCount", 100000);
            props.setFloat("surfacePhotonRadius", 0.05f);
            props.setBoolean("progressive", true);
            props.setString("directLight", "nee");
            pairs.push_back(
                {"no media: volumetric_photonmapper vs photonmapper",
                 {"photonmapper", loadScene(kSource + "/" + ppm)},
                 {"volumetric_photonmapper", withIntegrator(ppm, "volumetric_photonmapper", props)},
                 2 * scale,
                 1.05,
                 false});
        }
        {
            const std::string constant = "scenes/seed/medium_sphere_heterogeneous_constant.xml";
            std::shared_ptr<Scene> homogeneous =
                loadScene(kSource + "/scenes/seed/medium_sphere_chromatic.xml");
            std::shared_ptr<Scene> reduced = loadScene(kSource + "/" + constant);
            // sigma_t is 2 in every channel: a declared majorant of 2 tracks exactly as the
            // heterogeneous medium did before constant media were reduced.
            std::shared_ptr<Scene> tracked = loadVariant(
                constant, "tracked", R"(<medium type="heterogeneous" name="inside">)",
                R"(<medium type="heterogeneous" name="inside"><float name="majorant" value="2"/>)");
            pairs.push_back({"constant heterogeneous (rendered as homogeneous) vs homogeneous",
                             {"homogeneous", homogeneous},
                             {"heterogeneous, constant", reduced},
                             1 * scale,
                             1.05,
                             true});
            pairs.push_back({"constant heterogeneous tracked (declared majorant) vs homogeneous",
                             {"homogeneous", homogeneous},
                             {"heterogeneous, constant, majorant 2", tracked},
                             1 * scale,
                             0.0,
                             false});
        }
        {
            const std::string scatter = "scenes/seed/medium_sphere_scatter.xml";
            std::shared_ptr<Scene> grey = loadScene(kSource + "/" + scatter);
            std::shared_ptr<Scene> chromatic =
                loadVariant(scatter, "chromatic", R"(<color name="sigmaA" value="0"/>)",
                            R"(<color name="sigmaA" value="0, 0, 1e-6"/>)");
            pairs.push_back({"chromatic vs grey (sigma_s 10; sigma_a 0 vs (0, 0, 1e-6))",
                             {"grey", grey},
                             {"chromatic", chromatic},
                             1 * scale,
                             0.0,
                             false});
        }
        bool ok = true;
        for (const Pair& pair : pairs)
            if (pair.name.find(filter) != std::string::npos)
                ok = measure(pair, rounds, varianceRenders) && ok;
        return ok ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
