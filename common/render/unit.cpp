#include "common/render/unit.h"

#include "common/core/error.h"
#include "common/scene/scene.h"

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

namespace alphorn {

std::vector<Tile> makeTiles(int width, int height, int tileSize) {
    if (tileSize <= 0) fail("tile size must be positive, got %d", tileSize);
    std::vector<Tile> tiles;
    for (int y = 0; y < height; y += tileSize)
        for (int x = 0; x < width; x += tileSize)
            tiles.push_back(
                Tile{x, y, std::min(x + tileSize, width), std::min(y + tileSize, height)});
    return tiles;
}

int filterBorder(const Scene& scene) {
    return static_cast<int>(std::ceil(scene.camera()->filter()->radius() + 0.5f));
}

Tile grownTile(const Tile& tile, int border) {
    return Tile{tile.x0 - border, tile.y0 - border, tile.x1 + border, tile.y1 + border};
}

FilmBlock unitBlock(const Tile& tile, int border, SmallerRadius smallerRadius) {
    const Tile grown = grownTile(tile, border);
    return FilmBlock(grown.x0, grown.y0, grown.width(), grown.height(), PassHalves::Kept,
                     smallerRadius);
}

SmallerRadius filmSmallerRadius(const Scene& scene) {
    return scene.integrator()->estimatesBiasWithTwoRadii() ? SmallerRadius::Kept
                                                           : SmallerRadius::None;
}

FilmBlock makeUnitBlock(const Scene& scene, const Tile& tile) {
    return unitBlock(tile, filterBorder(scene), filmSmallerRadius(scene));
}

TileGrid::TileGrid(int width, int height, int tileSize, int border, SmallerRadius smallerRadius)
    : m_width(width), m_height(height), m_border(border), m_smallerRadius(smallerRadius) {
    if (width <= 0 || height <= 0) fail("image size must be positive, got %dx%d", width, height);
    if (border < 0) fail("the filter border must not be negative, got %d", border);
    m_tiles = makeTiles(width, height, tileSize);
}

TileGrid::TileGrid(const Scene& scene, int tileSize)
    : TileGrid(scene.camera()->outputSize().x(), scene.camera()->outputSize().y(), tileSize,
               filterBorder(scene), filmSmallerRadius(scene)) {}

std::vector<Tile> TileGrid::tilesReaching(const Tile& region) const {
    std::vector<Tile> reaching;
    for (const Tile& tile : m_tiles) {
        const Tile reach = grownTile(tile, m_border);
        if (reach.x0 < region.x1 && region.x0 < reach.x1 && reach.y0 < region.y1 &&
            region.y0 < reach.y1)
            reaching.push_back(tile);
    }
    return reaching;
}

// A scene loaded only to be checked has no BVH: its rays would find nothing, and its image would
// be black without a word.
static void failUnlessTraceable(const Scene& scene) {
    if (!scene.canTrace())
        fail("cannot render a scene loaded only to be checked (it has no acceleration structure)");
}

std::vector<std::shared_ptr<const PassData>> preparePasses(const Scene& scene, uint64_t seed,
                                                           uint32_t begin, uint32_t end) {
    failUnlessTraceable(scene);
    std::vector<std::shared_ptr<const PassData>> data;
    data.reserve(end - begin);
    for (uint32_t pass = begin; pass < end; ++pass) {
        try {
            data.push_back(scene.integrator()->preparePass(scene, seed, pass));
        } catch (const std::bad_alloc&) {
            // The scene's photon and light-path counts were checked against the machine's memory
            // when it loaded, but for one photon or vertex per path only: longer paths, other
            // processes or an address-space limit can still exhaust it here. The passes already
            // built are freed first, so that the message can be made.
            data.clear();
            fail(
                "%s: out of memory building pass %u's photons or light paths: lower the "
                "integrator's photon or path counts, or render where more memory is free",
                scene.integrator()->source(), pass);
        }
    }
    return data;
}

namespace {

bool isValidSample(const Color3f& value) {
    return value.isValid() && !(value.maxCoeff() > kFixedPointLimit);
}

// A camera sample into the block; rejected samples are counted, never clamped.
void splat(ScratchBlock& block, const ReconstructionFilter& filter, const Point2f& position,
           const Color3f& value) {
    if (!isValidSample(value)) {
        ++block.invalidSamples;
        return;
    }
    splatFiltered(block, filter, position, value, SampleWeight::Counted);
}

// A camera sample at both radii. The pass radius's sums are exactly splat()'s; a sample invalid
// at the smaller radius only is left out of its sums (they carry their own weights) and not
// counted: invalidSamples counts the image's samples.
void splatTwoRadii(ScratchBlock& block, const ReconstructionFilter& filter, const Point2f& position,
                   const TwoRadiiRadiance& value) {
    const bool smallerValid = isValidSample(value.atSmallerRadius);
    if (!isValidSample(value.atPassRadius)) {
        ++block.invalidSamples;
        if (smallerValid)
            splatFilteredSmallerRadius(block, filter, position, value.atSmallerRadius);
    } else if (smallerValid) {
        splatFilteredTwoRadii(block, filter, position, value.atPassRadius, value.atSmallerRadius);
    } else {
        splatFiltered(block, filter, position, value.atPassRadius, SampleWeight::Counted);
    }
}

}  // namespace

bool renderUnit(const Scene& scene, uint64_t seed, const RenderUnit& unit,
                const std::vector<std::shared_ptr<const PassData>>& passData, FilmBlock& out,
                RenderCounters* counters, const std::atomic<bool>* cancel, std::mutex* outLock) {
    failUnlessTraceable(scene);
    const Camera& camera = *scene.camera();
    const Integrator& integrator = *scene.integrator();
    const ReconstructionFilter& filter = *camera.filter();
    const Tile& tile = unit.tile;
    const int width = camera.outputSize().x();
    const size_t rows = static_cast<size_t>(tile.height());
    const size_t passes = unit.passEnd - unit.passBegin;
    if (passData.size() != passes)
        fail("renderUnit: pass data for %zu passes, expected %zu", passData.size(), passes);
    std::atomic<bool> cancelled{false};
    // The smaller radius's image only when `out` keeps it: a film without it (an older
    // coordinator's unit) gets exactly the samples it always got.
    const bool twoRadii = out.keepsSmallerRadius();
    if (twoRadii && !integrator.estimatesBiasWithTwoRadii())
        fail("renderUnit: the film keeps a smaller radius's image this integrator does not make");
    const SmallerRadius scratchSmallerRadius = twoRadii ? SmallerRadius::Kept : SmallerRadius::None;
    // The pixels the unit's samples reach: its block.
    const Tile reach = grownTile(tile, filterBorder(scene));

    // Work items are (pass, row) pairs. Each thread renders into blocks of its own, made once
    // per unit (a block per task cost a sixth of a Cornell box render in allocation and adding),
    // and the blocks are added to `out` exactly: the partitioning chosen by TBB, and which
    // thread took which rows, cannot change the result. A thread keeps even and odd passes in
    // separate blocks, so a sample is splatted into one sum only, whatever `out` keeps.
    struct ThreadFilm {
        ScratchBlock passesOfParity[2];  // [0]: even passes, [1]: odd passes
        std::unique_ptr<Sampler> sampler;
    };
    tbb::enumerable_thread_specific<ThreadFilm> threadFilms([&] {
        const bool bothParities = passes > 1;
        const auto block = [&](bool used) {
            return used ? ScratchBlock(reach.x0, reach.y0, reach.width(), reach.height(),
                                       scratchSmallerRadius)
                        : ScratchBlock(scratchSmallerRadius);
        };
        const bool firstIsOdd = unit.passBegin % 2 == 1;
        return ThreadFilm{{block(bothParities || !firstIsOdd), block(bothParities || firstIsOdd)},
                          scene.sampler()->clone()};
    });
    tbb::parallel_for(
        tbb::blocked_range<size_t>(0, passes * rows), [&](const tbb::blocked_range<size_t>& range) {
            ThreadFilm& threadFilm = threadFilms.local();
            Sampler* sampler = threadFilm.sampler.get();
            const uint64_t raysBefore = raysTracedByThisThread();
            uint64_t samples = 0;
            for (size_t item = range.begin(); item != range.end(); ++item) {
                if (cancel && cancel->load(std::memory_order_relaxed)) {
                    cancelled = true;
                    break;
                }
                const size_t passOffset = item / rows;
                const uint32_t pass = unit.passBegin + static_cast<uint32_t>(passOffset);
                const int y = tile.y0 + static_cast<int>(item % rows);
                const PassData* data = passData[passOffset].get();
                ScratchBlock& local = threadFilm.passesOfParity[pass % 2];
                for (int x = tile.x0; x < tile.x1; ++x) {
                    const uint64_t pixelIndex = static_cast<uint64_t>(y) * width + x;
                    sampler->startStream(seed, pass, pixelIndex, StreamPurpose::Camera);
                    const Point2f pixelSample = Point2f(float(x), float(y)) + sampler->next2D();
                    const Point2f apertureSample = sampler->next2D();
                    Ray3f ray;
                    Color3f value = camera.sampleRay(ray, pixelSample, apertureSample);
                    if (twoRadii) {
                        TwoRadiiRadiance radiance{value, value};
                        if (!value.isBlack()) {
                            const TwoRadiiRadiance li =
                                integrator.LiTwoRadii(scene, *sampler, ray, data);
                            radiance.atPassRadius *= li.atPassRadius;
                            radiance.atSmallerRadius *= li.atSmallerRadius;
                        }
                        splatTwoRadii(local, filter, pixelSample, radiance);
                        continue;
                    }
                    if (!value.isBlack()) value *= integrator.Li(scene, *sampler, ray, data);
                    splat(local, filter, pixelSample, value);
                }
                samples += static_cast<uint64_t>(tile.width());
            }
            if (counters) {
                counters->samples += samples;
                counters->rays += raysTracedByThisThread() - raysBefore;
            }
        });
    if (cancelled) return false;
    // Light paths splat onto the whole image (bidirectional integrators): each unit adds the
    // part on its own tile, into the half of each pass's parity.
    const bool passSplats = integrator.hasPassSplats();
    FilmBlock splats[2];
    if (passSplats) {
        // The integrator adds its splats to the smaller radius's image too when kept.
        for (FilmBlock& block : splats)
            block = FilmBlock(reach.x0, reach.y0, reach.width(), reach.height(), PassHalves::None,
                              scratchSmallerRadius);
        for (size_t i = 0; i < passes; ++i)
            integrator.addPassSplats(passData[i].get(), tile.x0, tile.y0, tile.x1, tile.y1,
                                     splats[(unit.passBegin + i) % 2]);
    }
    std::unique_lock<std::mutex> lock;
    if (outLock) lock = std::unique_lock(*outLock);
    for (const ThreadFilm& threadFilm : threadFilms)
        for (int parity = 0; parity < 2; ++parity)
            out.addPassesOfParity(threadFilm.passesOfParity[parity], parity == 1);
    if (passSplats)
        for (int parity = 0; parity < 2; ++parity)
            out.addPassesOfParity(splats[parity], parity == 1);
    return true;
}

}  // namespace alphorn
