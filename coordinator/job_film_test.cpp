// The job film: merges add exact sums, the progress figures kept on each merge equal a recount,
// and a checkpoint restores the same film and units; an older copy never overwrites a newer one.
#include "coordinator/job_film.h"

#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/sha256.h"

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
    const farm::JobGrid grid(TileGrid(10, 7, 4, 1), 5, 2);
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
    const farm::JobGrid grid(TileGrid(8, 8, 4, 1), 2, 1);
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

// A unit of passes [b, e) where every pixel of pass p is grey 1 + s_p with s_0 = 1, s_1 = -1 and
// s_p = 0 after: after D passes the halves are 1 + 2/D and 1 - 2/D, so the estimated relative
// RMSE is sqrt((4/D)^2 / 4) = 2/D (0.5 at 4 passes, 0.25 at 8, 0.125 at 16).
FilmBlock shrinkingNoiseBlock(const RenderUnit& unit) {
    FilmBlock block(unit.tile.x0, unit.tile.y0, unit.tile.width(), unit.tile.height());
    for (int y = block.y0(); y < block.y0() + block.height(); ++y)
        for (int x = block.x0(); x < block.x0() + block.width(); ++x)
            for (uint32_t pass = unit.passBegin; pass < unit.passEnd; ++pass) {
                const double value = 1.0 + (pass == 0 ? 1.0 : pass == 1 ? -1.0 : 0.0);
                for (PixelSum* sum : {&block.at(x, y), pass % 2 ? &block.oddAt(x, y) : nullptr}) {
                    if (!sum) continue;
                    for (int c = 0; c < 3; ++c) sum->rgb[c] += toFixedPoint(value);
                    sum->weight += toFixedPoint(1.0);
                }
            }
    return block;
}

// A job with a target error merges nothing past the next decision point, decides there from
// the merged passes only, and stops at the first point whose estimate reaches the target.
TEST(JobFilm, ATargetErrorStopsAtTheFirstDecisionPointThatReachesIt) {
    // 2 x 2 tiles, a cap of 32 passes in chunks of 2: 4 tiles per chunk.
    const farm::JobGrid grid(TileGrid(8, 8, 4, 1), 32, 2);
    JobFilm film(grid, "", "job", 0.2);
    film.startEmpty();
    EXPECT_EQ(film.leaseLimit(), 2u * 4) << "the passes before 4";
    for (uint32_t decision : {4u, 8u, 16u}) {
        const uint32_t limit = film.leaseLimit();
        EXPECT_EQ(limit, decision / 2 * 4);
        EXPECT_THROW(film.merge(limit, shrinkingNoiseBlock(grid.unit(limit))), Error)
            << "merged past the decision at " << decision;
        for (uint32_t i = 0; i < limit; ++i)
            if (!film.merged()[i]) film.merge(i, shrinkingNoiseBlock(grid.unit(i)));
        ASSERT_TRUE(film.estimate());
        EXPECT_EQ(film.estimate()->passes, decision);
        EXPECT_NEAR(film.estimate()->relativeRmse, 2.0 / decision, 1e-9);
        EXPECT_EQ(film.complete(), decision == 16u) << decision;
        // 2/D falls as 1/D, faster than the Monte Carlo rate the projection assumes: from 4
        // passes it projects (0.5 / 0.2)^2 * 4 = 25, the decision point 32.
        if (decision == 4u) {
            EXPECT_EQ(film.expectedPasses(), 32u);
        }
    }
    EXPECT_EQ(film.expectedPasses(), 16u) << "stopped";
    EXPECT_TRUE(film.targetReached());
    EXPECT_EQ(film.passesComplete(), 16u);
    EXPECT_EQ(film.leaseLimit(), 0u);

    // Without a target nothing waits, and the last decision point is the cap.
    JobFilm plain(grid, "");
    plain.startEmpty();
    EXPECT_EQ(plain.leaseLimit(), grid.unitCount());
    for (uint32_t i = grid.unitCount(); i-- > 0;) plain.merge(i, shrinkingNoiseBlock(grid.unit(i)));
    ASSERT_TRUE(plain.estimate());
    EXPECT_EQ(plain.estimate()->passes, 32u);
    EXPECT_NEAR(plain.estimate()->relativeRmse, 2.0 / 32, 1e-9);
    EXPECT_FALSE(plain.targetReached());
}

// After a restart the decision is taken again from the checkpoint's film: the same barrier,
// the same estimate, the same stop.
TEST(JobFilm, ACheckpointRestoresTheDecisions) {
    const fs::path dir =
        fs::temp_directory_path() / ("alphorn_job_film_target_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string path = (dir / "film.ckpt").string();
    const farm::JobGrid grid(TileGrid(8, 8, 4, 1), 32, 2);
    JobFilm film(grid, path, "job", 0.2);
    film.startEmpty();
    // The decisions at 4 and 8 passes go on; two units of the passes before 16 are merged.
    while (film.leaseLimit() <= 4 * 4)
        for (uint32_t i = 0, limit = film.leaseLimit(); i < limit; ++i)
            if (!film.merged()[i]) film.merge(i, shrinkingNoiseBlock(grid.unit(i)));
    film.merge(16, shrinkingNoiseBlock(grid.unit(16)));
    film.merge(17, shrinkingNoiseBlock(grid.unit(17)));
    film.writeFile(film.copy());
    JobFilm restored(grid, path, "job", 0.2);
    restored.restore(restored.readFile(), true);
    EXPECT_EQ(restored.leaseLimit(), film.leaseLimit());
    EXPECT_EQ(restored.leaseLimit(), 8u * 4);
    EXPECT_FALSE(restored.estimate()) << "no decision point is complete in the checkpoint";
    // The finished job: its checkpoint says it stopped at the target.
    for (uint32_t i = 0, limit = film.leaseLimit(); i < limit; ++i)
        if (!film.merged()[i]) film.merge(i, shrinkingNoiseBlock(grid.unit(i)));
    ASSERT_TRUE(film.targetReached());
    film.writeFile(film.copy());
    JobFilm done(grid, path, "job", 0.2);
    done.restore(done.readFile(), false);
    EXPECT_TRUE(done.complete());
    EXPECT_TRUE(done.targetReached());
    ASSERT_TRUE(done.estimate());
    EXPECT_EQ(done.estimate()->passes, 16u);
    fs::remove_all(dir);
}

// A unit whose pass 0 and 1 are grey 1 + amplitude and 1 - amplitude, later passes 1: an
// adaptive tile's relative RMSE is 2 amplitude / D after D passes (the image's mean is 1).
FilmBlock noiseBlock(const RenderUnit& unit, double amplitude) {
    FilmBlock block(unit.tile.x0, unit.tile.y0, unit.tile.width(), unit.tile.height());
    for (int y = block.y0(); y < block.y0() + block.height(); ++y)
        for (int x = block.x0(); x < block.x0() + block.width(); ++x)
            for (uint32_t pass = unit.passBegin; pass < unit.passEnd; ++pass) {
                const double value = 1.0 + (pass == 0 ? amplitude : pass == 1 ? -amplitude : 0.0);
                for (PixelSum* sum : {&block.at(x, y), pass % 2 ? &block.oddAt(x, y) : nullptr}) {
                    if (!sum) continue;
                    for (int c = 0; c < 3; ++c) sum->rgb[c] += toFixedPoint(value);
                    sum->weight += toFixedPoint(1.0);
                }
            }
    return block;
}

// An adaptive job: the left 32x32 tile (error 0.5 / D) meets the target 0.2 at 4 passes and its
// later units are skipped, never to be leased; the right one (2 / D) goes on to 16. A restart
// after the decision at 8 reads the decisions beside the checkpoint and goes on the same way.
TEST(JobFilm, AnAdaptiveJobSkipsTheUnitsOfFinishedTilesAcrossARestart) {
    const fs::path dir =
        fs::temp_directory_path() / ("alphorn_job_film_adaptive_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string path = (dir / "film.ckpt").string();
    // 64 x 32 pixels in tiles of 16: 4 x 2 unit tiles, 2 adaptive tiles; 32 passes in chunks of 2.
    const farm::JobGrid grid(TileGrid(64, 32, 16, 1), 32, 2);
    const auto block = [&](uint32_t i) {
        const RenderUnit unit = grid.unit(i);
        return noiseBlock(unit, unit.tile.x0 < 32 ? 0.25 : 1.0);
    };
    JobFilm film(grid, path, "job", 0.2, true);
    film.startEmpty();
    EXPECT_EQ(film.adaptiveTiles(), 2u);
    for (uint32_t i = 0, limit = film.leaseLimit(); i < limit; ++i) film.merge(i, block(i));
    EXPECT_EQ(film.adaptiveTilesFinished(), 1u);
    const std::vector<uint32_t> skipped = film.takeSkippedUnits();
    EXPECT_EQ(skipped.size(), 4u * 14) << "the left tile's 4 unit tiles x chunks of passes 4-31";
    for (uint32_t i : skipped) {
        EXPECT_LT(grid.unit(i).tile.x0, 32);
        EXPECT_GE(grid.unit(i).passBegin, 4u);
    }
    EXPECT_EQ(film.leaseLimit(), 4u * 8) << "the passes before 8";
    for (uint32_t i = 0, limit = film.leaseLimit(); i < limit; ++i)
        if (!film.merged()[i]) film.merge(i, block(i));
    EXPECT_FALSE(film.complete());
    EXPECT_EQ(film.adaptiveTilesFinished(), 1u);
    EXPECT_EQ(film.leaseLimit(), 8u * 8) << "the passes before 16";
    film.writeFile(film.copy());

    JobFilm restored(grid, path, "job", 0.2, true);
    restored.restore(restored.readFile(), true);
    EXPECT_EQ(restored.adaptiveTilesFinished(), 1u);
    EXPECT_EQ(restored.leaseLimit(), film.leaseLimit());
    EXPECT_EQ(restored.merged(), film.merged());
    EXPECT_EQ(restored.passesComplete(), film.passesComplete());
    for (uint32_t i = 0, limit = restored.leaseLimit(); i < limit; ++i)
        if (!restored.merged()[i]) restored.merge(i, block(i));
    EXPECT_TRUE(restored.complete());
    EXPECT_TRUE(restored.targetReached());
    EXPECT_EQ(restored.adaptiveTilesFinished(), 2u);
    ASSERT_TRUE(restored.estimate());
    EXPECT_EQ(restored.estimate()->passes, 16u);
    // Samples: the left tile's 4 passes and the right tile's 16 over 32 x 32 pixels each.
    EXPECT_EQ(restored.samplesMerged(), 32u * 32 * (4 + 16));
    fs::remove_all(dir);
}

// A checkpoint of version 1 (totals only) is read as a film without halves: the job goes on
// without an error estimate.
TEST(JobFilm, AVersion1CheckpointIsReadWithoutAnEstimate) {
    const fs::path dir =
        fs::temp_directory_path() / ("alphorn_job_film_v1_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string path = (dir / "film.ckpt").string();
    const farm::JobGrid grid(TileGrid(4, 4, 4, 1), 4, 1);
    FilmBlock totals(0, 0, 4, 4, PassHalves::None);
    totals.at(1, 2).rgb[0] = toFixedPoint(5.0);
    totals.at(1, 2).weight = toFixedPoint(2.0);
    std::string bytes = "ALPHCKP1";
    const auto put = [&](auto value) {
        bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
    };
    put(uint32_t(4));
    put(uint32_t(4));
    put(uint32_t(grid.unitCount()));
    put(uint64_t(0));
    for (uint32_t i = 0; i < grid.unitCount(); ++i) bytes.push_back(i < 2 ? 1 : 0);
    const std::string compressed = farm::compressFilm(totals);
    put(uint64_t(compressed.size()));
    bytes += compressed;
    bytes += farm::sha256Hex(bytes);
    farm::writeFileAtomically(path, bytes);
    JobFilm film(grid, path);
    film.restore(film.readFile(), true);
    EXPECT_EQ(film.mergedCount(), 2u);
    EXPECT_FALSE(film.film().keepsHalves());
    EXPECT_EQ(film.film().at(1, 2).weight, toFixedPoint(2.0));
    film.merge(2, FilmBlock(0, 0, 4, 4));
    film.merge(3, FilmBlock(0, 0, 4, 4));
    EXPECT_TRUE(film.complete());
    EXPECT_FALSE(film.estimate());
    // An unknown version is refused with the reason.
    bytes[7] = '9';
    farm::writeFileAtomically(path, bytes);
    try {
        film.readFile();
        FAIL() << "version 9 was read";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("version 9"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

// A job whose films keep the smaller radius's image (a progressive photon mapper's): its film,
// its checkpoints (version 3) and its estimate carry it, and the estimate has the bias; a
// checkpoint of version 2 is read as a film without it, which such a job refuses by name.
TEST(JobFilm, TheSmallerRadiusIsMergedCheckpointedAndEstimated) {
    const fs::path dir =
        fs::temp_directory_path() / ("alphorn_job_film_radii_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const std::string path = (dir / "film.ckpt").string();
    const farm::JobGrid grid(TileGrid(4, 4, 4, 1, SmallerRadius::Kept), 4, 1);
    EXPECT_GT(JobFilm::memoryBytes(4, 4, 4, SmallerRadius::Kept),
              JobFilm::memoryBytes(4, 4, 4) + 16 * 2 * sizeof(PixelSum) - 1);
    JobFilm film(grid, path, "job", 0.001);
    film.startEmpty();
    ASSERT_TRUE(film.film().keepsSmallerRadius());
    for (uint32_t pass = 0; pass < 4; ++pass) {
        FilmBlock block = grid.tiles().block(grid.unit(pass).tile);
        ASSERT_TRUE(block.keepsSmallerRadius());
        FilmBlock samples(block.x0(), block.y0(), block.width(), block.height(), PassHalves::None,
                          SmallerRadius::Kept);
        for (int y = 0; y < 4; ++y)
            for (int x = 0; x < 4; ++x) {
                const double value = 1.0 + 0.1 * x + 0.01 * ((pass + y) % 3);
                for (int c = 0; c < 3; ++c) {
                    samples.at(x, y).rgb[c] = toFixedPoint(value);
                    samples.smallerRadiusAt(x, y).rgb[c] = toFixedPoint(0.7 * value);
                }
                samples.at(x, y).weight = samples.smallerRadiusAt(x, y).weight = toFixedPoint(1);
            }
        block.addPassesOfParity(samples, pass % 2 == 1);
        film.merge(pass, block);
    }
    ASSERT_TRUE(film.estimate() && film.estimate()->relativeBias);
    EXPECT_GT(*film.estimate()->relativeBias, 0.3);
    v1::JobStatus status;
    describeEstimate(film, status);
    ASSERT_TRUE(status.has_error_bias());
    EXPECT_EQ(status.error_bias(), *film.estimate()->relativeBias);
    const JobFilm::Copy copy = film.copy();
    film.writeFile(copy);
    EXPECT_EQ(farm::readFile(path)[7], '4');
    JobFilm restored(grid, path, "job", 0.001);
    restored.restore(restored.readFile(), true);
    EXPECT_EQ(restored.film().serialize(), film.film().serialize());
    ASSERT_TRUE(restored.estimate() && restored.estimate()->relativeBias);
    EXPECT_EQ(*restored.estimate()->relativeBias, *film.estimate()->relativeBias);

    // The same file as version 2 (no smaller-radius flag, image sums only).
    FilmBlock image(0, 0, 4, 4);
    image.add(film.film());
    std::string bytes = "ALPHCKP2";
    const auto put = [&](auto value) {
        bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
    };
    put(uint32_t(4));
    put(uint32_t(4));
    put(uint32_t(grid.unitCount()));
    put(uint64_t(0));
    put(uint8_t(1));
    for (uint32_t i = 0; i < grid.unitCount(); ++i) bytes.push_back(1);
    const std::string compressed = farm::compressFilm(image);
    put(uint64_t(compressed.size()));
    bytes += compressed;
    bytes += farm::sha256Hex(bytes);
    farm::writeFileAtomically(path, bytes);
    const farm::JobGrid oldGrid(TileGrid(4, 4, 4, 1), 4, 1);
    JobFilm old(oldGrid, path);
    old.restore(old.readFile(), true);
    EXPECT_FALSE(old.film().keepsSmallerRadius());
    EXPECT_EQ(old.film().serialize(), image.serialize());
    try {
        restored.restore(restored.readFile(), true);
        FAIL() << "a film without the smaller radius was restored into a job that keeps it";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("smaller radius"), std::string::npos) << e.what();
    }
    fs::remove_all(dir);
}

}  // namespace
}  // namespace alphorn::coordinator
