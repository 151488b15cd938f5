#include "common/farm/film_codec.h"

#include "common/core/error.h"

#include <zstd.h>

#include <memory>
#include <vector>

namespace alphorn::farm {

std::string zstdCompress(const std::vector<std::string_view>& parts, int level) {
    const std::unique_ptr<ZSTD_CCtx, size_t (*)(ZSTD_CCtx*)> context(ZSTD_createCCtx(),
                                                                     ZSTD_freeCCtx);
    if (!context) fail("zstd compression failed: out of memory");
    const auto check = [](size_t code) {
        if (ZSTD_isError(code)) fail("zstd compression failed: %s", ZSTD_getErrorName(code));
        return code;
    };
    unsigned long long total = 0;
    for (std::string_view part : parts) total += part.size();
    check(ZSTD_CCtx_setParameter(context.get(), ZSTD_c_compressionLevel, level));
    check(ZSTD_CCtx_setPledgedSrcSize(context.get(), total));
    std::string out;
    std::vector<char> buffer(ZSTD_CStreamOutSize());
    for (size_t i = 0; i <= parts.size(); ++i) {
        // After the last part, one more round with no input ends the frame.
        const bool end = i == parts.size();
        ZSTD_inBuffer in{end ? nullptr : parts[i].data(), end ? 0 : parts[i].size(), 0};
        for (;;) {
            ZSTD_outBuffer output{buffer.data(), buffer.size(), 0};
            const size_t left = check(ZSTD_compressStream2(context.get(), &output, &in,
                                                           end ? ZSTD_e_end : ZSTD_e_continue));
            out.append(buffer.data(), output.pos);
            if (end ? left == 0 : in.pos == in.size) break;
        }
    }
    return out;
}

std::string zstdCompress(std::string_view bytes, int level) {
    return zstdCompress(std::vector<std::string_view>{bytes}, level);
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
    return zstdCompress(block.serializedParts());
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
