#include "common/core/rng.h"
#include "common/filter/rfilter.h"
#include "common/render/film.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <utility>
#include <vector>

namespace alphorn {
namespace {

std::shared_ptr<ReconstructionFilter> makeFilter(
    const std::string& type, std::initializer_list<std::pair<const char*, float>> floats = {}) {
    PropertyList props("test");
    for (const auto& [name, value] : floats) props.setFloat(name, value);
    auto filter = std::static_pointer_cast<ReconstructionFilter>(
        ObjectFactory::create(ObjectKind::Filter, type, props));
    filter->activate();
    return filter;
}

// A tap's fixed-point integer computed apart from the film: a float times a float is exact in
// long double (48 significant bits of its 64), and so is its scaling by 2^40; nearbyintl rounds
// it to the nearest integer, halves to even.
FixedPoint exactlyRounded(float w, float value) {
    return static_cast<FixedPoint>(
        std::nearbyintl(static_cast<long double>(w) * static_cast<long double>(value) * 0x1p40L));
}

// The taps of a sample as the film defines them: every pixel whose centre lies within the
// filter's reach, weighted weight(dx) * weight(dy) in float.
template <typename F>
void forEachReferenceTap(const ReconstructionFilter& filter, const Point2f& position, F&& f) {
    const float radius = filter.radius();
    const float px = position.x() - 0.5f, py = position.y() - 0.5f;
    for (int y = static_cast<int>(std::ceil(py - radius)); y <= std::floor(py + radius); ++y)
        for (int x = static_cast<int>(std::ceil(px - radius)); x <= std::floor(px + radius); ++x) {
            const float w = filter.weight(static_cast<float>(x) - px) *
                            filter.weight(static_cast<float>(y) - py);
            if (w != 0.0f) f(x, y, w);
        }
}

void referenceSplat(FilmBlock& block, const ReconstructionFilter& filter, const Point2f& position,
                    const Color3f& value, SampleWeight weight, bool smallerRadius = false) {
    forEachReferenceTap(filter, position, [&](int x, int y, float w) {
        if (!block.contains(x, y)) return;
        PixelSum& sum = smallerRadius ? block.smallerRadiusAt(x, y) : block.at(x, y);
        for (int c = 0; c < 3; ++c) sum.rgb[c] += exactlyRounded(w, value[c]);
        if (weight == SampleWeight::Counted) sum.weight += exactlyRounded(w, 1.0f);
    });
}

// Channels from 2^-30 to 2^24, and zero: both sides of kFixedPointSampleLimit (2^22, where the
// splat leaves its 64-bit rounding) and of 2^23 (where w * value * 2^40 passes 2^63).
Color3f randomValue(Rng& rng) {
    Color3f value;
    for (int c = 0; c < 3; ++c)
        value[c] = rng.nextFloat() < 0.05f
                       ? 0.0f
                       : static_cast<float>(std::exp2(54.0 * rng.nextDouble() - 30.0));
    return value;
}

void expectSameSums(const FilmBlock& a, const FilmBlock& b, const std::string& what) {
    for (int y = a.y0(); y < a.y0() + a.height(); ++y)
        for (int x = a.x0(); x < a.x0() + a.width(); ++x) {
            for (int c = 0; c < 3; ++c)
                ASSERT_TRUE(a.at(x, y).rgb[c] == b.at(x, y).rgb[c])
                    << what << " pixel " << x << "," << y << " channel " << c << ": "
                    << double(a.at(x, y).rgb[c]) << " != " << double(b.at(x, y).rgb[c]);
            ASSERT_TRUE(a.at(x, y).weight == b.at(x, y).weight)
                << what << " pixel " << x << "," << y << " weight";
        }
}

// Every tap adds w * value per channel (and w to the weight) rounded to the nearest multiple of
// 2^-40, halves to even, exactly as if each product were rounded on its own in exact arithmetic:
// with the Gaussian, Mitchell-Netravali's negative lobes, the box and the tent, for values far
// below 1 and for bright ones that take the 128-bit rounding. A truncating conversion, products
// formed in float, or the 64-bit rounding used beyond 2^22 each fail it.
TEST(Splat, EveryTapAddsItsProductRoundedToNearest) {
    const std::vector<std::pair<std::string, std::shared_ptr<ReconstructionFilter>>> filters = {
        {"gaussian", makeFilter("gaussian")},
        {"gaussian narrow", makeFilter("gaussian", {{"radius", 3.0f}, {"stddev", 0.1f}})},
        {"mitchell", makeFilter("mitchell", {{"B", 0.0f}, {"C", 0.5f}})},
        {"box", makeFilter("box")},
        {"tent", makeFilter("tent")}};
    Rng rng(7, 8, 9, StreamPurpose::Test);
    for (const auto& [name, filter] : filters) {
        FilmBlock film(-1, 2, 12, 10), reference(-1, 2, 12, 10);
        for (int i = 0; i < 3000; ++i) {
            // Positions reaching past the block's edges on every side.
            const Point2f position(static_cast<float>(-4.0 + 18.0 * rng.nextDouble()),
                                   static_cast<float>(-1.0 + 16.0 * rng.nextDouble()));
            const Color3f value = randomValue(rng);
            const SampleWeight weight = i % 3 ? SampleWeight::Counted : SampleWeight::NotCounted;
            splatFiltered(film, *filter, position, value, weight);
            referenceSplat(reference, *filter, position, value, weight);
        }
        expectSameSums(film, reference, name);
    }
}

// The smaller radius's sums get their value's taps, rounded alike, whether the pass radius's
// value is splatted with it or not, and whichever of the two takes the 128-bit rounding.
TEST(Splat, BothRadiiRoundEachValueOnItsOwn) {
    const auto filter = makeFilter("gaussian");
    Rng rng(10, 11, 12, StreamPurpose::Test);
    FilmBlock film(0, 0, 8, 8, PassHalves::None, SmallerRadius::Kept);
    FilmBlock reference(0, 0, 8, 8, PassHalves::None, SmallerRadius::Kept);
    for (int i = 0; i < 2000; ++i) {
        const Point2f position(static_cast<float>(8.0 * rng.nextDouble()),
                               static_cast<float>(8.0 * rng.nextDouble()));
        const Color3f value = randomValue(rng), smaller = randomValue(rng);
        if (i % 2) {
            splatFilteredTwoRadii(film, *filter, position, value, smaller);
            referenceSplat(reference, *filter, position, value, SampleWeight::Counted);
        } else {
            splatFilteredSmallerRadius(film, *filter, position, smaller);
        }
        referenceSplat(reference, *filter, position, smaller, SampleWeight::Counted, true);
    }
    expectSameSums(film, reference, "pass radius");
    expectSameSums(film.smallerRadiusFilm(), reference.smallerRadiusFilm(), "smaller radius");
}

// A sample's taps land in whichever blocks hold their pixels (a tile's block grown by the filter
// border, as render units have them), and adding the blocks in any order gives the sums of one
// block that took every sample: each tap is rounded on its own, so neither the tiling nor the
// order of the samples or of the blocks can change a bit.
TEST(Splat, SumsDoNotDependOnTilesOrOrder) {
    const auto filter = makeFilter("gaussian");
    const int size = 24, border = 2;
    Rng rng(13, 14, 15, StreamPurpose::Test);
    std::vector<std::pair<Point2f, Color3f>> samples;
    for (int i = 0; i < 4000; ++i)
        samples.emplace_back(Point2f(static_cast<float>(size * rng.nextDouble()),
                                     static_cast<float>(size * rng.nextDouble())),
                             randomValue(rng));
    FilmBlock whole(0, 0, size, size);
    for (const auto& [position, value] : samples)
        splatFiltered(whole, *filter, position, value, SampleWeight::Counted);
    for (int tile : {5, 8, 24}) {
        std::vector<FilmBlock> blocks;
        for (int y0 = 0; y0 < size; y0 += tile)
            for (int x0 = 0; x0 < size; x0 += tile)
                blocks.emplace_back(x0 - border, y0 - border, tile + 2 * border, tile + 2 * border);
        // The samples in reverse order, each into the block of the tile it lies in.
        for (auto it = samples.rbegin(); it != samples.rend(); ++it) {
            const int tx = static_cast<int>(it->first.x()) / tile,
                      ty = static_cast<int>(it->first.y()) / tile;
            const int tilesPerRow = (size + tile - 1) / tile;
            splatFiltered(blocks[ty * tilesPerRow + tx], *filter, it->first, it->second,
                          SampleWeight::Counted);
        }
        FilmBlock forward(0, 0, size, size), backward(0, 0, size, size);
        for (const FilmBlock& block : blocks) forward.add(block);
        for (auto it = blocks.rbegin(); it != blocks.rend(); ++it) backward.add(*it);
        expectSameSums(forward, whole, "tiles of " + std::to_string(tile));
        expectSameSums(backward, whole, "tiles of " + std::to_string(tile) + ", reversed");
    }
}

// A thread's scratch block, added into a film, gives the sums of splatting into the film itself,
// bit for bit: where the 64-bit sums overflow (bright samples just below 2^22 piled on a few
// pixels: three of their centre taps pass 2^63), with Mitchell-Netravali's negative taps among
// them, for samples of 2^22 and more that go to the 128-bit sums at once, for uncounted
// weights, both parities and the smaller radius's sums. Wrapping sums, a tap split between the
// two kinds of sums or a lost overflow each fail it.
TEST(Splat, ScratchBlocksGiveTheFilmsSums) {
    const std::vector<std::pair<std::string, std::shared_ptr<ReconstructionFilter>>> filters = {
        {"gaussian", makeFilter("gaussian")},
        {"mitchell", makeFilter("mitchell", {{"B", 0.0f}, {"C", 0.5f}})},
        {"box", makeFilter("box")}};
    Rng rng(19, 20, 21, StreamPurpose::Test);
    for (const auto& [name, filter] : filters) {
        for (const SmallerRadius smallerRadius : {SmallerRadius::None, SmallerRadius::Kept}) {
            const bool twoRadii = smallerRadius == SmallerRadius::Kept;
            FilmBlock film(-1, 2, 9, 8, PassHalves::Kept, smallerRadius);
            FilmBlock direct(-1, 2, 9, 8, PassHalves::Kept, smallerRadius);
            ScratchBlock scratch[2] = {ScratchBlock(-3, 0, 13, 12, smallerRadius),
                                       ScratchBlock(-3, 0, 13, 12, smallerRadius)};
            for (int i = 0; i < 3000; ++i) {
                const int parity = i % 2;
                // Half the samples on a 2 x 2 pixel patch, so that bright taps pile up.
                const Point2f position =
                    i % 4 < 2 ? Point2f(static_cast<float>(3.0 + 2.0 * rng.nextDouble()),
                                        static_cast<float>(5.0 + 2.0 * rng.nextDouble()))
                              : Point2f(static_cast<float>(-4.0 + 16.0 * rng.nextDouble()),
                                        static_cast<float>(-1.0 + 14.0 * rng.nextDouble()));
                Color3f value = randomValue(rng);
                if (i % 3 == 0)
                    for (int c = 0; c < 3; ++c)
                        value[c] = static_cast<float>((1.0 - 1e-3 * rng.nextDouble()) * 0x1p22);
                const Color3f smaller = randomValue(rng);
                FilmBlock odd(-1, 2, 9, 8, PassHalves::None, smallerRadius);
                if (twoRadii) {
                    splatFilteredTwoRadii(scratch[parity], *filter, position, value, smaller);
                    splatFilteredTwoRadii(odd, *filter, position, value, smaller);
                } else {
                    const SampleWeight weight =
                        i % 5 ? SampleWeight::Counted : SampleWeight::NotCounted;
                    splatFiltered(scratch[parity], *filter, position, value, weight);
                    splatFiltered(odd, *filter, position, value, weight);
                }
                direct.addPassesOfParity(odd, parity == 1);
            }
            for (int parity = 0; parity < 2; ++parity)
                film.addPassesOfParity(scratch[parity], parity == 1);
            const std::string what = name + (twoRadii ? ", two radii" : "");
            expectSameSums(film, direct, what);
            for (int y = film.y0(); y < film.y0() + film.height(); ++y)
                for (int x = film.x0(); x < film.x0() + film.width(); ++x)
                    for (int c = 0; c < 3; ++c)
                        ASSERT_TRUE(film.oddAt(x, y).rgb[c] == direct.oddAt(x, y).rgb[c])
                            << what << " odd half, pixel " << x << "," << y;
            if (twoRadii)
                expectSameSums(film.smallerRadiusFilm(), direct.smallerRadiusFilm(),
                               what + ", smaller radius");
        }
    }
}

// roundToInt64 rounds to the nearest integer, halves to even, on both signs and up to 2^62.
TEST(FixedPoint, RoundToInt64RoundsToNearestHalvesToEven) {
    EXPECT_EQ(roundToInt64(2.5), 2);
    EXPECT_EQ(roundToInt64(3.5), 4);
    EXPECT_EQ(roundToInt64(-2.5), -2);
    EXPECT_EQ(roundToInt64(-3.5), -4);
    EXPECT_EQ(roundToInt64(0.49999999999999994), 0);
    EXPECT_EQ(roundToInt64(-0.7), -1);
    EXPECT_EQ(roundToInt64(0x1p62), int64_t(1) << 62);
    EXPECT_EQ(roundToInt64(-0x1p62), -(int64_t(1) << 62));
    Rng rng(16, 17, 18, StreamPurpose::Test);
    for (int i = 0; i < 100000; ++i) {
        const double magnitude = std::exp2(102.0 * rng.nextDouble() - 40.0);  // 2^-40 .. 2^62
        const double v = i % 2 ? -magnitude : magnitude;
        ASSERT_EQ(roundToInt64(v), static_cast<int64_t>(std::nearbyint(v))) << v;
        const double half = std::floor(magnitude) + 0.5;
        if (half < 0x1p52) {
            ASSERT_EQ(roundToInt64(half), static_cast<int64_t>(std::nearbyint(half))) << half;
        }
    }
}

}  // namespace
}  // namespace alphorn
