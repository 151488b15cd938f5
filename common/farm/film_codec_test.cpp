// Unit-result decoding against hostile input: what the fuzz/film_codec harness found.
#include "common/farm/film_codec.h"
#include "common/core/error.h"
#include "common/farm/files.h"
#include "fuzz/fuzz_support.h"

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

// Sums near 2^127 that overflowed when the coordinator added two results into its film.
TEST(FilmCodec, FuzzCrashOverflowingSumsIsRefused) {
    const std::string input =
        readFile(std::string(ALPHORN_SOURCE_DIR) + "/fuzz/corpus/film_codec/crash_sum_overflow");
    ASSERT_GE(input.size(), fuzz::kFilmHeaderBytes);
    const fuzz::FilmShape shape =
        fuzz::filmShapeFromHeader(reinterpret_cast<const uint8_t*>(input.data()));
    FilmBlock block(shape.x0, shape.y0, shape.width, shape.height);
    EXPECT_THROW(decompressFilm(input.substr(fuzz::kFilmHeaderBytes), block), Error);
}

}  // namespace
}  // namespace alphorn::farm
