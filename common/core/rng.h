// Deterministic random numbers. Every stream is a pure function of (job seed, pass, stream id),
// where the stream id is a pixel index for camera paths and a photon index for photon paths;
// draws within a stream are sequential "dimensions". Nothing depends on threads, tiles or
// workers, which is what makes a farm render byte-identical to a local one.
#pragma once

#include <pcg_random.hpp>

#include <cstdint>

namespace alphorn {

// SplitMix64 finaliser: a bijective 64-bit mix used to derive independent stream states.
inline uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

// Purposes keep camera and photon streams of the same pass and index apart.
enum class StreamPurpose : uint64_t { Camera = 1, Photon = 2, Test = 3 };

class Rng {
  public:
    Rng() : m_pcg(0x853c49e6748fea9bULL, 0xda3e39cb94b95bdbULL) {}
    Rng(uint64_t seed, uint64_t pass, uint64_t stream, StreamPurpose purpose)
        : m_pcg(mix64(seed ^ mix64(pass ^ mix64(static_cast<uint64_t>(purpose)))), mix64(stream)) {}

    uint32_t nextUInt() { return m_pcg(); }
    uint32_t nextUInt(uint32_t bound) { return m_pcg(bound); }
    // Uniform in [0, 1): 23 random mantissa bits, so 1 is never returned and 0 is exact.
    float nextFloat() {
        uint32_t bits = (m_pcg() >> 9) | 0x3f800000u;
        float f;
        static_assert(sizeof(f) == sizeof(bits));
        __builtin_memcpy(&f, &bits, sizeof(f));
        return f - 1.0f;
    }
    double nextDouble() {
        uint64_t hi = m_pcg() >> 5;  // two statements: argument evaluation order is unspecified
        uint64_t lo = m_pcg() >> 6;
        return static_cast<double>(hi << 26 | lo) * 0x1p-53;
    }
    void advance(uint64_t delta) { m_pcg.advance(delta); }

  private:
    pcg32 m_pcg;
};

}  // namespace alphorn
