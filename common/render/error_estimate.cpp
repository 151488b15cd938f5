#include "common/render/error_estimate.h"

#include <algorithm>
#include <cmath>

namespace alphorn {

namespace {

// Luminance with the weights of Color3f::luminance(), in double.
double luminance(double r, double g, double b) {
    return 0.212671 * r + 0.715160 * g + 0.072169 * b;
}

double pixelLuminance(const PixelSum& sum) {
    const double w = fromFixedPoint(sum.weight);
    return luminance(fromFixedPoint(sum.rgb[0]) / w, fromFixedPoint(sum.rgb[1]) / w,
                     fromFixedPoint(sum.rgb[2]) / w);
}

PixelSum difference(const PixelSum& a, const PixelSum& b) {
    PixelSum d;
    for (int c = 0; c < 3; ++c) d.rgb[c] = a.rgb[c] - b.rgb[c];
    d.weight = a.weight - b.weight;
    return d;
}

// The sums of one region of a film: squared half differences (scaled to the full pixel's
// squared error for `passes` passes), luminances and pixels counted, in a fixed pixel order (the
// same film gives the same bits).
struct RegionSums {
    double squaredError = 0.0, luminance = 0.0;
    uint64_t pixels = 0;
};

RegionSums sumRegion(const FilmBlock& film, const Tile& region, uint32_t passes) {
    const double oddPasses = passes / 2, evenPasses = passes - passes / 2;
    // Var(Y_even - Y_odd) = s^2 (1/n_even + 1/n_odd); the full image's variance is s^2 / n.
    const double scale = evenPasses * oddPasses / (double(passes) * double(passes));
    RegionSums sums;
    for (int y = region.y0; y < region.y1; ++y)
        for (int x = region.x0; x < region.x1; ++x) {
            if (!film.contains(x, y)) continue;
            const PixelSum& total = film.at(x, y);
            const PixelSum& odd = film.oddAt(x, y);
            const PixelSum even = difference(total, odd);
            if (odd.weight <= 0 || even.weight <= 0) continue;
            const double delta = pixelLuminance(even) - pixelLuminance(odd);
            sums.squaredError += scale * delta * delta;
            sums.luminance += pixelLuminance(total);
            ++sums.pixels;
        }
    return sums;
}

std::optional<ErrorEstimate> makeEstimate(const RegionSums& sums, uint32_t passes) {
    if (sums.pixels == 0) return std::nullopt;
    ErrorEstimate estimate;
    estimate.passes = passes;
    estimate.pixels = sums.pixels;
    estimate.meanLuminance = sums.luminance / double(sums.pixels);
    if (!(estimate.meanLuminance > 0.0) || !std::isfinite(sums.squaredError)) return std::nullopt;
    estimate.relativeRmse =
        std::sqrt(sums.squaredError / double(sums.pixels)) / estimate.meanLuminance;
    return estimate;
}

}  // namespace

std::optional<ErrorEstimate> estimateError(const FilmBlock& film, const Tile& region,
                                           uint32_t passes) {
    if (passes < 2 || !film.keepsHalves()) return std::nullopt;
    return makeEstimate(sumRegion(film, region, passes), passes);
}

std::vector<Tile> adaptiveTiles(int width, int height) {
    return makeTiles(width, height, kAdaptiveTileSize);
}

TileDecisions decideTiles(const FilmBlock& film, const std::vector<Tile>& tiles,
                          const std::vector<bool>& finishedBefore, uint32_t passes,
                          double targetError) {
    TileDecisions decisions;
    decisions.finished = finishedBefore;
    decisions.finished.resize(tiles.size(), false);
    if (passes < 2 || !film.keepsHalves()) return decisions;
    std::vector<RegionSums> sums(tiles.size());
    RegionSums image;
    for (size_t i = 0; i < tiles.size(); ++i) {
        sums[i] = sumRegion(film, tiles[i], passes);
        image.squaredError += sums[i].squaredError;
        image.luminance += sums[i].luminance;
        image.pixels += sums[i].pixels;
    }
    decisions.image = makeEstimate(image, passes);
    if (!decisions.image) return decisions;
    const double limit = targetError * decisions.image->meanLuminance;
    for (size_t i = 0; i < tiles.size(); ++i)
        if (!decisions.finished[i] && sums[i].pixels > 0 &&
            std::sqrt(sums[i].squaredError / double(sums[i].pixels)) <= limit)
            decisions.finished[i] = true;
    return decisions;
}

std::optional<double> fitSlope(const std::vector<ErrorEstimate>& history) {
    const size_t count = std::min<size_t>(3, history.size());
    if (count < 2) return std::nullopt;
    double sumX = 0, sumY = 0, sumXX = 0, sumXY = 0;
    for (size_t i = history.size() - count; i < history.size(); ++i) {
        if (!(history[i].relativeRmse > 0.0) || history[i].passes == 0) return std::nullopt;
        const double x = std::log(double(history[i].passes)), y = std::log(history[i].relativeRmse);
        sumX += x;
        sumY += y;
        sumXX += x * x;
        sumXY += x * y;
    }
    const double denominator = count * sumXX - sumX * sumX;
    if (!(denominator > 0.0)) return std::nullopt;
    const double slope = (count * sumXY - sumX * sumY) / denominator;
    return std::clamp(slope, kSteepestSlope, kShallowestSlope);
}

uint32_t nextDecisionPasses(uint32_t passesDone, uint32_t cap) {
    uint64_t decision = 4;
    while (decision <= passesDone) decision *= 2;
    return static_cast<uint32_t>(std::min<uint64_t>(decision, cap));
}

bool isDecisionPasses(uint32_t passes, uint32_t cap) {
    return passes == cap || (passes < cap && passes >= 4 && (passes & (passes - 1)) == 0);
}

bool reachesTarget(const std::optional<ErrorEstimate>& estimate, double targetError) {
    return estimate && estimate->relativeRmse <= targetError;
}

double projectedPasses(const ErrorEstimate& estimate, double targetError) {
    const double slope = estimate.slope.value_or(-0.5);
    const double passes =
        double(estimate.passes) * std::pow(targetError / estimate.relativeRmse, 1.0 / slope);
    return std::max(double(estimate.passes), std::isfinite(passes) ? passes : HUGE_VAL);
}

}  // namespace alphorn
