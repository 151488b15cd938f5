#include "common/render/film.h"

#include "common/core/error.h"
#include "common/filter/rfilter.h"

#include <algorithm>
#include <cstring>

namespace alphorn {

FilmBlock::FilmBlock(int x0, int y0, int width, int height, PassHalves halves,
                     SmallerRadius smallerRadius)
    : m_x0(x0),
      m_y0(y0),
      m_width(width),
      m_height(height),
      m_halves(halves),
      m_smallerRadius(smallerRadius),
      m_pixels(static_cast<size_t>(width) * height),
      m_odd(halves == PassHalves::Kept ? m_pixels.size() : 0),
      m_smaller(smallerRadius == SmallerRadius::Kept ? m_pixels.size() : 0),
      m_smallerOdd(halves == PassHalves::Kept && smallerRadius == SmallerRadius::Kept
                       ? m_pixels.size()
                       : 0) {}

void FilmBlock::clear() {
    for (Sums* sums : {&m_pixels, &m_odd, &m_smaller, &m_smallerOdd})
        std::fill(sums->begin(), sums->end(), PixelSum{});
    invalidSamples = 0;
}

void FilmBlock::copyRows(const FilmBlock& from, int yBegin, int yEnd) {
    if (from.m_x0 != m_x0 || from.m_y0 != m_y0 || from.m_width != m_width ||
        from.m_height != m_height || from.m_halves != m_halves ||
        from.m_smallerRadius != m_smallerRadius)
        fail("cannot copy rows between blocks of different shapes or layouts");
    const size_t begin = size_t(yBegin - m_y0) * m_width, end = size_t(yEnd - m_y0) * m_width;
    const Sums* source[] = {&from.m_pixels, &from.m_odd, &from.m_smaller, &from.m_smallerOdd};
    Sums* target[] = {&m_pixels, &m_odd, &m_smaller, &m_smallerOdd};
    for (int i = 0; i < 4; ++i)
        if (!target[i]->empty())
            std::copy(source[i]->begin() + begin, source[i]->begin() + end,
                      target[i]->begin() + begin);
}

FilmBlock FilmBlock::smallerRadiusFilm() const {
    if (!keepsSmallerRadius()) fail("the film keeps no smaller radius's sums");
    FilmBlock film(m_x0, m_y0, m_width, m_height, m_halves);
    film.m_pixels = m_smaller;
    film.m_odd = m_smallerOdd;
    return film;
}

namespace {

// Calls f(x, y) for every pixel the two blocks share.
template <typename Other, typename F>
void forOverlap(const FilmBlock& a, const Other& b, F&& f) {
    const int xBegin = std::max(a.x0(), b.x0()),
              xEnd = std::min(a.x0() + a.width(), b.x0() + b.width());
    const int yBegin = std::max(a.y0(), b.y0()),
              yEnd = std::min(a.y0() + a.height(), b.y0() + b.height());
    for (int y = yBegin; y < yEnd; ++y)
        for (int x = xBegin; x < xEnd; ++x) f(x, y);
}

}  // namespace

void FilmBlock::add(const FilmBlock& other) {
    if (keepsHalves() && !other.keepsHalves())
        fail("cannot add a film without pass halves into one that keeps them");
    if (keepsSmallerRadius() && !other.keepsSmallerRadius())
        fail("cannot add a film without the smaller radius's sums into one that keeps them");
    if (keepsHalves())
        forOverlap(*this, other, [&](int x, int y) {
            at(x, y) += other.at(x, y);
            oddAt(x, y) += other.oddAt(x, y);
        });
    else
        forOverlap(*this, other, [&](int x, int y) { at(x, y) += other.at(x, y); });
    if (keepsSmallerRadius())
        forOverlap(*this, other, [&](int x, int y) {
            smallerRadiusAt(x, y) += other.smallerRadiusAt(x, y);
            if (keepsHalves()) smallerRadiusOddAt(x, y) += other.smallerRadiusOddAt(x, y);
        });
    invalidSamples += other.invalidSamples;
}

namespace {

// A pixel's sums in a block of one parity's samples, as 128-bit sums.
const PixelSum& passSums(const FilmBlock& samples, int x, int y) {
    return samples.at(x, y);
}
PixelSum passSums(const ScratchBlock& samples, int x, int y) {
    return samples.total(x, y);
}
const PixelSum& smallerRadiusPassSums(const FilmBlock& samples, int x, int y) {
    return samples.smallerRadiusAt(x, y);
}
PixelSum smallerRadiusPassSums(const ScratchBlock& samples, int x, int y) {
    return samples.smallerRadiusTotal(x, y);
}

template <typename Samples>
void addParity(FilmBlock& film, const Samples& samples, bool oddPasses) {
    if (film.keepsSmallerRadius() && !samples.keepsSmallerRadius())
        fail("cannot add samples without the smaller radius's sums into a film that keeps them");
    const bool odd = oddPasses && film.keepsHalves();
    forOverlap(film, samples, [&](int x, int y) {
        const PixelSum& sum = passSums(samples, x, y);
        film.at(x, y) += sum;
        if (odd) film.oddAt(x, y) += sum;
    });
    if (film.keepsSmallerRadius())
        forOverlap(film, samples, [&](int x, int y) {
            const PixelSum& sum = smallerRadiusPassSums(samples, x, y);
            film.smallerRadiusAt(x, y) += sum;
            if (odd) film.smallerRadiusOddAt(x, y) += sum;
        });
    film.invalidSamples += samples.invalidSamples;
}

}  // namespace

void FilmBlock::addPassesOfParity(const FilmBlock& samples, bool oddPasses) {
    addParity(*this, samples, oddPasses);
}

void FilmBlock::addPassesOfParity(const ScratchBlock& samples, bool oddPasses) {
    addParity(*this, samples, oddPasses);
}

static_assert(sizeof(PixelSum) == 64, "PixelSum must be four packed 128-bit integers");

std::vector<std::string_view> FilmBlock::serializedParts() const {
    // x86-64 and aarch64 are little-endian; the bytes are the in-memory integers.
    std::vector<std::string_view> parts;
    for (const Sums* sums : {&m_pixels, &m_odd, &m_smaller, &m_smallerOdd})
        if (!sums->empty())
            parts.emplace_back(reinterpret_cast<const char*>(sums->data()),
                               sums->size() * sizeof(PixelSum));
    return parts;
}

std::string FilmBlock::serialize() const {
    std::string bytes;
    bytes.reserve(m_pixels.size() * bytesPerPixel());
    for (std::string_view part : serializedParts()) bytes += part;
    return bytes;
}

void FilmBlock::deserialize(const std::string& bytes) {
    const size_t half = m_pixels.size() * sizeof(PixelSum);
    if (bytes.size() != m_pixels.size() * bytesPerPixel()) {
        if (keepsHalves() && bytes.size() == half && half != 0)
            fail(
                "film data has no pass halves (written by an older Alphorn): a %dx%d block "
                "needs %zu bytes with its odd passes' sums, got %zu",
                m_width, m_height, m_pixels.size() * bytesPerPixel(), bytes.size());
        if (keepsSmallerRadius() && bytes.size() * 2 == m_pixels.size() * bytesPerPixel() &&
            half != 0)
            fail(
                "film data has no smaller radius's sums (written by an older Alphorn): a %dx%d "
                "block of a progressive photon mapper needs %zu bytes, got %zu",
                m_width, m_height, m_pixels.size() * bytesPerPixel(), bytes.size());
        fail("film data has %zu bytes, expected %zu for a %dx%d block", bytes.size(),
             m_pixels.size() * bytesPerPixel(), m_width, m_height);
    }
    size_t offset = 0;
    for (Sums* sums : {&m_pixels, &m_odd, &m_smaller, &m_smallerOdd}) {
        if (sums->empty()) continue;
        std::memcpy(sums->data(), bytes.data() + offset, sums->size() * sizeof(PixelSum));
        offset += sums->size() * sizeof(PixelSum);
    }
}

Image resolveImage(const FilmBlock& film, int width, int height) {
    Image image(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            if (!film.contains(x, y)) continue;
            const PixelSum& s = film.at(x, y);
            if (s.weight == 0) continue;
            double w = fromFixedPoint(s.weight);
            image.set(x, y,
                      Color3f(static_cast<float>(fromFixedPoint(s.rgb[0]) / w),
                              static_cast<float>(fromFixedPoint(s.rgb[1]) / w),
                              static_cast<float>(fromFixedPoint(s.rgb[2]) / w)));
        }
    }
    return image;
}

namespace {

// Calls addTap(x, y, w) for every pixel of the block within the filter's reach with a nonzero
// weight w.
template <typename Block, typename AddTap>
void forEachTap(const Block& block, const ReconstructionFilter& filter, const Point2f& position,
                AddTap&& addTap) {
    const float radius = filter.radius();
    const float px = position.x() - 0.5f, py = position.y() - 0.5f;
    const int xBegin = static_cast<int>(std::ceil(px - radius));
    const int xEnd = static_cast<int>(std::floor(px + radius));
    const int yBegin = static_cast<int>(std::ceil(py - radius));
    const int yEnd = static_cast<int>(std::floor(py + radius));
    // The filter's radius is at most 7 pixels (rfilter.cpp), so a row has at most 15 taps.
    float wx[16];
    const int nx = std::min(16, xEnd - xBegin + 1);
    for (int i = 0; i < nx; ++i) wx[i] = filter.weight(static_cast<float>(xBegin + i) - px);
    // Only the taps inside the block.
    const int iBegin = std::max(0, block.x0() - xBegin);
    const int iEnd = std::min(nx, block.x0() + block.width() - xBegin);
    const int yFirst = std::max(yBegin, block.y0());
    const int yLast = std::min(yEnd, block.y0() + block.height() - 1);
    for (int y = yFirst; y <= yLast; ++y) {
        const float wy = filter.weight(static_cast<float>(y) - py);
        for (int i = iBegin; i < iEnd; ++i) {
            const float w = wx[i] * wy;
            if (w != 0.0f) addTap(xBegin + i, y, w);
        }
    }
}

// A sample's value as its taps add it. Every tap's w * value (exact in double: two floats'
// product) is rounded once to fixed point, as toFixedPoint rounds it. When every channel is
// below kFixedPointSampleLimit, w * value * 2^40 is below 2^62 (|w| <= 1, rfilter.h) and one
// conversion instruction rounds it (roundToInt64); brighter samples go through toFixedPoint.
// Either way a tap's integers depend on w and the value alone, so the sums do not depend on
// which block, thread or worker adds which taps.
struct SplatValue {
    explicit SplatValue(const Color3f& value) : value(value) {
        fitsInt64 = value.abs().maxCoeff() < kFixedPointSampleLimit;
        for (int c = 0; c < 3; ++c) scaled[c] = double(value[c]) * kFixedPointScale;
    }
    Color3f value;
    bool fitsInt64;
    double scaled[3];  // value * 2^40, exact
};

// The taps of samples at or above kFixedPointSampleLimit: rare, kept out of the inlined path.
[[gnu::noinline]] void addBrightTap(PixelSum& sum, double w, const Color3f& value,
                                    SampleWeight weight) {
    for (int c = 0; c < 3; ++c) sum.rgb[c] += toFixedPoint(w * double(value[c]));
    if (weight == SampleWeight::Counted) sum.weight += roundToInt64(w * kFixedPointScale);
}

inline void addTap(FilmBlock& block, bool smallerRadius, int x, int y, float w,
                   const SplatValue& value, SampleWeight weight) {
    PixelSum& sum = smallerRadius ? block.smallerRadiusAt(x, y) : block.at(x, y);
    const double wd = w;
    if (!value.fitsInt64) [[unlikely]]
        return addBrightTap(sum, wd, value.value, weight);
    for (int c = 0; c < 3; ++c) sum.rgb[c] += roundToInt64(wd * value.scaled[c]);
    if (weight == SampleWeight::Counted) sum.weight += roundToInt64(wd * kFixedPointScale);
}

// A tap the 64-bit sums cannot take, into the overflow's 128-bit sums: rare, out of line.
[[gnu::noinline]] void addOverflowTap(ScratchBlock& block, bool smallerRadius, int x, int y,
                                      double w, const Color3f& value, SampleWeight weight) {
    FilmBlock& overflow = block.overflow();
    PixelSum& sum = smallerRadius ? overflow.smallerRadiusAt(x, y) : overflow.at(x, y);
    for (int c = 0; c < 3; ++c) sum.rgb[c] += toFixedPoint(w * double(value[c]));
    if (weight == SampleWeight::Counted) sum.weight += roundToInt64(w * kFixedPointScale);
}

// The tap's integers as addTap forms them; all four go to the 64-bit sums when none of those
// overflows, else all four to the overflow (a tap is never split, so which taps overflowed
// cannot matter: every tap is counted once either way).
inline void addTap(ScratchBlock& block, bool smallerRadius, int x, int y, float w,
                   const SplatValue& value, SampleWeight weight) {
    const double wd = w;
    if (value.fitsInt64) [[likely]] {
        ScratchBlock::Sums& sum = smallerRadius ? block.smallerRadiusAt(x, y) : block.at(x, y);
        int64_t tap[4], next[4];
        for (int c = 0; c < 3; ++c) tap[c] = roundToInt64(wd * value.scaled[c]);
        tap[3] = weight == SampleWeight::Counted ? roundToInt64(wd * kFixedPointScale) : 0;
        bool overflows = false;
        for (int c = 0; c < 3; ++c)
            overflows |= __builtin_add_overflow(sum.rgb[c], tap[c], &next[c]);
        overflows |= __builtin_add_overflow(sum.weight, tap[3], &next[3]);
        if (!overflows) [[likely]] {
            for (int c = 0; c < 3; ++c) sum.rgb[c] = next[c];
            sum.weight = next[3];
            return;
        }
    }
    addOverflowTap(block, smallerRadius, x, y, wd, value.value, weight);
}

}  // namespace

template <typename Block>
void splatFiltered(Block& block, const ReconstructionFilter& filter, const Point2f& position,
                   const Color3f& value, SampleWeight weight) {
    const SplatValue v(value);
    forEachTap(block, filter, position,
               [&](int x, int y, float w) { addTap(block, false, x, y, w, v, weight); });
}

template <typename Block>
void splatFilteredSmallerRadius(Block& block, const ReconstructionFilter& filter,
                                const Point2f& position, const Color3f& value) {
    const SplatValue v(value);
    forEachTap(block, filter, position, [&](int x, int y, float w) {
        addTap(block, true, x, y, w, v, SampleWeight::Counted);
    });
}

template <typename Block>
void splatFilteredTwoRadii(Block& block, const ReconstructionFilter& filter,
                           const Point2f& position, const Color3f& value,
                           const Color3f& smallerRadiusValue) {
    const SplatValue v(value), smaller(smallerRadiusValue);
    forEachTap(block, filter, position, [&](int x, int y, float w) {
        addTap(block, false, x, y, w, v, SampleWeight::Counted);
        addTap(block, true, x, y, w, smaller, SampleWeight::Counted);
    });
}

#define ALPHORN_SPLATS_INTO(Block)                                                                \
    template void splatFiltered(Block&, const ReconstructionFilter&, const Point2f&,              \
                                const Color3f&, SampleWeight);                                    \
    template void splatFilteredSmallerRadius(Block&, const ReconstructionFilter&, const Point2f&, \
                                             const Color3f&);                                     \
    template void splatFilteredTwoRadii(Block&, const ReconstructionFilter&, const Point2f&,      \
                                        const Color3f&, const Color3f&);
ALPHORN_SPLATS_INTO(FilmBlock)
ALPHORN_SPLATS_INTO(ScratchBlock)
#undef ALPHORN_SPLATS_INTO

ScratchBlock::ScratchBlock(SmallerRadius smallerRadius) : m_smallerRadius(smallerRadius) {}

ScratchBlock::ScratchBlock(int x0, int y0, int width, int height, SmallerRadius smallerRadius)
    : m_x0(x0),
      m_y0(y0),
      m_width(width),
      m_height(height),
      m_smallerRadius(smallerRadius),
      m_sums(static_cast<size_t>(width) * height),
      m_smaller(smallerRadius == SmallerRadius::Kept ? m_sums.size() : 0) {}

FilmBlock& ScratchBlock::overflow() {
    if (!m_overflow)
        m_overflow = std::make_unique<FilmBlock>(m_x0, m_y0, m_width, m_height, PassHalves::None,
                                                 m_smallerRadius);
    return *m_overflow;
}

namespace {

PixelSum widened(const ScratchBlock::Sums& sums) {
    PixelSum sum;
    for (int c = 0; c < 3; ++c) sum.rgb[c] = sums.rgb[c];
    sum.weight = sums.weight;
    return sum;
}

}  // namespace

PixelSum ScratchBlock::total(int x, int y) const {
    PixelSum sum = widened(m_sums[index(x, y)]);
    if (m_overflow) sum += m_overflow->at(x, y);
    return sum;
}

PixelSum ScratchBlock::smallerRadiusTotal(int x, int y) const {
    PixelSum sum = widened(m_smaller[index(x, y)]);
    if (m_overflow) sum += m_overflow->smallerRadiusAt(x, y);
    return sum;
}

}  // namespace alphorn
