// Allocating and zeroing image-sized buffers: the ordinary allocator (4 KiB pages, a page fault
// each on first touch) against HugePageAllocator (2 MiB pages), alternating in one run.
//
// Each allocation runs in a fresh child process: a render allocates its film once, at start, and
// glibc keeps a freed buffer below 32 MiB for reuse, so a second allocation in the same process
// would measure memory already faulted in.
//
// The buffer is a film of the given size with its odd passes' sums (what a render's or a job's
// film holds) and, with --photons, a pass's photon array of that many photons. The time is the
// construction (zero-filled, as FilmBlock and a resized photon vector are) plus the release.
//
// usage: bench_large_buffers [WIDTH HEIGHT] [PHOTONS] [ROUNDS]
#include "bench/timing.h"
#include "common/core/huge_page_allocator.h"
#include "common/photon/photon.h"
#include "common/render/film.h"

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <vector>

using namespace alphorn;
using bench::median;
using bench::seconds;

namespace {

// Milliseconds to allocate `count` zeroed records with vector type V, touch them and free them,
// measured in a child process of its own.
template <typename V>
double allocationMilliseconds(size_t count) {
    int channel[2];
    if (pipe(channel) != 0) {
        std::perror("pipe");
        std::exit(1);
    }
    const pid_t child = fork();
    if (child < 0) {
        std::perror("fork");
        std::exit(1);
    }
    if (child == 0) {
        const auto start = std::chrono::steady_clock::now();
        {
            V buffer(count);
            // Keep the zeroing from being elided: read one byte per page.
            volatile unsigned char sink = 0;
            const auto* bytes = reinterpret_cast<const unsigned char*>(buffer.data());
            for (size_t i = 0; i < count * sizeof(buffer[0]); i += 4096) sink = sink + bytes[i];
        }
        const double milliseconds = 1e3 * seconds(start);
        const bool written = write(channel[1], &milliseconds, sizeof milliseconds) ==
                             static_cast<ssize_t>(sizeof milliseconds);
        _exit(written ? 0 : 1);
    }
    close(channel[1]);
    double milliseconds = -1.0;
    const bool read = ::read(channel[0], &milliseconds, sizeof milliseconds) ==
                      static_cast<ssize_t>(sizeof milliseconds);
    close(channel[0]);
    int status = 0;
    waitpid(child, &status, 0);
    if (!read || !WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        std::fprintf(stderr, "the measuring child process failed\n");
        std::exit(1);
    }
    return milliseconds;
}

template <typename T>
void compare(const char* what, size_t count, int rounds) {
    std::vector<double> ordinary, huge;
    for (int round = 0; round < rounds; ++round) {
        ordinary.push_back(allocationMilliseconds<std::vector<T>>(count));
        huge.push_back(allocationMilliseconds<HugePageVector<T>>(count));
    }
    const double a = median(ordinary), b = median(huge);
    std::printf("%s (%.1f MiB): ordinary %.2f ms, huge pages %.2f ms (medians of %d), ratio %.3f\n",
                what, double(count * sizeof(T)) / (1 << 20), a, b, rounds, b / a);
}

}  // namespace

int main(int argc, char** argv) {
    const int width = argc > 2 ? std::atoi(argv[1]) : 512;
    const int height = argc > 2 ? std::atoi(argv[2]) : 512;
    const long photons = argc > 3 ? std::atol(argv[3]) : 1200000;
    const int rounds = argc > 4 ? std::atoi(argv[4]) : 9;
    if (width <= 0 || height <= 0 || photons <= 0 || rounds <= 0) {
        std::fprintf(stderr, "usage: bench_large_buffers [WIDTH HEIGHT] [PHOTONS] [ROUNDS]\n");
        return 2;
    }
    // A film with halves is two arrays of PixelSum of the image's size.
    compare<PixelSum>("film sums, one of two arrays", size_t(width) * height, rounds);
    compare<Photon>("a pass's photons", size_t(photons), rounds);
    return 0;
}
