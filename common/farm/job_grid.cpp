#include "common/farm/job_grid.h"

#include "common/core/error.h"

#include <utility>

namespace alphorn::farm {

JobGrid::JobGrid(TileGrid tiles, uint32_t passes, uint32_t passesPerUnit)
    : m_tiles(std::move(tiles)), m_passes(passes), m_passesPerUnit(passesPerUnit) {
    if (m_tiles.tiles().empty()) fail("a job's grid needs tiles");
    if (passes == 0) fail("the number of passes must be positive");
    if (passesPerUnit == 0) fail("passes per unit must be positive");
    const uint64_t chunks = (uint64_t(passes) + passesPerUnit - 1) / passesPerUnit;
    const uint64_t units = chunks * m_tiles.tiles().size();
    if (units > UINT32_MAX)
        fail("%u passes in chunks of %u over %u tiles make %u units, more than %u", passes,
             passesPerUnit, m_tiles.tiles().size(), units, UINT32_MAX);
    m_chunkCount = static_cast<uint32_t>(chunks);
}

RenderUnit JobGrid::unit(uint32_t index) const {
    if (index >= unitCount())
        fail("unit %u out of range (the job has %u units)", index, unitCount());
    const uint32_t chunk = index / tileCount();
    RenderUnit unit;
    unit.passBegin = chunk * m_passesPerUnit;  // < m_passes, so no overflow
    unit.passEnd = static_cast<uint32_t>(
        std::min<uint64_t>(m_passes, uint64_t(unit.passBegin) + m_passesPerUnit));
    unit.tile = m_tiles.tiles()[index % tileCount()];
    return unit;
}

uint32_t JobGrid::chunkPasses(uint32_t chunk) const {
    const uint64_t begin = uint64_t(chunk) * m_passesPerUnit;
    return static_cast<uint32_t>(std::min<uint64_t>(m_passes, begin + m_passesPerUnit) - begin);
}

uint32_t JobGrid::passesComplete(const std::vector<bool>& merged) const {
    if (merged.size() != unitCount())
        fail("%u merged flags for a grid of %u units", merged.size(), unitCount());
    uint32_t passes = 0;
    for (uint32_t chunk = 0; chunk < chunkCount(); ++chunk) {
        bool complete = true;
        for (uint32_t tile = 0; tile < tileCount() && complete; ++tile)
            complete = merged[size_t(chunk) * tileCount() + tile];
        if (complete) passes += chunkPasses(chunk);
    }
    return passes;
}

}  // namespace alphorn::farm
