// Unit-result decoding against hostile input: what the fuzz/film_codec harness found.
#include "common/farm/film_codec.h"
#include "common/core/error.h"
#include "common/farm/files.h"
#include "fuzz/fuzz_support.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

namespace alphorn::farm {
namespace {

FilmBlock blockWithWeight(FixedPoint weight) {
    FilmBlock block(0, 0, 3, 2);
    block.at(2, 1).weight = weight;
    return block;
}

TEST(FilmCodec, RefusesSumsBeyondTheDecodeLimit) {
    FilmBlock back(0, 0, 3, 2);
    decompressFilm(compressFilm(blockWithWeight(kMaxDecodedSum)), back);
    EXPECT_EQ(back.at(2, 1).weight, kMaxDecodedSum);
    decompressFilm(compressFilm(blockWithWeight(-kMaxDecodedSum)), back);
    EXPECT_EQ(back.at(2, 1).weight, -kMaxDecodedSum);
    try {
        decompressFilm(compressFilm(blockWithWeight(kMaxDecodedSum + 1)), back);
        FAIL() << "a sum beyond the limit was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("impossible sum at pixel (2, 1)"), std::string::npos)
            << e.what();
    }
    EXPECT_THROW(decompressFilm(compressFilm(blockWithWeight(-kMaxDecodedSum - 1)), back), Error);
}

// The streamed compression of a film's parts is one frame of their concatenation: parts larger
// than zstd's stream buffers, empty parts and no parts at all come back byte for byte.
TEST(FilmCodec, PartsCompressToOneFrameOfTheirConcatenation) {
    std::string large(3 << 20, '\0');
    uint64_t state = 1;
    for (char& c : large) {
        state = state * 6364136223846793005ull + 1442695040888963407ull;
        c = static_cast<char>(state >> 62);  // four values: compressible, not trivially
    }
    const std::string small = "halves";
    const std::vector<std::string_view> parts{large, "", small, std::string_view(large).substr(7)};
    std::string joined;
    for (std::string_view part : parts) joined += part;
    const std::string compressed = zstdCompress(parts);
    EXPECT_LT(compressed.size(), joined.size() / 2);
    EXPECT_EQ(zstdDecompress(compressed, joined.size()), joined);
    EXPECT_EQ(zstdDecompress(zstdCompress(std::vector<std::string_view>{}), 0), "");
    // A film with every kind of sum: its parts are serialize()'s bytes, and it comes back whole.
    FilmBlock film(0, 0, 5, 3, PassHalves::Kept, SmallerRadius::Kept);
    film.at(4, 2).weight = 7;
    film.oddAt(0, 1).rgb[1] = -3;
    film.smallerRadiusAt(1, 1).rgb[2] = 11;
    film.smallerRadiusOddAt(3, 0).weight = 5;
    EXPECT_EQ(film.serializedParts().size(), 4u);
    FilmBlock back(0, 0, 5, 3, PassHalves::Kept, SmallerRadius::Kept);
    decompressFilm(compressFilm(film), back);
    EXPECT_EQ(back.serialize(), film.serialize());
    EXPECT_EQ(back.smallerRadiusOddAt(3, 0).weight, 5);
}

// Sums near 2^127 that overflowed when the coordinator added two results into its film.
TEST(FilmCodec, FuzzCrashOverflowingSumsIsRefused) {
    const std::string input = readFile(sourcePath("fuzz/corpus/film_codec/crash_sum_overflow"));
    ASSERT_GE(input.size(), fuzz::kFilmHeaderBytes);
    const fuzz::FilmShape shape =
        fuzz::filmShapeFromHeader(reinterpret_cast<const uint8_t*>(input.data()));
    FilmBlock block(shape.x0, shape.y0, shape.width, shape.height);
    EXPECT_THROW(decompressFilm(input.substr(fuzz::kFilmHeaderBytes), block), Error);
}

}  // namespace
}  // namespace alphorn::farm
