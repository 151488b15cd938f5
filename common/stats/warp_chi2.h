// Chi-square tests of sampling routines against their densities (Nori's warptest): draw many
// samples from a fixed random stream, histogram them, and compare with the density integrated
// over each cell. For warps on the plane, on the sphere and on a line; the HG phase function,
// free-flight distances and light emission can be tested the same way.
#pragma once

#include "common/core/common.h"
#include "common/stats/chi_square.h"
#include "common/stats/spherical_histogram.h"

#include <cstdint>
#include <functional>

namespace alphorn::stats {

// A resolution x resolution grid over [x0, x1] x [y0, y1].
struct PlanarGrid {
    double x0 = 0.0, y0 = 0.0, x1 = 1.0, y1 = 1.0;
    int resolution = 20;
    int cellCount() const { return resolution * resolution; }
    int cellOf(const Point2f& p) const;
    // scale times the integral of density over each cell.
    std::vector<double> integrate(const std::function<double(double, double)>& density,
                                  double scale) const;
};

struct WarpChi2Options {
    int sampleCount = 1000000;
    double alpha = 0.01;  // already corrected for the number of tests (sidakAlpha)
    double minExpFrequency = 5;
    uint64_t stream = 0;  // the fixed random stream (StreamPurpose::Test) of this test
};

// Each warp maps a uniform point of [0, 1)^2 to a sample. Samples that are not finite, outside
// the grid (planar) or not unit length (spherical) make the test fail; `message` says so.
Chi2Result planarChi2(const std::function<Point2f(const Point2f&)>& warp,
                      const std::function<double(double, double)>& density, const PlanarGrid& grid,
                      const WarpChi2Options& options);

Chi2Result sphericalChi2(const std::function<Vector3f(const Point2f&)>& warp,
                         const std::function<double(const Vector3f&)>& density,
                         const SphericalGrid& grid, const WarpChi2Options& options);

// Samples on a line, binned on `bins` equal cells over [x0, x1]. Samples outside go to a rest
// cell whose expected count is what the density leaves outside [x0, x1], computed as 1 minus
// the integral inside -- so pass a normalised density (check that separately), e.g. for
// exponential free-flight distances on [0, infinity).
Chi2Result lineChi2(const std::function<double(const Point2f&)>& warp,
                    const std::function<double(double)>& density, double x0, double x1, int bins,
                    const WarpChi2Options& options);

}  // namespace alphorn::stats
