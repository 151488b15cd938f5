#include "common/render/local_render.h"

#include "common/scene/scene.h"

#include <tbb/parallel_for.h>

#include <mutex>

namespace alphorn {

FilmBlock renderLocal(const Scene& scene, const RenderSettings& settings,
                      const ProgressCallback& progress, RenderCounters* externalCounters) {
    const Vector2i size = scene.camera()->outputSize();
    FilmBlock film(0, 0, size.x(), size.y());
    const std::vector<Tile> tiles = makeTiles(size.x(), size.y(), settings.tileSize);
    RenderCounters localCounters;
    RenderCounters& counters = externalCounters ? *externalCounters : localCounters;
    std::mutex filmMutex;
    const uint32_t chunk = std::max<uint32_t>(1, settings.passesPerUnit);
    for (uint32_t begin = 0; begin < settings.passes; begin += chunk) {
        if (settings.stop && settings.stop->load()) break;
        const uint32_t end = std::min(settings.passes, begin + chunk);
        // Pass data (photon maps) is built once and shared by every tile of these passes.
        const auto passData = preparePasses(scene, settings.seed, begin, end);
        tbb::parallel_for(size_t(0), tiles.size(), [&](size_t i) {
            RenderUnit unit{begin, end, tiles[i]};
            FilmBlock block = makeUnitBlock(scene, unit.tile);
            renderUnit(scene, settings.seed, unit, passData, block, &counters);
            std::lock_guard lock(filmMutex);
            film.add(block);
        });
        if (progress) {
            RenderStatus status;
            status.passesDone = end;
            status.passesTotal = settings.passes;
            status.samplesDone = counters.samples.load();
            status.samplesTotal = uint64_t(settings.passes) * size.x() * size.y();
            status.rays = counters.rays.load();
            progress(status);
        }
    }
    return film;
}

}  // namespace alphorn
