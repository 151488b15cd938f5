#include "common/render/error_estimate.h"

#include "common/photon/radius_schedule.h"

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

// What turns a pixel's squared half difference into the squared error of its full image of
// `passes` passes: Var(Y_even - Y_odd) = s^2 (1/n_even + 1/n_odd), the full image's is s^2 / n.
double halvesScale(uint32_t passes) {
    const double oddPasses = passes / 2, evenPasses = passes - passes / 2;
    return evenPasses * oddPasses / (double(passes) * double(passes));
}

RegionSums sumRegion(const FilmBlock& film, const Tile& region, uint32_t passes) {
    const double scale = halvesScale(passes);
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

// Sums a region's squared bias signal: per pixel with samples in both halves of both films,
// difference(film, other)^2 minus its expected noise (noiseOf), with the full image's mean
// luminance; then relates it to the mean and divides by `fraction` (E[difference] = fraction *
// bias).
template <typename NoiseOf>
std::optional<double> relativeBiasFromDifferences(const FilmBlock& film, const FilmBlock& other,
                                                  const Tile& region, uint32_t passes,
                                                  double fraction, NoiseOf&& noiseOf) {
    if (passes < 2 || !film.keepsHalves() || !other.keepsHalves() || !(fraction > 0.0))
        return std::nullopt;
    double signal = 0.0, luminanceSum = 0.0;
    uint64_t pixels = 0;
    for (int y = region.y0; y < region.y1; ++y)
        for (int x = region.x0; x < region.x1; ++x) {
            if (!film.contains(x, y) || !other.contains(x, y)) continue;
            const PixelSum& total = film.at(x, y);
            const PixelSum& odd = film.oddAt(x, y);
            const PixelSum& otherTotal = other.at(x, y);
            const PixelSum& otherOdd = other.oddAt(x, y);
            const PixelSum even = difference(total, odd),
                           otherEven = difference(otherTotal, otherOdd);
            if (odd.weight <= 0 || even.weight <= 0 || otherOdd.weight <= 0 ||
                otherEven.weight <= 0)
                continue;
            const double delta = pixelLuminance(total) - pixelLuminance(otherTotal);
            signal += delta * delta - noiseOf(pixelLuminance(even), pixelLuminance(odd),
                                              pixelLuminance(otherEven), pixelLuminance(otherOdd));
            luminanceSum += pixelLuminance(total);
            ++pixels;
        }
    if (pixels == 0 || !(luminanceSum > 0.0) || !std::isfinite(signal)) return std::nullopt;
    const double mean = luminanceSum / double(pixels);
    return std::sqrt(std::max(0.0, signal / double(pixels))) / fraction / mean;
}

}  // namespace

ErrorEstimate withBias(ErrorEstimate noise, double relativeBias) {
    noise.relativeRmse = std::hypot(noise.relativeRmse, relativeBias);
    noise.relativeBias = relativeBias;
    return noise;
}

std::optional<double> estimateRelativeBiasTwoRadii(const FilmBlock& film,
                                                   const FilmBlock& smallerRadius,
                                                   const Tile& region, uint32_t passes,
                                                   double areaRatio) {
    const double scale = halvesScale(passes);
    // The difference of the two radii's images has its own halves: (D_even - D_odd)^2 scaled
    // as for an image estimates its noise (the photons they share make it smaller than either
    // image's own).
    return relativeBiasFromDifferences(
        film, smallerRadius, region, passes, 1.0 - areaRatio,
        [&](double even, double odd, double smallEven, double smallOdd) {
            const double delta = (even - smallEven) - (odd - smallOdd);
            return scale * delta * delta;
        });
}

double temporalBiasRatio(uint32_t passes, double alpha) {
    double early = 0.0, all = 0.0;
    const uint32_t half = passes / 2;
    for (uint32_t pass = 1; pass <= passes; ++pass) {
        const double r2 = progressiveRadiusSquaredRatio(pass, alpha);
        all += r2;
        if (pass <= half) early += r2;
    }
    return (early / half) / (all / passes);
}

std::optional<double> estimateRelativeBiasTemporal(const FilmBlock& film, const FilmBlock& earlier,
                                                   const Tile& region, uint32_t passes,
                                                   double alpha) {
    if (passes < 4) return std::nullopt;
    const double scale = halvesScale(passes);
    // Y_earlier - Y = (Y_first - Y_second) / 2 has the variance of Y itself.
    return relativeBiasFromDifferences(film, earlier, region, passes,
                                       temporalBiasRatio(passes, alpha) - 1.0,
                                       [&](double even, double odd, double, double) {
                                           return scale * (even - odd) * (even - odd);
                                       });
}

std::optional<ErrorEstimate> estimateError(const FilmBlock& film, const Tile& region,
                                           uint32_t passes) {
    if (passes < 2 || !film.keepsHalves()) return std::nullopt;
    std::optional<ErrorEstimate> estimate = makeEstimate(sumRegion(film, region, passes), passes);
    if (!estimate || !film.keepsSmallerRadius()) return estimate;
    // A progressive photon mapper's film: its halves see the noise only; the two radii's images
    // add the radius's bias.
    if (const auto bias = estimateRelativeBiasTwoRadii(film, film.smallerRadiusFilm(), region,
                                                       passes, kSmallerRadiusAreaRatio))
        return withBias(*estimate, *bias);
    return estimate;
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
