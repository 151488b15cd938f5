// CPU cost of a sampler's draws against the independent sampler's, in the same run.
//
// Every sampler draws what a camera path of path_mis draws: the stream start, the pixel and
// aperture 2D draws, then per bounce the light selection (1D), the light sample (2D), the BSDF
// sample (2D) and Russian roulette (1D). The samplers run alternately, one sampler per turn
// with the first rotating each round, on one thread; the time is this thread's CPU time.
// Each sampler's draws are also summed into a checksum of their bits, printed so that a change
// meant to make a sampler faster can show that it draws the same numbers.
//
// usage: bench_sampler_cost [streams=1000000] [rounds=5] [bounces=4]
// [samplers=independent,sobol,stratified]
#include "bench/timing.h"
#include "common/sampler/sampler.h"

#include <time.h>

#include <cstdio>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

using namespace alphorn;

namespace {

double threadCpuSeconds() {
    timespec ts{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

uint64_t bitsOf(float value) {
    uint32_t bits;
    std::memcpy(&bits, &value, sizeof(bits));
    return bits;
}

// FNV-1a-style mixing of the draws' bits: order-sensitive, so a reordered sequence differs.
struct Checksum {
    uint64_t value = 0xcbf29ce484222325ULL;
    void add(float x) { value = (value ^ bitsOf(x)) * 0x100000001b3ULL; }
};

// Draws the numbers of `streams` camera paths of one pass; returns their checksum.
uint64_t drawPaths(Sampler& sampler, uint64_t pass, uint64_t streams, int bounces) {
    Checksum sum;
    for (uint64_t stream = 0; stream < streams; ++stream) {
        sampler.startStream(7, pass, stream, StreamPurpose::Camera);
        const Point2f pixel = sampler.next2D(), aperture = sampler.next2D();
        sum.add(pixel.x()), sum.add(pixel.y()), sum.add(aperture.x()), sum.add(aperture.y());
        for (int bounce = 0; bounce < bounces; ++bounce) {
            const float selection = sampler.next1D();
            const Point2f light = sampler.next2D(), bsdf = sampler.next2D();
            const float roulette = sampler.next1D();
            sum.add(selection), sum.add(light.x()), sum.add(light.y()), sum.add(bsdf.x());
            sum.add(bsdf.y()), sum.add(roulette);
        }
    }
    return sum.value;
}

std::vector<std::string> split(const std::string& list) {
    std::vector<std::string> out;
    std::stringstream in(list);
    for (std::string item; std::getline(in, item, ',');) out.push_back(item);
    return out;
}

}  // namespace

int main(int argc, char** argv) {
    const uint64_t streams = argc > 1 ? std::stoull(argv[1]) : 1000000;
    const int rounds = argc > 2 ? std::stoi(argv[2]) : 5;
    const int bounces = argc > 3 ? std::stoi(argv[3]) : 4;
    const std::vector<std::string> types =
        split(argc > 4 ? argv[4] : "independent,sobol,stratified");
    if (types.empty() || types[0] != "independent") {
        std::fprintf(stderr, "the first sampler must be independent (the baseline)\n");
        return 2;
    }

    std::vector<std::unique_ptr<Sampler>> samplers;
    for (const std::string& type : types) {
        auto sampler = std::static_pointer_cast<Sampler>(
            ObjectFactory::create(ObjectKind::Sampler, type, PropertyList("bench_sampler_cost")));
        sampler->activate();
        samplers.push_back(sampler->clone());
    }
    const double drawsPerStream = 2 + 4.0 * bounces;
    std::printf("%llu streams a round, %d bounces (%.0f draws a stream), %d rounds, one thread\n",
                static_cast<unsigned long long>(streams), bounces, drawsPerStream, rounds);

    std::vector<std::vector<double>> cpu(types.size()), ratio(types.size());
    std::vector<uint64_t> checksum(types.size(), 0);
    for (int round = 0; round < rounds; ++round) {
        std::vector<double> times(types.size());
        for (size_t turn = 0; turn < types.size(); ++turn) {
            const size_t i = (turn + size_t(round)) % types.size();
            const double start = threadCpuSeconds();
            checksum[i] ^= drawPaths(*samplers[i], uint64_t(round), streams, bounces);
            times[i] = threadCpuSeconds() - start;
        }
        std::printf("round %d:", round);
        for (size_t i = 0; i < types.size(); ++i) {
            cpu[i].push_back(times[i]);
            ratio[i].push_back(times[i] / times[0]);
            std::printf("  %s %.3f s", types[i].c_str(), times[i]);
        }
        std::printf("\n");
    }
    std::printf(
        "\n| sampler | ns per draw (median) | CPU time / independent's (median of rounds) | "
        "checksum |\n|---|---:|---:|---|\n");
    for (size_t i = 0; i < types.size(); ++i)
        std::printf("| %s | %.2f | %.3f | %016llx |\n", types[i].c_str(),
                    1e9 * bench::median(cpu[i]) / (double(streams) * drawsPerStream),
                    bench::median(ratio[i]), static_cast<unsigned long long>(checksum[i]));
    return 0;
}
