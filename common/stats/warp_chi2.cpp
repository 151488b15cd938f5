#include "common/stats/warp_chi2.h"

#include "common/core/rng.h"
#include "common/stats/integrate.h"

#include <absl/strings/str_format.h>

namespace alphorn::stats {

namespace {

template <typename Visit>
void drawSamples(const WarpChi2Options& options, Visit&& visit) {
    Rng rng(0x3a4b, options.stream, 0, StreamPurpose::Test);
    for (int k = 0; k < options.sampleCount; ++k) {
        const float u = rng.nextFloat();  // two statements: argument order is unspecified
        visit(Point2f(u, rng.nextFloat()));
    }
}

Chi2Result withBadSamples(Chi2Result r, int bad, const char* what) {
    if (bad == 0) return r;
    r.passed = false;
    r.message = absl::StrFormat("FAIL: %d samples were %s", bad, what);
    return r;
}

}  // namespace

int PlanarGrid::cellOf(const Point2f& p) const {
    const int i = std::clamp(static_cast<int>(std::floor((p.x() - x0) / (x1 - x0) * resolution)), 0,
                             resolution - 1);
    const int j = std::clamp(static_cast<int>(std::floor((p.y() - y0) / (y1 - y0) * resolution)), 0,
                             resolution - 1);
    return j * resolution + i;
}

std::vector<double> PlanarGrid::integrate(const std::function<double(double, double)>& density,
                                          double scale) const {
    std::vector<double> cells(cellCount());
    const double dx = (x1 - x0) / resolution, dy = (y1 - y0) / resolution;
    for (int j = 0; j < resolution; ++j) {
        for (int i = 0; i < resolution; ++i) {
            // Evaluate a hair inside the cell: a support ending on a cell edge (the unit square)
            // must not leak its edge value into the neighbouring cell.
            const double cx = x0 + (i + 0.5) * dx, cy = y0 + (j + 0.5) * dy;
            auto inset = [&](double x, double y) {
                return density(x + (cx - x) * 1e-7, y + (cy - y) * 1e-7);
            };
            cells[j * resolution + i] =
                scale * adaptiveSimpson2D(inset, x0 + i * dx, y0 + j * dy, x0 + (i + 1) * dx,
                                          y0 + (j + 1) * dy);
        }
    }
    return cells;
}

Chi2Result planarChi2(const std::function<Point2f(const Point2f&)>& warp,
                      const std::function<double(double, double)>& density, const PlanarGrid& grid,
                      const WarpChi2Options& options) {
    std::vector<double> observed(grid.cellCount(), 0.0);
    int bad = 0;
    drawSamples(options, [&](const Point2f& u) {
        const Point2f p = warp(u);
        if (!p.allFinite() || p.x() < grid.x0 || p.x() > grid.x1 || p.y() < grid.y0 ||
            p.y() > grid.y1)
            ++bad;
        else
            observed[grid.cellOf(p)] += 1.0;
    });
    return withBadSamples(chi2Test(observed, grid.integrate(density, options.sampleCount),
                                   options.sampleCount, options.minExpFrequency, options.alpha),
                          bad, "not finite or outside the grid");
}

Chi2Result sphericalChi2(const std::function<Vector3f(const Point2f&)>& warp,
                         const std::function<double(const Vector3f&)>& density,
                         const SphericalGrid& grid, const WarpChi2Options& options) {
    std::vector<double> observed(grid.cellCount(), 0.0);
    int bad = 0;
    drawSamples(options, [&](const Point2f& u) {
        const Vector3f w = warp(u);
        if (!w.allFinite() || std::abs(w.norm() - 1.0f) > 1e-4f)
            ++bad;
        else
            observed[grid.cellOf(w)] += 1.0;
    });
    return withBadSamples(
        chi2Test(observed, expectedFrequencies(grid, density, options.sampleCount),
                 options.sampleCount, options.minExpFrequency, options.alpha),
        bad, "not finite or not unit length");
}

Chi2Result lineChi2(const std::function<double(const Point2f&)>& warp,
                    const std::function<double(double)>& density, double x0, double x1, int bins,
                    const WarpChi2Options& options) {
    std::vector<double> observed(bins + 1, 0.0), expected(bins + 1, 0.0);
    int bad = 0;
    drawSamples(options, [&](const Point2f& u) {
        const double x = warp(u);
        if (!std::isfinite(x))
            ++bad;
        else if (x < x0 || x >= x1)
            observed[bins] += 1.0;
        else
            observed[std::clamp(static_cast<int>((x - x0) / (x1 - x0) * bins), 0, bins - 1)] += 1.0;
    });
    const double dx = (x1 - x0) / bins;
    double inside = 0.0;
    for (int i = 0; i < bins; ++i) {
        const double a = x0 + i * dx, b = i + 1 == bins ? x1 : a + dx, c = 0.5 * (a + b);
        const double p =
            adaptiveSimpson([&](double x) { return density(x + (c - x) * 1e-7); }, a, b);
        expected[i] = options.sampleCount * p;
        inside += p;
    }
    expected[bins] = options.sampleCount * std::max(0.0, 1.0 - inside);
    return withBadSamples(
        chi2Test(observed, expected, options.sampleCount, options.minExpFrequency, options.alpha),
        bad, "not finite");
}

}  // namespace alphorn::stats
