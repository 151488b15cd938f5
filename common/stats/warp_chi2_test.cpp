// The warp chi-square helpers themselves: a right density passes, a wrong one and broken
// samples fail. (warp.h's routines are tested in common/core/warp_test.cpp.)
#include "common/stats/warp_chi2.h"

#include <gtest/gtest.h>

#include <cmath>

namespace alphorn::stats {
namespace {

WarpChi2Options small(uint64_t stream) {
    WarpChi2Options o;
    o.sampleCount = 200000;
    o.stream = stream;
    return o;
}

// Exponential free-flight distances with sigma_t = 2: the distance sampler of a homogeneous
// medium, on [0, infinity); the bins cover [0, 3] and the rest cell the tail exp(-6).
double exponentialSample(const Point2f& u) {
    return -std::log(1.0 - double(u.x())) / 2.0;
}

TEST(WarpChi2Helpers, LineAcceptsTheRightDensityAndRejectsAWrongOne) {
    auto right = [](double x) { return x >= 0 ? 2.0 * std::exp(-2.0 * x) : 0.0; };
    auto wrong = [](double x) { return x >= 0 ? 2.1 * std::exp(-2.1 * x) : 0.0; };
    Chi2Result ok = lineChi2(exponentialSample, right, 0.0, 3.0, 50, small(1));
    EXPECT_TRUE(ok.passed) << ok.message;
    Chi2Result bad = lineChi2(exponentialSample, wrong, 0.0, 3.0, 50, small(1));
    EXPECT_FALSE(bad.passed) << bad.message;
}

TEST(WarpChi2Helpers, BrokenSamplesFail) {
    PlanarGrid grid;
    auto uniform = [](double, double) { return 1.0; };
    Chi2Result outside = planarChi2([](const Point2f& u) { return Point2f(u.x() * 1.01f, u.y()); },
                                    uniform, grid, small(2));
    EXPECT_FALSE(outside.passed);
    EXPECT_NE(outside.message.find("outside the grid"), std::string::npos) << outside.message;
    Chi2Result nan = sphericalChi2(
        [](const Point2f& u) { return u.x() < 0.001f ? Vector3f(NAN, 0, 0) : Vector3f(0, 0, 1); },
        [](const Vector3f&) { return 1.0 / (4.0 * M_PI); }, SphericalGrid(), small(3));
    EXPECT_FALSE(nan.passed);
    EXPECT_NE(nan.message.find("not finite"), std::string::npos) << nan.message;
}

TEST(WarpChi2Helpers, PlanarGridCells) {
    PlanarGrid grid{-1, -1, 1, 1, 4};
    EXPECT_EQ(grid.cellOf(Point2f(-1, -1)), 0);
    EXPECT_EQ(grid.cellOf(Point2f(1, 1)), 15);  // the closed upper edge joins the last cell
    EXPECT_EQ(grid.cellOf(Point2f(0.1f, -0.4f)), 1 * 4 + 2);
    std::vector<double> cells = grid.integrate([](double, double) { return 0.25; }, 16.0);
    for (double c : cells) EXPECT_NEAR(c, 1.0, 1e-9);
}

}  // namespace
}  // namespace alphorn::stats
