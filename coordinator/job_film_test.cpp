// The job film: merges add exact sums, the progress figures kept on each merge equal a recount,
// and a checkpoint restores the same film and units; an older copy never overwrites a newer one.
#include "coordinator/job_film.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

FilmBlock unitBlock(const RenderUnit& unit, int value) {
    FilmBlock block(unit.tile.x0 - 1, unit.tile.y0 - 1, unit.tile.width() + 2,
                    unit.tile.height() + 2);
    for (int y = block.y0(); y < block.y0() + block.height(); ++y)
        for (int x = block.x0(); x < block.x0() + block.width(); ++x) {
            block.at(x, y).rgb[0] = value * (x + 3 * y + 1);
            block.at(x, y).weight = 1;
        }
    return block;
}

TEST(JobFilm, ProgressKeptOnEachMergeEqualsARecount) {
    // 3 x 2 tiles, 5 passes in chunks of 2: chunks of 2, 2 and 1 passes.
    const farm::JobGrid grid(10, 7, 4, 5, 2);
    JobFilm film(grid, "");
    film.startEmpty();
    FilmBlock expected(0, 0, 10, 7);
    uint64_t samples = 0;
    // An order that completes chunk 2 first, then chunk 0.
    std::vector<uint32_t> order;
    for (uint32_t i = 0; i < grid.unitCount(); ++i)
        order.push_back((i + 2 * grid.tileCount()) % grid.unitCount());
    for (uint32_t index : order) {
        const RenderUnit unit = grid.unit(index);
        const FilmBlock block = unitBlock(unit, int(index) + 1);
        film.merge(index, block);
        expected.add(block);
        samples +=
            uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
        EXPECT_EQ(film.passesComplete(), grid.passesComplete(film.merged())) << index;
        EXPECT_EQ(film.samplesMerged(), samples);
    }
    EXPECT_TRUE(film.complete());
    EXPECT_EQ(film.passesComplete(), 5u);
    EXPECT_EQ(film.film().serialize(), expected.serialize());
    EXPECT_THROW(film.merge(0, unitBlock(grid.unit(0), 1)), Error) << "merged twice";
}

TEST(JobFilm, ACheckpointRestoresTheFilmAndNeverGoesBack) {
    const fs::path dir =
        fs::temp_directory_path() / ("alphorn_job_film_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const farm::JobGrid grid(8, 8, 4, 2, 1);
    const std::string path = (dir / "film.ckpt").string();
    JobFilm film(grid, path);
    film.startEmpty();
    EXPECT_TRUE(film.newerThanCheckpoint(0)) << "the first, empty checkpoint";
    film.merge(1, unitBlock(grid.unit(1), 3));
    film.merge(6, unitBlock(grid.unit(6), 5));
    EXPECT_TRUE(film.dirty());
    const JobFilm::Copy older = film.copy();
    film.merge(2, unitBlock(grid.unit(2), 7));
    const JobFilm::Copy newer = film.copy();
    film.writeFile(newer);
    film.checkpointWritten(newer.count);
    EXPECT_FALSE(film.dirty());
    EXPECT_FALSE(film.newerThanCheckpoint(older.count)) << "an older copy would overwrite";
    EXPECT_EQ(film.checkpointsWritten(), 1u);

    JobFilm restored(grid, path);
    restored.restore(restored.readFile(), true);
    EXPECT_EQ(restored.mergedCount(), 3u);
    EXPECT_EQ(restored.merged(), film.merged());
    EXPECT_EQ(restored.film().serialize(), film.film().serialize());
    EXPECT_EQ(restored.samplesMerged(), film.samplesMerged());
    EXPECT_EQ(restored.passesComplete(), 0u);
    EXPECT_FALSE(restored.dirty());
    fs::remove_all(dir);
}

}  // namespace
}  // namespace alphorn::coordinator
