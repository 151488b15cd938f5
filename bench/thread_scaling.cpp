// Thread scaling: how much shorter a whole render gets with N threads than with one, on the
// Cornell box with path_mis and on the progressive photon mapper.
//
// Each scene is loaded once (its Embree BVH built, as in `alphorn render`); then every round
// renders it with 1 thread and with N threads, in turns, each limited by a tbb::global_control
// exactly as `--threads` does. The speedup printed is the ratio of the two wall times of the
// same round (the machine is shared and noisy, so only ratios measured together count), and its
// median over the rounds. The process CPU time of each render is printed beside its wall time:
// CPU / wall is the number of cores the render really kept busy, which checks the claim (a
// speedup with CPU / wall near 1 would be a measurement error; a CPU / wall near N without a
// speedup would be overhead). Every render's film must be byte-identical to the first one.
//
// usage: bench_thread_scaling [threads] [rounds] [SCENE.xml PASSES]...
//   default: 2 threads, 3 rounds, scenes/cbox/cbox.xml 4, scenes/cbox/cbox_ppm.xml 4,
//   scenes/caustic/caustic.xml 8
#include "bench/timing.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <tbb/global_control.h>

#include <time.h>

#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

using namespace alphorn;
using bench::median;
using bench::processCpuSeconds;
using bench::seconds;

namespace {

struct Job {
    std::string scene;
    uint32_t passes;
};

struct Timing {
    double wall = 0.0, cpu = 0.0;
};

Timing renderWith(int threads, const Scene& scene, uint32_t passes, std::string& filmBytes) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
    const size_t allowed =
        tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism);
    if (allowed != size_t(threads))
        fail("asked for %d threads, oneTBB allows %d", threads, allowed);
    RenderSettings settings;
    settings.passes = passes;
    const double cpuStart = processCpuSeconds();
    const auto start = std::chrono::steady_clock::now();
    const FilmBlock film = renderLocal(scene, settings);
    Timing timing{seconds(start), processCpuSeconds() - cpuStart};
    filmBytes = film.serialize();
    return timing;
}

// Returns false when a film differs from the first one.
bool measure(const Job& job, int threads, int rounds) {
    std::shared_ptr<Scene> scene = loadScene(job.scene);
    std::printf("%s, %u passes, 1 vs %d threads, %d rounds\n", job.scene.c_str(), job.passes,
                threads, rounds);
    std::string reference, bytes;
    bool identical = true;
    std::vector<double> speedups;
    for (int round = 0; round < rounds; ++round) {
        const Timing one = renderWith(1, *scene, job.passes, bytes);
        if (round == 0) reference = bytes;
        identical = identical && bytes == reference;
        const Timing many = renderWith(threads, *scene, job.passes, bytes);
        identical = identical && bytes == reference;
        speedups.push_back(one.wall / many.wall);
        std::printf(
            "  round %d: 1 thread %.2f s wall, %.2f s CPU (CPU/wall %.2f); %d threads %.2f s "
            "wall, %.2f s CPU (CPU/wall %.2f); speedup %.2f\n",
            round, one.wall, one.cpu, one.cpu / one.wall, threads, many.wall, many.cpu,
            many.cpu / many.wall, speedups.back());
    }
    std::printf("  median speedup %d threads / 1 thread: %.2f (goal >= %.1f); films %s\n", threads,
                median(speedups), 0.95 * threads, identical ? "byte-identical" : "DIFFER");
    return identical;
}

}  // namespace

int main(int argc, char** argv) {
    const int threads = argc > 1 ? std::stoi(argv[1]) : 2;
    const int rounds = argc > 2 ? std::stoi(argv[2]) : 3;
    std::vector<Job> jobs;
    for (int i = 3; i + 1 < argc; i += 2)
        jobs.push_back({argv[i], static_cast<uint32_t>(std::stoul(argv[i + 1]))});
    if (jobs.empty())
        jobs = {{sourcePath("scenes/cbox/cbox.xml"), 4},
                {sourcePath("scenes/cbox/cbox_ppm.xml"), 4},
                {sourcePath("scenes/caustic/caustic.xml"), 8}};
    try {
        bool identical = true;
        for (const Job& job : jobs) identical = measure(job, threads, rounds) && identical;
        return identical ? 0 : 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "error: %s\n", e.what());
        return 1;
    }
}
