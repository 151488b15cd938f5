#include "common/render/local_render.h"

#include "common/core/error.h"
#include "common/core/system_memory.h"
#include "common/scene/scene.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <mutex>

namespace alphorn {

FilmBlock renderLocal(const Scene& scene, const RenderSettings& settings,
                      const ProgressCallback& progress, RenderCounters* externalCounters,
                      RenderStatus* finalStatus) {
    const Vector2i size = scene.camera()->outputSize();
    const size_t bytesPerPixel =
        FilmBlock(0, 0, 0, 0, PassHalves::Kept, filmSmallerRadius(scene)).bytesPerPixel();
    const uint64_t filmBytes = uint64_t(size.x()) * uint64_t(size.y()) * bytesPerPixel;
    const uint64_t maxFilmBytes =
        settings.maxFilmBytes ? settings.maxFilmBytes : physicalMemoryBytes();
    if (filmBytes > maxFilmBytes)
        fail("a %dx%d image needs %s for its film (%zu bytes of sums per pixel), more than %s",
             size.x(), size.y(), formatBytes(filmBytes), bytesPerPixel,
             settings.maxFilmBytes ? "the limit of " + formatBytes(maxFilmBytes)
                                   : "this machine's " + formatBytes(maxFilmBytes) + " of memory");
    FilmBlock film(0, 0, size.x(), size.y(), PassHalves::Kept, filmSmallerRadius(scene));
    // The farm's grid (farm::JobGrid cuts a job along the same one).
    const TileGrid grid(scene, settings.tileSize);
    // A crop needs the tiles whose samples reach it, whole: a tile's pixels are sampled the same
    // whichever tiles are rendered with it.
    const std::vector<Tile> tiles =
        settings.crop ? grid.tilesReaching(*settings.crop) : grid.tiles();
    if (settings.adaptive && settings.crop) fail("adaptive passes do not combine with a crop");
    // The adaptive grid's tiles, and what is rendered: each render tile cut along that grid, so
    // that a finished grid tile's pixels get no more samples whatever the render tile size.
    const bool adaptive = settings.adaptive && settings.targetError;
    const std::vector<Tile> decisionTiles =
        adaptive ? adaptiveTiles(size.x(), size.y()) : std::vector<Tile>{};
    struct Piece {
        Tile tile;
        size_t decisionTile = 0;
    };
    std::vector<Piece> pieces;
    for (const Tile& tile : tiles) {
        if (!adaptive) {
            pieces.push_back({tile, 0});
            continue;
        }
        for (size_t d = 0; d < decisionTiles.size(); ++d) {
            const Tile& grid = decisionTiles[d];
            const Tile cut{std::max(tile.x0, grid.x0), std::max(tile.y0, grid.y0),
                           std::min(tile.x1, grid.x1), std::min(tile.y1, grid.y1)};
            if (cut.x0 < cut.x1 && cut.y0 < cut.y1) pieces.push_back({cut, d});
        }
    }
    std::vector<bool> finished(decisionTiles.size(), false);
    uint64_t pixelsRendered = 0;
    for (const Tile& tile : tiles) pixelsRendered += uint64_t(tile.width()) * tile.height();
    RenderCounters localCounters;
    RenderCounters& counters = externalCounters ? *externalCounters : localCounters;
    std::mutex filmMutex;
    const uint32_t chunk = std::max<uint32_t>(1, settings.passesPerUnit);
    const Tile estimateRegion = settings.crop ? *settings.crop : Tile{0, 0, size.x(), size.y()};
    RenderStatus status;
    status.passesTotal = settings.passes;
    status.samplesTotal = uint64_t(settings.passes) * pixelsRendered;
    status.adaptiveTiles = static_cast<uint32_t>(decisionTiles.size());
    std::vector<ErrorEstimate> history;  // the estimates at the decision points passed
    std::vector<Piece> running;
    for (uint32_t begin = 0; begin < settings.passes && !status.targetReached;) {
        if (settings.stop && settings.stop->load()) break;
        // Chunks end at every decision point (units never change the sums, so this is free).
        const uint32_t end =
            std::min({settings.passes, begin + chunk, nextDecisionPasses(begin, settings.passes)});
        running.clear();
        for (const Piece& piece : pieces)
            if (!adaptive || !finished[piece.decisionTile]) running.push_back(piece);
        // Pass data (photon maps) is built once and shared by every tile of these passes.
        const auto passData = preparePasses(scene, settings.seed, begin, end);
        tbb::parallel_for(size_t(0), running.size(), [&](size_t i) {
            const RenderUnit unit{begin, end, running[i].tile};
            renderUnit(scene, settings.seed, unit, passData, film, &counters, nullptr, &filmMutex);
        });
        status.passesDone = end;
        status.samplesDone = counters.samples.load();
        status.rays = counters.rays.load();
        if (isDecisionPasses(end, settings.passes)) {
            if (adaptive) {
                const TileDecisions decisions =
                    decideTiles(film, decisionTiles, finished, end, *settings.targetError);
                status.estimate = decisions.image;
                finished = decisions.finished;
                status.adaptiveTilesFinished =
                    static_cast<uint32_t>(std::count(finished.begin(), finished.end(), true));
                status.targetReached = status.adaptiveTilesFinished == decisionTiles.size();
            } else {
                status.estimate = estimateError(film, estimateRegion, end);
                status.targetReached =
                    settings.targetError && reachesTarget(status.estimate, *settings.targetError);
            }
            if (status.estimate) {
                history.push_back(*status.estimate);
                status.estimate->slope = fitSlope(history);
            }
        }
        if (progress) progress(status);
        begin = end;
    }
    if (finalStatus) *finalStatus = status;
    return film;
}

}  // namespace alphorn
