// Film blocks on the wire and on disk: the exact fixed-point sums (the totals, then the odd
// passes' half, see film.h), zstd-compressed. Most of a block's 128-bit integers have zero high
// words, so compression typically shrinks them 4-8x. Data of an older Alphorn (totals only) is
// recognised by its size and refused with a message saying so.
#pragma once

#include "common/render/film.h"

#include <string>
#include <string_view>
#include <vector>

namespace alphorn::farm {

// The largest magnitude a decoded sum may have: 2^60 in real units, which no render reaches
// (it takes 2^14 samples at the fixed-point limit of 2^46 in one pixel), so that the coordinator
// can add 2^27 accepted blocks into one pixel before a 128-bit sum could overflow. A worker or a
// checkpoint file cannot make the coordinator's film overflow.
inline constexpr FixedPoint kMaxDecodedSum = FixedPoint(1) << 100;

std::string compressFilm(const FilmBlock& block);
// Fills `block` (already of the right shape) from compressFilm's output; throws Error on
// corrupt data, a shape mismatch or a sum beyond kMaxDecodedSum.
void decompressFilm(const std::string& compressed, FilmBlock& block);

// One zstd frame of the concatenation of `parts`, recording its size (which zstdDecompress
// needs). Streamed: neither the input's concatenation nor a worst-case output buffer is made, so
// compressing a film of a few hundred megabytes allocates only its compressed size.
std::string zstdCompress(const std::vector<std::string_view>& parts, int level = 1);
std::string zstdCompress(std::string_view bytes, int level = 1);
// Throws Error when the data is corrupt or would exceed `maxBytes` decompressed.
std::string zstdDecompress(std::string_view compressed, uint64_t maxBytes);

}  // namespace alphorn::farm
