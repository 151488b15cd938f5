// How far a render is from converged, from the film's two halves by pass parity (film.h).
//
// The odd and the even passes are two independent renders of the same image; for an unbiased
// estimator each pixel's half difference has the variance of both halves, so
// (Y_even - Y_odd)^2 * n_even * n_odd / n^2 estimates the squared error of the full image's
// pixel (n passes, luminance Y). The relative RMSE is the root of the mean of those over the
// pixels, divided by the image's mean luminance: normalising by the mean, not per pixel, keeps
// near-black pixels from dominating (docs/error-estimate.md says why, and what it misses for the
// biased photon mappers).
//
// Decisions to stop are taken only at pass counts fixed in advance: 4, 8, 16, ... (powers of
// two) and the cap, so the pass a render stops at is a pure function of the scene, the seed and
// the target, wherever and however it was rendered.
#pragma once

#include "common/render/film.h"
#include "common/render/unit.h"

#include <cstdint>
#include <optional>

namespace alphorn {

struct ErrorEstimate {
    uint32_t passes = 0;         // passes in the film the estimate was made from
    double relativeRmse = 0.0;   // RMSE of the luminance / the mean luminance
    double meanLuminance = 0.0;  // of the full image over the pixels counted
    uint64_t pixels = 0;         // pixels with samples in both halves
};

// The estimate over the pixels of `region` of a film holding passes [0, passes). Nothing when
// it cannot be made: fewer than 2 passes, a film without halves, no pixel with samples in both
// halves, or a black image (no mean to relate the error to).
std::optional<ErrorEstimate> estimateError(const FilmBlock& film, const Tile& region,
                                           uint32_t passes);

// The first pass count at which a decision is taken: the smallest of 4, 8, 16, ... and `cap`
// above `passesDone`. `cap` when passesDone >= cap.
uint32_t nextDecisionPasses(uint32_t passesDone, uint32_t cap);
bool isDecisionPasses(uint32_t passes, uint32_t cap);

// Does the estimate at a decision point stop the render? A missing estimate (e.g. after 2 passes
// of a black image) never does; the cap always does.
bool reachesTarget(const std::optional<ErrorEstimate>& estimate, double targetError);

// The passes at which the estimate would reach `targetError`, assuming the Monte Carlo rate
// (the error falls as 1/sqrt(passes)); at least estimate.passes.
double projectedPasses(const ErrorEstimate& estimate, double targetError);

}  // namespace alphorn
