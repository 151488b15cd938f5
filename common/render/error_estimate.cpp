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

}  // namespace

std::optional<ErrorEstimate> estimateError(const FilmBlock& film, const Tile& region,
                                           uint32_t passes) {
    if (passes < 2 || !film.keepsHalves()) return std::nullopt;
    const double oddPasses = passes / 2, evenPasses = passes - passes / 2;
    // Var(Y_even - Y_odd) = s^2 (1/n_even + 1/n_odd); the full image's variance is s^2 / n.
    const double scale = evenPasses * oddPasses / (double(passes) * double(passes));
    // Sums in a fixed pixel order: the same film gives the same bits.
    double squaredDifferences = 0.0, luminanceSum = 0.0;
    uint64_t pixels = 0;
    for (int y = region.y0; y < region.y1; ++y)
        for (int x = region.x0; x < region.x1; ++x) {
            if (!film.contains(x, y)) continue;
            const PixelSum& total = film.at(x, y);
            const PixelSum& odd = film.oddAt(x, y);
            const PixelSum even = difference(total, odd);
            if (odd.weight <= 0 || even.weight <= 0) continue;
            const double delta = pixelLuminance(even) - pixelLuminance(odd);
            squaredDifferences += delta * delta;
            luminanceSum += pixelLuminance(total);
            ++pixels;
        }
    if (pixels == 0) return std::nullopt;
    ErrorEstimate estimate;
    estimate.passes = passes;
    estimate.pixels = pixels;
    estimate.meanLuminance = luminanceSum / double(pixels);
    if (!(estimate.meanLuminance > 0.0) || !std::isfinite(squaredDifferences)) return std::nullopt;
    estimate.relativeRmse =
        std::sqrt(scale * squaredDifferences / double(pixels)) / estimate.meanLuminance;
    return estimate;
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
    const double ratio = estimate.relativeRmse / targetError;
    return std::max(double(estimate.passes), double(estimate.passes) * ratio * ratio);
}

}  // namespace alphorn
