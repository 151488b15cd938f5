#include "common/render/local_render.h"

#include "common/scene/scene.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <mutex>

namespace alphorn {

FilmBlock renderLocal(const Scene& scene, const RenderSettings& settings,
                      const ProgressCallback& progress, RenderCounters* externalCounters,
                      RenderStatus* finalStatus) {
    const Vector2i size = scene.camera()->outputSize();
    FilmBlock film(0, 0, size.x(), size.y());
    std::vector<Tile> tiles = makeTiles(size.x(), size.y(), settings.tileSize);
    if (settings.crop) {
        // A sample splats into pixels up to the filter's radius away (as makeUnitBlock's border
        // allows), so the crop needs the tiles within that reach of it, whole: a tile's pixels
        // are sampled the same whichever tiles are rendered with it.
        const int reach = static_cast<int>(std::ceil(scene.camera()->filter()->radius() + 0.5f));
        const Tile& c = *settings.crop;
        std::erase_if(tiles, [&](const Tile& t) {
            return t.x1 <= c.x0 - reach || t.x0 >= c.x1 + reach || t.y1 <= c.y0 - reach ||
                   t.y0 >= c.y1 + reach;
        });
    }
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
    for (uint32_t begin = 0; begin < settings.passes && !status.targetReached;) {
        if (settings.stop && settings.stop->load()) break;
        // Chunks end at every decision point (units never change the sums, so this is free).
        const uint32_t end =
            std::min({settings.passes, begin + chunk, nextDecisionPasses(begin, settings.passes)});
        // Pass data (photon maps) is built once and shared by every tile of these passes.
        const auto passData = preparePasses(scene, settings.seed, begin, end);
        tbb::parallel_for(size_t(0), tiles.size(), [&](size_t i) {
            RenderUnit unit{begin, end, tiles[i]};
            FilmBlock block = makeUnitBlock(scene, unit.tile);
            renderUnit(scene, settings.seed, unit, passData, block, &counters);
            std::lock_guard lock(filmMutex);
            film.add(block);
        });
        status.passesDone = end;
        status.samplesDone = counters.samples.load();
        status.rays = counters.rays.load();
        if (isDecisionPasses(end, settings.passes)) {
            status.estimate = estimateError(film, estimateRegion, end);
            status.targetReached =
                settings.targetError && reachesTarget(status.estimate, *settings.targetError);
        }
        if (progress) progress(status);
        begin = end;
    }
    if (finalStatus) *finalStatus = status;
    return film;
}

}  // namespace alphorn
