// Rendering a whole job in this process: the same units, the same renderUnit() and the same
// exact merge as the farm, without sockets ("a coordinator and a worker in one process").
#pragma once

#include "common/render/error_estimate.h"
#include "common/render/unit.h"

#include <atomic>
#include <functional>
#include <optional>

namespace alphorn {

struct RenderSettings {
    uint64_t seed = 0;
    uint32_t passes = 1;
    int tileSize = 64;
    uint32_t passesPerUnit = 1;
    // Checked between chunks of passes: once it is true, rendering stops there and the film
    // holds exactly the passes completed, as a render of that many passes would (Ctrl-C, a time
    // limit).
    const std::atomic<bool>* stop = nullptr;
    // When set, only the tiles whose samples reach these pixels (through the reconstruction
    // filter) are rendered: the film's sums over the crop are exactly those of the whole image.
    std::optional<Tile> crop;
    // When set, `passes` is a cap: rendering stops at the first decision point
    // (nextDecisionPasses) whose error estimate over the image (or the crop) is at most this
    // relative RMSE. The stopping pass depends on nothing but the scene, seed and target.
    std::optional<double> targetError;
    // With a target: tile-adaptive passes (decideTiles). At each decision point every tile of
    // the fixed adaptive grid whose own estimate meets the target gets no more passes; the
    // render ends when all have, or at the cap. Not with a crop.
    bool adaptive = false;
    // The most memory the film may take; 0: the machine's physical memory. A larger film is
    // refused with an error before anything is allocated, rather than left to the kernel's
    // out-of-memory killer (a 16384 x 16384 film with its odd passes' sums is 32 GiB).
    uint64_t maxFilmBytes = 0;
};

struct RenderStatus {
    uint32_t passesDone = 0;
    uint32_t passesTotal = 0;
    uint64_t samplesDone = 0;
    uint64_t samplesTotal = 0;
    uint64_t rays = 0;
    // The error estimate at the last decision point passed (nothing before the first, or when it
    // cannot be made), and whether it stopped the render at the target.
    std::optional<ErrorEstimate> estimate;
    bool targetReached = false;
    // Adaptive renders: the tiles of the adaptive grid, and those finished (no more passes).
    uint32_t adaptiveTiles = 0, adaptiveTilesFinished = 0;
};

// Called from the rendering thread after each chunk of passes.
using ProgressCallback = std::function<void(const RenderStatus&)>;

// Renders all passes (or those before settings.stop, or up to the decision point that reaches
// settings.targetError) and returns the film over the whole image. `finalStatus`, when given,
// receives the status after the last pass rendered.
FilmBlock renderLocal(const Scene& scene, const RenderSettings& settings,
                      const ProgressCallback& progress = {}, RenderCounters* counters = nullptr,
                      RenderStatus* finalStatus = nullptr);

}  // namespace alphorn
