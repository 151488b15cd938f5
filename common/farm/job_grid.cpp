#include "common/farm/job_grid.h"

#include "common/core/error.h"

namespace alphorn::farm {

JobGrid::JobGrid(int width, int height, int tileSize, uint32_t passes, uint32_t passesPerUnit)
    : m_width(width), m_height(height), m_passes(passes), m_passesPerUnit(passesPerUnit) {
    if (width <= 0 || height <= 0) fail("image size must be positive, got %dx%d", width, height);
    if (passes == 0) fail("the number of passes must be positive");
    if (passesPerUnit == 0) fail("passes per unit must be positive");
    m_tiles = makeTiles(width, height, tileSize);
}

RenderUnit JobGrid::unit(uint32_t index) const {
    if (index >= unitCount())
        fail("unit %u out of range (the job has %u units)", index, unitCount());
    const uint32_t chunk = index / tileCount();
    RenderUnit unit;
    unit.passBegin = chunk * m_passesPerUnit;
    unit.passEnd = std::min(m_passes, unit.passBegin + m_passesPerUnit);
    unit.tile = m_tiles[index % tileCount()];
    return unit;
}

uint32_t JobGrid::chunkPasses(uint32_t chunk) const {
    const uint32_t begin = chunk * m_passesPerUnit;
    return std::min(m_passes, begin + m_passesPerUnit) - begin;
}

uint32_t JobGrid::passesComplete(const std::vector<bool>& merged) const {
    uint32_t passes = 0;
    for (uint32_t chunk = 0; chunk < chunkCount(); ++chunk) {
        bool complete = true;
        for (uint32_t tile = 0; tile < tileCount() && complete; ++tile)
            complete = merged[chunk * tileCount() + tile];
        if (complete) passes += chunkPasses(chunk);
    }
    return passes;
}

}  // namespace alphorn::farm
