#include "common/farm/film_codec.h"

#include "common/core/error.h"

#include <zstd.h>

namespace alphorn::farm {

std::string zstdCompress(std::string_view bytes, int level) {
    std::string out(ZSTD_compressBound(bytes.size()), '\0');
    size_t size = ZSTD_compress(out.data(), out.size(), bytes.data(), bytes.size(), level);
    if (ZSTD_isError(size)) fail("zstd compression failed: %s", ZSTD_getErrorName(size));
    out.resize(size);
    return out;
}

std::string zstdDecompress(std::string_view compressed, uint64_t maxBytes) {
    unsigned long long size = ZSTD_getFrameContentSize(compressed.data(), compressed.size());
    if (size == ZSTD_CONTENTSIZE_ERROR || size == ZSTD_CONTENTSIZE_UNKNOWN)
        fail("corrupt compressed data (no zstd frame size)");
    if (size > maxBytes)
        fail("compressed data expands to %llu bytes, more than the %llu allowed", size,
             static_cast<unsigned long long>(maxBytes));
    std::string out(size, '\0');
    size_t got = ZSTD_decompress(out.data(), out.size(), compressed.data(), compressed.size());
    if (ZSTD_isError(got)) fail("corrupt compressed data: %s", ZSTD_getErrorName(got));
    if (got != size) fail("corrupt compressed data: %zu bytes instead of %llu", got, size);
    return out;
}

std::string compressFilm(const FilmBlock& block) {
    return zstdCompress(block.serialize());
}

void decompressFilm(const std::string& compressed, FilmBlock& block) {
    const uint64_t expected =
        uint64_t(block.width()) * uint64_t(block.height()) * block.bytesPerPixel();
    block.deserialize(zstdDecompress(compressed, expected));
    const auto check = [](const PixelSum& sum, int x, int y) {
        for (FixedPoint value : {sum.rgb[0], sum.rgb[1], sum.rgb[2], sum.weight})
            if (value > kMaxDecodedSum || value < -kMaxDecodedSum)
                fail("film data has an impossible sum at pixel (%d, %d): beyond 2^60", x, y);
    };
    for (int y = block.y0(); y < block.y0() + block.height(); ++y)
        for (int x = block.x0(); x < block.x0() + block.width(); ++x) {
            check(block.at(x, y), x, y);
            if (block.keepsHalves()) check(block.oddAt(x, y), x, y);
            if (block.keepsSmallerRadius()) check(block.smallerRadiusAt(x, y), x, y);
            if (block.keepsSmallerRadius() && block.keepsHalves())
                check(block.smallerRadiusOddAt(x, y), x, y);
        }
}

}  // namespace alphorn::farm
