// What verifying a worker's cached blobs costs: SHA-256 throughput of farm::sha256OfFile, and
// for real scenes the time to hash every file of the scene's bundle (what a worker does at the
// first use of a cached scene after it starts) against the time to load the scene to render
// (what it does next in any case), as a ratio measured in the same round.
//
// Files are read from the page cache (they were just written or read): on a worker whose disk
// must be read first, hashing and loading both pay for the read, the hash once more than the
// load only where the load would not read the whole file.
//
// A scene's files are hashed kHashRepeats times per round and the time divided: a few hundred
// kilobytes hash in about a millisecond, less than the scheduler's noise on a shared machine.
//
// usage: bench_blob_verify [rounds=5] [throughput_mib=64] [scenes...]
// (default scenes: scenes/stage/stage.xml, tests/integration/scenes/farm_area_light.xml,
// scenes/cbox/cbox.xml)
#include "bench/timing.h"
#include "common/farm/bundle.h"
#include "common/farm/job_scene.h"
#include "common/farm/sha256.h"
#include "tests/support/source_tree.h"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <vector>

using namespace alphorn;
using bench::median;
using bench::processCpuSeconds;

namespace {

constexpr int kHashRepeats = 20;

struct Timing {
    double wall = 0, cpu = 0;
};

template <typename Work>
Timing timed(Work&& work) {
    const auto start = std::chrono::steady_clock::now();
    const double cpuStart = processCpuSeconds();
    work();
    return {bench::seconds(start), processCpuSeconds() - cpuStart};
}

// SHA-256 of a file of `mib` MiB of random bytes, `rounds` times: MB/s of wall and CPU time.
void measureThroughput(int rounds, int mib) {
    char pattern[] = "/tmp/alphorn-bench-blob-XXXXXX";
    const int descriptor = ::mkstemp(pattern);
    if (descriptor < 0) {
        std::perror("mkstemp");
        std::exit(1);
    }
    ::close(descriptor);
    const std::string path = pattern;
    {
        std::mt19937_64 random(7);
        std::vector<uint64_t> block(1 << 17);  // 1 MiB
        std::ofstream file(path, std::ios::binary);
        for (int i = 0; i < mib; ++i) {
            for (uint64_t& word : block) word = random();
            file.write(reinterpret_cast<const char*>(block.data()),
                       std::streamsize(block.size() * sizeof(uint64_t)));
        }
    }
    const double megabytes = double(mib) * 1048576.0 / 1e6;
    std::vector<double> wallRates, cpuRates;
    std::printf("sha256OfFile, %d MiB file (page cache), %d rounds\n", mib, rounds);
    for (int round = 0; round < rounds; ++round) {
        const Timing t = timed([&] { farm::sha256OfFile(path); });
        wallRates.push_back(megabytes / t.wall);
        cpuRates.push_back(megabytes / t.cpu);
        std::printf("  round %d: %.0f MB/s wall, %.0f MB/s CPU (CPU/wall %.2f)\n", round + 1,
                    megabytes / t.wall, megabytes / t.cpu, t.cpu / t.wall);
    }
    std::printf("  median: %.0f MB/s wall, %.0f MB/s CPU\n\n", median(wallRates), median(cpuRates));
    std::filesystem::remove(path);
}

void measureScene(const std::string& scenePath, int rounds) {
    const farm::Bundle bundle = farm::gatherBundle(scenePath);
    std::printf("%s: %zu files, %.1f kB\n", scenePath.c_str(), bundle.files.size(),
                double(bundle.totalSize()) / 1e3);
    std::vector<double> wallRatios, cpuRatios, hashWall, hashCpu, loadWall, loadCpu;
    for (int round = 0; round < rounds; ++round) {
        Timing hash = timed([&] {
            for (int repeat = 0; repeat < kHashRepeats; ++repeat)
                for (const farm::BundleEntry& file : bundle.files)
                    if (farm::sha256OfFile(file.sourcePath) != file.sha256) {
                        std::fprintf(stderr, "%s changed while measuring\n", file.path.c_str());
                        std::exit(1);
                    }
        });
        hash.wall /= kHashRepeats;
        hash.cpu /= kHashRepeats;
        const Timing load = timed([&] { farm::loadSceneWithIntegrator(scenePath, ""); });
        hashWall.push_back(hash.wall), hashCpu.push_back(hash.cpu);
        loadWall.push_back(load.wall), loadCpu.push_back(load.cpu);
        wallRatios.push_back(hash.wall / load.wall);
        cpuRatios.push_back(hash.cpu / load.cpu);
        std::printf(
            "  round %d: hash %.3f ms wall %.3f ms CPU (CPU/wall %.2f); load %.1f ms wall %.1f ms "
            "CPU (CPU/wall %.2f); hash/load %.2f%% wall %.2f%% CPU\n",
            round + 1, 1e3 * hash.wall, 1e3 * hash.cpu, hash.cpu / hash.wall, 1e3 * load.wall,
            1e3 * load.cpu, load.cpu / load.wall, 100 * hash.wall / load.wall,
            100 * hash.cpu / load.cpu);
    }
    std::printf(
        "  median: hash %.3f ms wall %.3f ms CPU; load %.1f ms wall %.1f ms CPU; "
        "verifying costs %.2f%% (wall) %.2f%% (CPU) of the scene load\n\n",
        1e3 * median(hashWall), 1e3 * median(hashCpu), 1e3 * median(loadWall),
        1e3 * median(loadCpu), 100 * median(wallRatios), 100 * median(cpuRatios));
}

}  // namespace

int main(int argc, char** argv) {
    const int rounds = argc > 1 ? std::atoi(argv[1]) : 5;
    const int mib = argc > 2 ? std::atoi(argv[2]) : 64;
    std::vector<std::string> scenes;
    for (int i = 3; i < argc; ++i) scenes.push_back(argv[i]);
    if (scenes.empty())
        scenes = {sourcePath("scenes/stage/stage.xml"),
                  sourcePath("tests/integration/scenes/farm_area_light.xml"),
                  sourcePath("scenes/cbox/cbox.xml")};
    if (rounds < 1 || mib < 1) {
        std::fprintf(stderr,
                     "usage: bench_blob_verify [rounds=5] [throughput_mib=64] [scenes...]\n");
        return 2;
    }
    measureThroughput(rounds, mib);
    for (const std::string& scene : scenes) measureScene(scene, rounds);
    return 0;
}
