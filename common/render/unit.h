// The one function that renders a unit of work. The local renderer and the farm worker both
// call renderUnit(); nothing else turns camera rays into film sums.
#pragma once

#include "common/integrator/integrator.h"
#include "common/render/film.h"

#include <atomic>
#include <mutex>

namespace alphorn {

class Scene;

// A rectangle of pixels [x0, x1) x [y0, y1).
struct Tile {
    int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
    int width() const { return x1 - x0; }
    int height() const { return y1 - y0; }
    bool operator==(const Tile&) const = default;
};

// A unit: passes [passBegin, passEnd) over one tile. Passes are numbered from 0.
struct RenderUnit {
    uint32_t passBegin = 0, passEnd = 0;
    Tile tile;
};

// The tiles of an image in row-major order; edge tiles are smaller.
std::vector<Tile> makeTiles(int width, int height, int tileSize);

// How many pixels beyond its own a sample's filtered contribution can reach: the border around
// a unit's tile.
int filterBorder(const Scene& scene);
// The tile grown by `border` pixels on each side: the pixels a unit over `tile` can write.
Tile grownTile(const Tile& tile, int border);
// The film block of a unit whose tile is `tile`: over grownTile(tile, border), with the pass
// halves and, when asked, the smaller radius's image.
// The coordinator, which keeps a job's border rather than its scene, checks results against it.
FilmBlock unitBlock(const Tile& tile, int border,
                    SmallerRadius smallerRadius = SmallerRadius::None);
// Whether the scene's films keep the smaller radius's image: when its integrator makes one
// (Integrator::estimatesBiasWithTwoRadii).
SmallerRadius filmSmallerRadius(const Scene& scene);
// The film block a unit writes: unitBlock(tile, filterBorder(scene), filmSmallerRadius(scene)).
FilmBlock makeUnitBlock(const Scene& scene, const Tile& tile);

// The tiles an image is rendered in, the same for a local render (renderLocal) and a farm job
// (farm::JobGrid, which adds the pass chunks and unit ids): makeTiles(width, height, tileSize),
// each rendered into its block, the tile grown by `border` pixels on each side (unitBlock).
class TileGrid {
  public:
    TileGrid() = default;
    // Throws Error on a non-positive image or tile size and on a negative border.
    TileGrid(int width, int height, int tileSize, int border,
             SmallerRadius smallerRadius = SmallerRadius::None);
    // The grid of the scene's image, with its reconstruction filter's border (filterBorder),
    // its blocks keeping the smaller radius's image when the scene's do (filmSmallerRadius).
    TileGrid(const Scene& scene, int tileSize);

    int width() const { return m_width; }
    int height() const { return m_height; }
    int border() const { return m_border; }
    SmallerRadius smallerRadius() const { return m_smallerRadius; }
    const std::vector<Tile>& tiles() const { return m_tiles; }
    // The film block a unit over `tile` writes: unitBlock(tile, border(), smallerRadius()).
    FilmBlock block(const Tile& tile) const { return unitBlock(tile, m_border, m_smallerRadius); }
    // The tiles whose blocks overlap `region`: every tile a sample of which can reach a pixel of
    // it, in grid order.
    std::vector<Tile> tilesReaching(const Tile& region) const;

  private:
    int m_width = 0, m_height = 0, m_border = 0;
    SmallerRadius m_smallerRadius = SmallerRadius::None;
    std::vector<Tile> m_tiles;
};

// Counters a caller can poll while a unit renders (progress, Mrays/s).
struct RenderCounters {
    std::atomic<uint64_t> samples{0};  // camera samples finished
    std::atomic<uint64_t> rays{0};     // rays traced (closest-hit and shadow)
};

// The per-pass data (photon maps, ...) of passes [begin, end), built in pass order.
std::vector<std::shared_ptr<const PassData>> preparePasses(const Scene& scene, uint64_t seed,
                                                           uint32_t begin, uint32_t end);

// Renders `unit` and adds its samples into `out`: the unit's block (makeUnitBlock, or the block
// of the scene's TileGrid), or, given `outLock`, a film that holds that block's pixels and that
// other units add to at the same time (the lock is held while adding; a local render's image
// film, which saves a block per unit and adding it once more).
// passData[i] belongs to pass unit.passBegin + i. Returns false if cancelled midway, leaving
// `out` as it was.
bool renderUnit(const Scene& scene, uint64_t seed, const RenderUnit& unit,
                const std::vector<std::shared_ptr<const PassData>>& passData, FilmBlock& out,
                RenderCounters* counters = nullptr, const std::atomic<bool>* cancel = nullptr,
                std::mutex* outLock = nullptr);

}  // namespace alphorn
