// Fuzzes the unit-result decoder: decompressFilm() of a worker's compressed film into the block
// the coordinator expects, then what the coordinator does with an accepted block (merge into the
// job's film, resolve to an image) and a compress/decompress round trip that must be exact.
#include "common/farm/film_codec.h"
#include "common/core/error.h"
#include "fuzz/fuzz_support.h"

#include <cstdio>
#include <cstdlib>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
    using namespace alphorn;
    if (size < fuzz::kFilmHeaderBytes) return -1;
    const fuzz::FilmShape shape = fuzz::filmShapeFromHeader(data);
    const std::string compressed(fuzz::asText(data, size).substr(fuzz::kFilmHeaderBytes));
    FilmBlock block(shape.x0, shape.y0, shape.width, shape.height);
    try {
        farm::decompressFilm(compressed, block);
    } catch (const Error&) {
        return 0;
    }
    FilmBlock again(shape.x0, shape.y0, shape.width, shape.height);
    farm::decompressFilm(farm::compressFilm(block), again);
    if (again.serialize() != block.serialize()) {
        std::fprintf(stderr, "compressFilm/decompressFilm round trip changed the film\n");
        std::abort();
    }
    // The job's film: a 64x64 image, which blocks at negative offsets overlap only partly.
    FilmBlock film(0, 0, 64, 64);
    film.add(block);
    film.add(block);
    resolveImage(film, 64, 64);
    return 0;
}
