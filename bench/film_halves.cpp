// What the film's second half (the odd passes' sums, for the error estimate) costs in memory and
// on the wire: the compressed size of unit results with the halves against the same totals
// without them, for units of 1, 4 and 16 passes of the Cornell box (path_mis) in 64-pixel tiles.
// Sizes are exact (no timing): the figures are in bench/RESULTS.md.
//
// usage: bench_film_halves [SCENE.xml]   (default: scenes/cbox/cbox.xml at 256x256)
#include "common/farm/film_codec.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <cstdio>
#include <string>

using namespace alphorn;

int main(int argc, char** argv) {
    const std::string path = argc > 1 ? argv[1] : sourcePath("scenes/cbox/cbox.xml");
    SceneOverrides overrides;
    if (argc <= 1) overrides.imageSize = Vector2i(256, 256);
    const std::shared_ptr<Scene> scene = loadScene(path, {}, overrides);
    std::printf("in memory: %zu bytes per pixel with the halves, %zu without (x%.2f)\n",
                FilmBlock(0, 0, 1, 1).bytesPerPixel(),
                FilmBlock(0, 0, 1, 1, PassHalves::None).bytesPerPixel(),
                double(FilmBlock(0, 0, 1, 1).bytesPerPixel()) /
                    double(FilmBlock(0, 0, 1, 1, PassHalves::None).bytesPerPixel()));
    const Tile tile{64, 64, 128, 128};
    std::printf("%-8s %14s %14s %8s\n", "passes", "with halves", "totals only", "ratio");
    for (uint32_t passes : {1u, 4u, 16u}) {
        // Units starting at pass 1: a one-pass unit holds an odd pass, its odd half equal to the
        // totals (the costlier case; an even pass leaves the half zero).
        const RenderUnit unit{1, 1 + passes, tile};
        FilmBlock block = makeUnitBlock(*scene, tile);
        renderUnit(*scene, 7, unit, preparePasses(*scene, 7, unit.passBegin, unit.passEnd), block);
        FilmBlock totals(block.x0(), block.y0(), block.width(), block.height(), PassHalves::None);
        totals.add(block);
        const size_t with = farm::compressFilm(block).size();
        const size_t without = farm::compressFilm(totals).size();
        std::printf("%-8u %14zu %14zu %8.2f\n", passes, with, without, double(with) / without);
    }
    return 0;
}
