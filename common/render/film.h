// Exact, order-independent accumulation of filtered samples.
//
// A sample's filtered contribution (weight w, and w times radiance per channel) is rounded once
// to a 128-bit fixed-point integer with 40 fractional bits, and from then on only integer sums
// are formed. Integer addition is associative, so the image does not depend on the order in
// which threads, tiles or workers add their parts: this is how a render on one machine, on two
// workers, or with a worker killed midway gives the same bytes (see
// docs/architecture.md for why this beats a canonical merge order).
//
// Beside the sums of all passes a film keeps the sums of its odd passes (passes 1, 3, 5, ...),
// also exact; the even passes' sums are the difference. The two halves are independent
// renders of the same image, and their difference measures its noise (error_estimate.h).
// A film of a progressive photon mapper may also keep the same sums for the image gathered at
// the smaller radius r_i / sqrt(2) of every pass, totals and odd half: the difference of the two
// radii's images measures the radius's bias (estimateRelativeBiasTwoRadii).
#pragma once

#include "common/core/color.h"
#include "common/core/huge_page_allocator.h"
#include "common/core/image.h"

#include <cmath>
#include <cstdint>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace alphorn {

using FixedPoint = __int128;

inline constexpr double kFixedPointScale = 0x1p40;
// |contribution| above this would overflow after summing ~2^40 samples; such samples are
// counted as invalid rather than silently clamped.
inline constexpr double kFixedPointLimit = 0x1p46;
// A sample whose every channel is below this has all its taps' contributions below 2^62 (filter
// weights are at most 1 in magnitude): they round to fixed point through 64-bit integers.
inline constexpr double kFixedPointSampleLimit = 0x1p22;

struct PixelSum {
    FixedPoint rgb[3] = {0, 0, 0};
    FixedPoint weight = 0;

    PixelSum& operator+=(const PixelSum& o) {
        for (int c = 0; c < 3; ++c) rgb[c] += o.rgb[c];
        weight += o.weight;
        return *this;
    }
};

inline FixedPoint toFixedPoint(double value) {
    const double scaled = value * kFixedPointScale;
    const double magnitude = std::abs(scaled);
    // std::nearbyint is a libm call on x86-64 (its inline form needs SSE4.1). Below 2^52,
    // adding and subtracting 2^52 rounds to the nearest integer, ties to even, exactly as
    // nearbyint does in the default rounding mode; from 2^52 on every double is an integer.
    if (magnitude < 0x1p52) {
        const double rounded = (magnitude + 0x1p52) - 0x1p52;
        const int64_t integer = static_cast<int64_t>(rounded);
        return scaled < 0.0 ? -integer : integer;
    }
    // Converting a double to a 128-bit integer is a slow libgcc call; every value in range of a
    // 64-bit integer (all but absurdly bright samples) converts exactly through int64_t instead.
    if (magnitude < 0x1p62) return static_cast<int64_t>(scaled);
    return static_cast<FixedPoint>(scaled);
}
// A double rounded to the nearest 64-bit integer, ties to even, as toFixedPoint rounds:
// |scaled| must be below 2^63. On x86-64 one conversion instruction (cvtsd2si rounds in the
// current rounding mode, round to nearest unless a program changes it, which Alphorn never
// does; the addition of 2^52 in toFixedPoint relies on the same mode).
inline int64_t roundToInt64(double scaled) {
#if defined(__x86_64__)
    return _mm_cvtsd_si64(_mm_set_sd(scaled));
#else
    const double magnitude = std::abs(scaled);
    const double rounded = magnitude < 0x1p52 ? (magnitude + 0x1p52) - 0x1p52 : magnitude;
    const int64_t integer = static_cast<int64_t>(rounded);
    return scaled < 0.0 ? -integer : integer;
#endif
}
inline double fromFixedPoint(FixedPoint value) {
    return static_cast<double>(value) / kFixedPointScale;
}

// Whether a block keeps the odd passes' sums beside the totals. Blocks that hold the samples of
// passes of one parity only (a thread's scratch film) need not; a checkpoint written before the
// halves existed has none (its film has no error estimate).
enum class PassHalves : uint8_t { Kept, None };
// Whether a block keeps the sums of the image at the smaller gather radius (totals, and their
// odd half when the halves are kept). Only films of integrators that return that image
// (Integrator::estimatesBiasWithTwoRadii) keep them; every other film keeps its size and bytes.
enum class SmallerRadius : uint8_t { None, Kept };

class ScratchBlock;

// A rectangle of pixel sums: [x0, x0 + width) x [y0, y0 + height) in image pixels. The
// rectangle may reach outside the image (a tile plus its filter border).
class FilmBlock {
  public:
    FilmBlock() = default;
    FilmBlock(int x0, int y0, int width, int height, PassHalves halves = PassHalves::Kept,
              SmallerRadius smallerRadius = SmallerRadius::None);

    int x0() const { return m_x0; }
    int y0() const { return m_y0; }
    int width() const { return m_width; }
    int height() const { return m_height; }

    bool keepsHalves() const { return m_halves == PassHalves::Kept; }
    bool keepsSmallerRadius() const { return m_smallerRadius == SmallerRadius::Kept; }

    // The sums of all passes.
    PixelSum& at(int x, int y) { return m_pixels[index(x, y)]; }
    const PixelSum& at(int x, int y) const { return m_pixels[index(x, y)]; }
    // The sums of the odd passes only (keepsHalves() must hold); the even passes' sums are
    // at() minus these.
    PixelSum& oddAt(int x, int y) { return m_odd[index(x, y)]; }
    const PixelSum& oddAt(int x, int y) const { return m_odd[index(x, y)]; }
    // The smaller radius's sums of all passes and of the odd passes (keepsSmallerRadius() must
    // hold, and keepsHalves() for the odd half).
    PixelSum& smallerRadiusAt(int x, int y) { return m_smaller[index(x, y)]; }
    const PixelSum& smallerRadiusAt(int x, int y) const { return m_smaller[index(x, y)]; }
    PixelSum& smallerRadiusOddAt(int x, int y) { return m_smallerOdd[index(x, y)]; }
    const PixelSum& smallerRadiusOddAt(int x, int y) const { return m_smallerOdd[index(x, y)]; }
    // The smaller radius's sums as a film of their own (totals and odd half), for the estimates
    // that compare two films (keepsSmallerRadius() must hold).
    FilmBlock smallerRadiusFilm() const;
    bool contains(int x, int y) const {
        return x >= m_x0 && y >= m_y0 && x < m_x0 + m_width && y < m_y0 + m_height;
    }

    // Adds the overlapping part of another block (exact, so any order gives the same sums).
    // Throws Error when this block keeps halves or the smaller radius and the other does not:
    // its samples could not be split by pass parity, or have no smaller radius's image.
    void add(const FilmBlock& other);
    // Adds the overlapping part of a block holding samples of passes of one parity only: odd
    // passes count in both the totals and the odd half, even passes in the totals only.
    void addPassesOfParity(const FilmBlock& samples, bool oddPasses);
    void addPassesOfParity(const ScratchBlock& samples, bool oddPasses);
    void clear();
    // Copies rows [yBegin, yEnd) of every sum `from` holds; `from` has this block's rectangle
    // and layout (halves, smaller radius).
    void copyRows(const FilmBlock& from, int yBegin, int yEnd);

    // Bytes per pixel of serialize(): the totals, the odd half when kept, and the smaller
    // radius's totals and odd half when kept.
    size_t bytesPerPixel() const {
        return sizeof(PixelSum) * (keepsHalves() ? 2 : 1) * (keepsSmallerRadius() ? 2 : 1);
    }
    // Raw little-endian bytes of the sums (all totals, then the odd half when kept, then the
    // smaller radius's totals and odd half when kept), for checkpoints and the wire.
    std::string serialize() const;
    // The byte ranges serialize() concatenates, in its order: views of this block's sums, so that
    // a large film can be compressed or hashed without a serialized copy.
    std::vector<std::string_view> serializedParts() const;
    // Throws Error when the bytes do not describe a block of this shape and halves.
    void deserialize(const std::string& bytes);

    // Samples rejected as NaN, infinite, negative or beyond the fixed-point range (never clamped).
    uint64_t invalidSamples = 0;

  private:
    size_t index(int x, int y) const { return size_t(y - m_y0) * m_width + size_t(x - m_x0); }

    int m_x0 = 0, m_y0 = 0, m_width = 0, m_height = 0;
    PassHalves m_halves = PassHalves::Kept;
    SmallerRadius m_smallerRadius = SmallerRadius::None;
    // Image-sized films are large (32 MiB for 512 x 512 with halves): huge pages.
    using Sums = std::vector<PixelSum, HugePageAllocator<PixelSum>>;
    Sums m_pixels;
    Sums m_odd;         // empty unless the halves are kept
    Sums m_smaller;     // empty unless the smaller radius is kept
    Sums m_smallerOdd;  // empty unless both are kept
};

// A thread's scratch sums, added into a FilmBlock when its work is done: the same exact sums in
// half the memory and about half the instructions per tap. A tap below kFixedPointSampleLimit
// is a 64-bit integer, and so are the sums of such taps until one would overflow; that tap, and
// every tap of a brighter sample, goes to a block of 128-bit sums beside (made on first use), so
// nothing is rounded or lost and the total is the FilmBlock's to the bit. Passes of one parity
// only, as a thread renders them (FilmBlock::addPassesOfParity).
class ScratchBlock {
  public:
    ScratchBlock() = default;
    // An empty block that adds nothing (a parity the unit has no pass of).
    explicit ScratchBlock(SmallerRadius smallerRadius);
    ScratchBlock(int x0, int y0, int width, int height, SmallerRadius smallerRadius);

    bool keepsSmallerRadius() const { return m_smallerRadius == SmallerRadius::Kept; }

    struct Sums {
        int64_t rgb[3] = {0, 0, 0};
        int64_t weight = 0;
    };
    Sums& at(int x, int y) { return m_sums[index(x, y)]; }
    Sums& smallerRadiusAt(int x, int y) { return m_smaller[index(x, y)]; }
    // The 128-bit sums of the taps the 64-bit ones could not take (made on first use).
    FilmBlock& overflow();
    // The sums of (x, y), exactly, as a FilmBlock's pixel: the 64-bit sums plus the overflow.
    PixelSum total(int x, int y) const;
    PixelSum smallerRadiusTotal(int x, int y) const;

    int x0() const { return m_x0; }
    int y0() const { return m_y0; }
    int width() const { return m_width; }
    int height() const { return m_height; }

    // Samples rejected as NaN, infinite, negative or beyond the fixed-point range (never clamped).
    uint64_t invalidSamples = 0;

  private:
    size_t index(int x, int y) const { return size_t(y - m_y0) * m_width + size_t(x - m_x0); }

    int m_x0 = 0, m_y0 = 0, m_width = 0, m_height = 0;
    SmallerRadius m_smallerRadius = SmallerRadius::None;
    std::vector<Sums> m_sums;
    std::vector<Sums> m_smaller;  // empty unless the smaller radius is kept
    std::unique_ptr<FilmBlock> m_overflow;
};

class ReconstructionFilter;

// What a filtered sample adds to the pixels' weights: a camera sample counts its filter weight;
// a light-tracing splat adds radiance only (the pixel's weight counts the camera samples, one
// per pass, and a pass's light image estimates the same filtered integral as one such sample).
enum class SampleWeight { Counted, NotCounted };

// Adds a sample at image position `position` to the pixels within the filter's reach (Nori's
// ImageBlock::put: pixel centres sit at integer + 0.5), each product rounded once to fixed
// point. The caller rejects invalid values (NaN, infinite, negative, beyond kFixedPointLimit)
// first. `Block` is a FilmBlock or a thread's ScratchBlock (the sums are the same).
template <typename Block>
void splatFiltered(Block& block, const ReconstructionFilter& filter, const Point2f& position,
                   const Color3f& value, SampleWeight weight);
// The same into the smaller radius's sums (keepsSmallerRadius() must hold).
template <typename Block>
void splatFilteredSmallerRadius(Block& block, const ReconstructionFilter& filter,
                                const Point2f& position, const Color3f& value);
// A camera sample into both: splatFiltered(value, Counted) and splatFilteredSmallerRadius(
// smallerRadiusValue), the filter evaluated once.
template <typename Block>
void splatFilteredTwoRadii(Block& block, const ReconstructionFilter& filter,
                           const Point2f& position, const Color3f& value,
                           const Color3f& smallerRadiusValue);

// Resolves sums into an image: each pixel is sum(w L) / sum(w), computed in double from the
// exact integers and rounded once to float. Pixels with no weight are black.
Image resolveImage(const FilmBlock& film, int width, int height);

}  // namespace alphorn
