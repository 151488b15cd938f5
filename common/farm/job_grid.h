// How a job is split into units: a fixed grid of pass chunks x tiles, chosen at submission and
// never changed, so unit ids stay meaningful across coordinator restarts and worker retries.
// The tiles and their blocks are a TileGrid, the one renderLocal renders along; this adds the
// pass chunks and the unit ids.
#pragma once

#include "common/render/unit.h"

#include <cstdint>
#include <vector>

namespace alphorn::farm {

class JobGrid {
  public:
    JobGrid() = default;
    // Throws Error on a grid without tiles, non-positive passes, and when the grid would have more
    // units than a 32-bit unit index can name (counts are computed in 64 bits, never wrapped).
    JobGrid(TileGrid tiles, uint32_t passes, uint32_t passesPerUnit);

    const TileGrid& tiles() const { return m_tiles; }
    int width() const { return m_tiles.width(); }
    int height() const { return m_tiles.height(); }
    uint32_t passes() const { return m_passes; }
    uint32_t passesPerUnit() const { return m_passesPerUnit; }
    uint32_t tileCount() const { return static_cast<uint32_t>(m_tiles.tiles().size()); }
    uint32_t chunkCount() const { return m_chunkCount; }
    uint32_t unitCount() const { return m_chunkCount * tileCount(); }

    // Unit `index` = chunk * tileCount() + tile: all tiles of the first passes come first, so
    // a preview fills the whole image early.
    RenderUnit unit(uint32_t index) const;
    uint32_t chunkOf(uint32_t index) const { return index / tileCount(); }
    // Passes of chunk `chunk`: [chunk * passesPerUnit, min(passes, ...)).
    uint32_t chunkPasses(uint32_t chunk) const;
    // Passes whose every unit is merged, given a per-unit "merged" flag.
    uint32_t passesComplete(const std::vector<bool>& merged) const;

  private:
    TileGrid m_tiles;
    uint32_t m_passes = 0, m_passesPerUnit = 1, m_chunkCount = 0;
};

}  // namespace alphorn::farm
