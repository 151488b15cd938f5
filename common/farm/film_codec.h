// Film blocks on the wire and on disk: the exact fixed-point sums, zstd-compressed. Most of a
// block's 128-bit integers have zero high words, so compression typically shrinks them 4-8x.
#pragma once

#include "common/render/film.h"

#include <string>

namespace alphorn::farm {

std::string compressFilm(const FilmBlock& block);
// Fills `block` (already of the right shape) from compressFilm's output; throws Error on
// corrupt data or a shape mismatch.
void decompressFilm(const std::string& compressed, FilmBlock& block);

std::string zstdCompress(std::string_view bytes, int level = 1);
// Throws Error when the data is corrupt or would exceed `maxBytes` decompressed.
std::string zstdDecompress(std::string_view compressed, uint64_t maxBytes);

}  // namespace alphorn::farm
