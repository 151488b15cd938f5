#include "common/render/film.h"

#include "common/core/error.h"
#include "common/core/rng.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

// Adding blocks in different orders must give identical sums: the merge that lets a farm render
// equal a local one. Float sums of the same values in a different order would differ.
TEST(FilmBlock, MergeIsIndependentOfOrder) {
    std::vector<FilmBlock> parts;
    Rng rng(1, 2, 3, StreamPurpose::Test);
    for (int i = 0; i < 8; ++i) {
        FilmBlock block(-2 + i, -1, 6, 5);
        for (int y = block.y0(); y < block.y0() + block.height(); ++y)
            for (int x = block.x0(); x < block.x0() + block.width(); ++x) {
                PixelSum& s = block.at(x, y);
                s.rgb[0] = toFixedPoint(std::exp(20.0 * rng.nextDouble() - 10.0));
                s.weight = toFixedPoint(rng.nextDouble());
            }
        parts.push_back(block);
    }
    FilmBlock forward(0, 0, 10, 4), backward(0, 0, 10, 4);
    for (size_t i = 0; i < parts.size(); ++i) forward.add(parts[i]);
    for (size_t i = parts.size(); i-- > 0;) backward.add(parts[i]);
    EXPECT_EQ(forward.serialize(), backward.serialize());
    EXPECT_NE(forward.at(3, 2).weight, 0);
}

TEST(FilmBlock, SerializeRoundTripsAndRejectsWrongSize) {
    FilmBlock a(3, 4, 5, 6);
    a.at(4, 5).rgb[1] = toFixedPoint(1.25);
    FilmBlock b(3, 4, 5, 6);
    b.deserialize(a.serialize());
    EXPECT_EQ(fromFixedPoint(b.at(4, 5).rgb[1]), 1.25);
    FilmBlock c(0, 0, 2, 2);
    EXPECT_THROW(c.deserialize(a.serialize()), Error);
}

// Samples of odd passes count in the totals and the odd half, even passes in the totals only;
// adding films adds both, and the halves survive serialization.
TEST(FilmBlock, KeepsTheOddPassesHalf) {
    FilmBlock even(0, 0, 2, 1, PassHalves::None), odd(0, 0, 2, 1, PassHalves::None);
    even.at(0, 0).rgb[0] = toFixedPoint(1.0);
    even.at(0, 0).weight = toFixedPoint(1.0);
    odd.at(0, 0).rgb[0] = toFixedPoint(3.0);
    odd.at(0, 0).weight = toFixedPoint(2.0);
    FilmBlock unit(0, 0, 2, 1);
    unit.addPassesOfParity(even, false);
    unit.addPassesOfParity(odd, true);
    EXPECT_EQ(unit.at(0, 0).rgb[0], toFixedPoint(4.0));
    EXPECT_EQ(unit.oddAt(0, 0).rgb[0], toFixedPoint(3.0));
    EXPECT_EQ(unit.oddAt(0, 0).weight, toFixedPoint(2.0));
    FilmBlock film(-1, 0, 4, 1);
    film.add(unit);
    film.add(unit);
    EXPECT_EQ(film.at(0, 0).weight, toFixedPoint(6.0));
    EXPECT_EQ(film.oddAt(0, 0).weight, toFixedPoint(4.0));
    FilmBlock back(-1, 0, 4, 1);
    back.deserialize(film.serialize());
    EXPECT_EQ(back.serialize(), film.serialize());
    EXPECT_EQ(back.oddAt(0, 0).rgb[0], toFixedPoint(6.0));
    EXPECT_EQ(film.serialize().size(), 4u * 2 * sizeof(PixelSum));
}

// A film that keeps halves cannot take samples it cannot split; one without halves takes any.
TEST(FilmBlock, RefusesToMixFilmsWithoutHalvesIntoHalves) {
    FilmBlock withHalves(0, 0, 2, 2), without(0, 0, 2, 2, PassHalves::None);
    EXPECT_THROW(withHalves.add(without), Error);
    without.add(withHalves);
    EXPECT_FALSE(without.keepsHalves());
}

// Data of an older Alphorn (totals only) gets a message saying so, not a bare size mismatch.
TEST(FilmBlock, OldFormatWithoutHalvesIsNamed) {
    FilmBlock old(0, 0, 3, 2, PassHalves::None);
    FilmBlock current(0, 0, 3, 2);
    try {
        current.deserialize(old.serialize());
        FAIL() << "totals without halves were accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("no pass halves"), std::string::npos) << e.what();
    }
}

TEST(FilmBlock, ResolveDividesByWeight) {
    FilmBlock film(0, 0, 2, 1);
    film.at(1, 0).rgb[0] = toFixedPoint(3.0);
    film.at(1, 0).rgb[1] = toFixedPoint(1.5);
    film.at(1, 0).weight = toFixedPoint(1.5);
    Image image = resolveImage(film, 2, 1);
    EXPECT_EQ(image.get(0, 0).r(), 0.0f);  // no weight: black, not NaN
    EXPECT_EQ(image.get(1, 0).r(), 2.0f);
    EXPECT_EQ(image.get(1, 0).g(), 1.0f);
}

// Both conversion paths (through int64 and the full 128-bit one) round to the same integer.
TEST(FixedPoint, ConversionIsExactOnBothSidesOfThe64BitFastPath) {
    for (double v : {0.0, 1.0, -2.5, 0.1, 1e-12, 4.0e6, 4.2e6, -4.2e6, 1e9, 3.7e13}) {
        const FixedPoint fixed = toFixedPoint(v);
        const long double expected = std::nearbyint(static_cast<long double>(v) * 0x1p40L);
        EXPECT_EQ(static_cast<long double>(fixed), expected) << v;
        EXPECT_EQ(fromFixedPoint(fixed), std::nearbyint(v * 0x1p40) / 0x1p40) << v;
    }
    // 2^22 * 2^40 = 2^62 is the first value beyond the fast path.
    EXPECT_EQ(toFixedPoint(0x1p22), FixedPoint(1) << 62);
    EXPECT_EQ(toFixedPoint(-0x1p22), -(FixedPoint(1) << 62));
}

// The inline rounding below 2^52 gives nearbyint's integer for every value: halves go to the
// even neighbour (2.5 -> 2, 3.5 -> 4, on both signs), and values just either side of a half, of
// every magnitude up to the 2^52 boundary, round as nearbyint does.
TEST(FixedPoint, RoundsLikeNearbyintBelowAndAbove2To52) {
    auto reference = [](double v) { return static_cast<FixedPoint>(std::nearbyint(v * 0x1p40)); };
    for (double half : {0.5, 1.5, 2.5, 3.5, 1e6 + 0.5, 0x1p51 + 0.5, 0x1p51 + 1.5}) {
        for (double sign : {1.0, -1.0}) {
            const double v = sign * half * 0x1p-40;
            EXPECT_EQ(toFixedPoint(v), reference(v)) << v * 0x1p40;
        }
    }
    EXPECT_EQ(toFixedPoint(2.5 * 0x1p-40), 2);
    EXPECT_EQ(toFixedPoint(-3.5 * 0x1p-40), -4);
    Rng rng(4, 5, 6, StreamPurpose::Test);
    for (int i = 0; i < 100000; ++i) {
        // Magnitudes from 2^-60 to 2^21 (2^61 after scaling), so both sides of 2^52.
        const double magnitude = std::exp2(81.0 * rng.nextDouble() - 60.0);
        const double v = rng.nextFloat() < 0.5f ? -magnitude : magnitude;
        ASSERT_EQ(toFixedPoint(v), reference(v)) << v;
        const double nearHalf =
            std::nextafter((std::floor(magnitude * 0x1p40) + 0.5) * 0x1p-40, i % 2 ? 0.0 : 1.0);
        ASSERT_EQ(toFixedPoint(nearHalf), reference(nearHalf)) << nearHalf;
    }
}

// The smaller radius's sums: kept beside the image's, merged, split by parity and serialised
// (image totals, odd half, then the smaller radius's totals and odd half), and refused where a
// film keeps them and the other does not.
TEST(FilmBlock, SmallerRadiusSumsAreMergedAndSerialised) {
    FilmBlock film(0, 0, 2, 1, PassHalves::Kept, SmallerRadius::Kept);
    FilmBlock odd(0, 0, 2, 1, PassHalves::None, SmallerRadius::Kept);
    odd.at(1, 0).weight = toFixedPoint(1.0);
    odd.smallerRadiusAt(1, 0).weight = toFixedPoint(2.0);
    FilmBlock even(0, 0, 2, 1, PassHalves::None, SmallerRadius::Kept);
    even.smallerRadiusAt(1, 0).weight = toFixedPoint(3.0);
    film.addPassesOfParity(odd, true);
    film.addPassesOfParity(even, false);
    EXPECT_EQ(film.at(1, 0).weight, toFixedPoint(1.0));
    EXPECT_EQ(film.smallerRadiusAt(1, 0).weight, toFixedPoint(5.0));
    EXPECT_EQ(film.smallerRadiusOddAt(1, 0).weight, toFixedPoint(2.0));
    FilmBlock sum(0, 0, 2, 1, PassHalves::Kept, SmallerRadius::Kept);
    sum.add(film);
    sum.add(film);
    EXPECT_EQ(sum.smallerRadiusAt(1, 0).weight, toFixedPoint(10.0));
    EXPECT_EQ(sum.smallerRadiusOddAt(1, 0).weight, toFixedPoint(4.0));
    EXPECT_EQ(film.bytesPerPixel(), 4 * sizeof(PixelSum));
    const std::string bytes = film.serialize();
    ASSERT_EQ(bytes.size(), 2 * 4 * sizeof(PixelSum));
    FilmBlock back(0, 0, 2, 1, PassHalves::Kept, SmallerRadius::Kept);
    back.deserialize(bytes);
    EXPECT_EQ(back.serialize(), bytes);
    EXPECT_EQ(back.smallerRadiusOddAt(1, 0).weight, toFixedPoint(2.0));
    const FilmBlock smaller = film.smallerRadiusFilm();
    EXPECT_EQ(smaller.at(1, 0).weight, toFixedPoint(5.0));
    EXPECT_EQ(smaller.oddAt(1, 0).weight, toFixedPoint(2.0));
    // The image part of the bytes is what a film without the smaller radius serialises.
    FilmBlock imageOnly(0, 0, 2, 1);
    imageOnly.add(film);
    EXPECT_EQ(bytes.substr(0, imageOnly.serialize().size()), imageOnly.serialize());
    EXPECT_THROW(film.add(imageOnly), Error);
    EXPECT_THROW(film.addPassesOfParity(FilmBlock(0, 0, 2, 1, PassHalves::None), true), Error);
}

// Data without the smaller radius's sums where they are expected is named as such.
TEST(FilmBlock, DataWithoutTheSmallerRadiusIsNamed) {
    FilmBlock old(0, 0, 3, 2);
    FilmBlock current(0, 0, 3, 2, PassHalves::Kept, SmallerRadius::Kept);
    try {
        current.deserialize(old.serialize());
        FAIL() << "film data without the smaller radius was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("no smaller radius"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace alphorn
