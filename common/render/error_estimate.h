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

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>
#include <vector>

namespace alphorn {

struct ErrorEstimate {
    uint32_t passes = 0;        // passes in the film the estimate was made from
    double relativeRmse = 0.0;  // RMSE of the luminance / the mean luminance (noise and bias)
    // The part of relativeRmse due to the bias of a progressive photon mapper's radius
    // (withBias()), when one was estimated: relativeRmse^2 = noise^2 + relativeBias^2.
    std::optional<double> relativeBias;
    // The noise part of relativeRmse (all of it when no bias was estimated).
    double relativeNoise() const {
        return relativeBias ? std::sqrt(std::max(
                                  0.0, relativeRmse * relativeRmse - *relativeBias * *relativeBias))
                            : relativeRmse;
    }
    double meanLuminance = 0.0;  // of the full image over the pixels counted
    uint64_t pixels = 0;         // pixels with samples in both halves
    // How the error has fallen: the log-log slope of the estimates at this and the previous
    // decision points (fitSlope), when they are known. projectedPasses() uses it.
    std::optional<double> slope;
};

// The estimate over the pixels of `region` of a film holding passes [0, passes). Nothing when
// it cannot be made: fewer than 2 passes, a film without halves, no pixel with samples in both
// halves, or a black image (no mean to relate the error to). When the film keeps the smaller
// radius's image (a progressive photon mapper's), the two-radii bias is added (withBias) and
// reported in relativeBias.
std::optional<ErrorEstimate> estimateError(const FilmBlock& film, const Tile& region,
                                           uint32_t passes);

// The noise-only estimate `noise` with the bias `relativeBias` added in quadrature (the noise and
// the bias of a pixel are independent errors: their squares add).
ErrorEstimate withBias(ErrorEstimate noise, double relativeBias);

// Bias estimates for the progressive photon mappers, whose halves by pass parity share the
// radius schedule and so see noise only. Both relate a bias B that falls as the squared gather
// radius (smooth radiance: the kernel's blur is of second order in r) to a difference of two
// images whose expectations differ by a known fraction of B; each pixel's squared difference
// has its own expected noise (from the halves) taken out, the rest is summed over the region and
// divided by that fraction squared. Nothing when it cannot be made (as estimateError); 0 when
// the differences are no larger than their noise.
//
// Two radii: `smallerRadius` holds the same passes as `film` (same seed: the same photons and
// camera paths) gathered at radius r_i * sqrt(areaRatio). B(r sqrt(a)) = a B(r), so
// E[Y - Y_small] = (1 - a) B. Both films must keep their halves.
std::optional<double> estimateRelativeBiasTwoRadii(const FilmBlock& film,
                                                   const FilmBlock& smallerRadius,
                                                   const Tile& region, uint32_t passes,
                                                   double areaRatio = 0.5);
// Temporal: `earlier` holds the first passes / 2 passes of `film` (the image at the previous
// decision point). Under the Knaus-Zwicker schedule with `alpha` the bias of the mean of n
// passes is c * mean_{i<n} r_i^2, so E[Y_earlier - Y] = (rho - 1) B with rho the ratio of the
// means of r_i^2 over the first passes / 2 and over all passes (temporalBiasRatio). The
// difference is (Y_first - Y_second) / 2 of the two halves in time, whose noise is that of the
// full image: the noise-only estimate's squared error per pixel.
std::optional<double> estimateRelativeBiasTemporal(const FilmBlock& film, const FilmBlock& earlier,
                                                   const Tile& region, uint32_t passes,
                                                   double alpha);
// rho above: mean r_i^2 over passes [0, passes / 2) over the mean over [0, passes).
double temporalBiasRatio(uint32_t passes, double alpha);

// The first pass count at which a decision is taken: the smallest of 4, 8, 16, ... and `cap`
// above `passesDone`. `cap` when passesDone >= cap.
uint32_t nextDecisionPasses(uint32_t passesDone, uint32_t cap);
bool isDecisionPasses(uint32_t passes, uint32_t cap);

// Does the estimate at a decision point stop the render? A missing estimate (e.g. after 2 passes
// of a black image) never does; the cap always does.
bool reachesTarget(const std::optional<ErrorEstimate>& estimate, double targetError);

// The slope of log(error) against log(passes) by least squares over the last (up to) three
// estimates of `history` (in decision-point order), clamped to [kSteepestSlope,
// kShallowestSlope]; nothing with fewer than two. A progressive photon mapper's noise falls slower
// than 1/sqrt(passes) while its radius shrinks; the measured slope projects it better than the
// Monte Carlo rate. Three points, not all, so that the slope follows the current regime while
// one firefly-driven estimate does not decide it alone.
inline constexpr double kSteepestSlope = -1.0, kShallowestSlope = -0.1;
std::optional<double> fitSlope(const std::vector<ErrorEstimate>& history);

// The passes at which the estimate would reach `targetError`, the error falling as
// passes^slope with the estimate's measured slope, or the Monte Carlo rate (-1/2) without one;
// at least estimate.passes.
double projectedPasses(const ErrorEstimate& estimate, double targetError);

// Tile-adaptive passes (--adaptive): the image is divided into a fixed grid of decision tiles of
// kAdaptiveTileSize pixels, whatever the render's tile size, so that --tile changes no byte. At a
// decision point each tile still running is finished when its own RMSE, related to the mean
// luminance of the whole image (not of the tile: a dark tile's error counts as little as it
// shows), is at most the target; a finished tile gets no more passes. When every tile meets it,
// the image's relative RMSE does too.
inline constexpr int kAdaptiveTileSize = 32;
std::vector<Tile> adaptiveTiles(int width, int height);

struct TileDecisions {
    // Over the whole image.
    std::optional<ErrorEstimate> image;
    // Per tile: finished now or before.
    std::vector<bool> finished;
};
// The decision at `passes` passes; `finishedBefore[i]`: tile i finished at an earlier decision
// point. Every pixel's half difference is scaled as for `passes` passes: a finished tile stopped
// at a power of two, where the scale is 1/4 as it is for any even count, so this is exact for it
// except at an odd cap, and keeps the estimate a function of the film, the decision point and
// which tiles are finished (a restarted coordinator knows those, not when each finished). Pixels
// near a finished tile's edge also hold samples of running neighbours (the reconstruction
// filter's reach), which the halves count as the tile's own: the estimate there is approximate.
TileDecisions decideTiles(const FilmBlock& film, const std::vector<Tile>& tiles,
                          const std::vector<bool>& finishedBefore, uint32_t passes,
                          double targetError);

}  // namespace alphorn
