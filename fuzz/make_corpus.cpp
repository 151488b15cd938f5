// Writes the seed inputs that only the code can make -- a real bundle manifest, compressed films
// and checkpoints -- into the corpus folders given (fuzz/corpus). Usage: fuzz_make_corpus DIR
#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "coordinator/checkpoint.h"
#include "fuzz/fuzz_support.h"
#include "tests/support/source_tree.h"

#include <cstdio>

namespace {

using namespace alphorn;
namespace fs = std::filesystem;

// A block with distinct, realistic sums (positive and negative weights, as Mitchell gives).
FilmBlock sampleFilm(const fuzz::FilmShape& shape) {
    FilmBlock block(shape.x0, shape.y0, shape.width, shape.height);
    for (int y = shape.y0; y < shape.y0 + shape.height; ++y)
        for (int x = shape.x0; x < shape.x0 + shape.width; ++x) {
            PixelSum& sum = block.at(x, y);
            const double weight = 0.25 + 0.01 * ((x * 7 + y * 3) % 11) - (x == y ? 0.3 : 0.0);
            sum.weight = toFixedPoint(weight);
            for (int c = 0; c < 3; ++c) sum.rgb[c] = toFixedPoint(weight * (0.1 * c + 0.05 * x));
            // The odd passes' half: about half of the total, never exactly.
            PixelSum& odd = block.oddAt(x, y);
            odd.weight = sum.weight / 2 + (x - y);
            for (int c = 0; c < 3; ++c) odd.rgb[c] = sum.rgb[c] / 2 + c;
        }
    block.invalidSamples = 2;
    return block;
}

std::string header(uint8_t a, uint8_t b, uint8_t c, uint8_t d) {
    return std::string{char(a), char(b), char(c), char(d)};
}

void write(const fs::path& path, const std::string& bytes) {
    fs::create_directories(path.parent_path());
    fuzz::writeFile(path.string(), bytes);
    std::printf("%s (%zu bytes)\n", path.c_str(), bytes.size());
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s CORPUS_DIR\n", argv[0]);
        return 2;
    }
    const fs::path out = argv[1];

    const farm::Bundle bundle = farm::gatherBundle(alphorn::sourcePath("scenes/cbox/cbox.xml"));
    write(out / "bundle_manifest/cbox_manifest", farm::toProto(bundle).SerializeAsString());

    // Header bytes as fuzz::filmShapeFromHeader reads them: width-1, height-1, x0, y0.
    for (const std::string& head : {header(7, 5, uint8_t(-2), 3), header(31, 31, 0, 0)}) {
        const fuzz::FilmShape shape =
            fuzz::filmShapeFromHeader(reinterpret_cast<const uint8_t*>(head.data()));
        write(out / "film_codec" /
                  ("film_" + std::to_string(shape.width) + "x" + std::to_string(shape.height)),
              head + farm::compressFilm(sampleFilm(shape)));
    }

    // Header bytes as fuzz::checkpointShapeFromHeader reads them: width-1, height-1, units,
    // flags. With the checksum flag the input holds the file without its 64-byte trailer.
    const std::string path = fuzz::scratchDirectory() + "/film.ckpt";
    coordinator::writeCheckpoint(path, fuzz::kCheckpointOwner, sampleFilm({0, 0, 4, 3}),
                                 {true, false, true, true, false});
    const std::string file = farm::readFile(path);
    write(out / "checkpoint/checkpoint_4x3", header(3, 2, 5, 1) + file.substr(0, file.size() - 64));
    write(out / "checkpoint/checkpoint_4x3_with_checksum", header(3, 2, 5, 0) + file);
    return 0;
}
