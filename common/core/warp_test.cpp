// Chi-square tests of every sampling routine in warp.h against its pdf (Nori's warptest, run
// as unit tests): histogram many samples on a grid and compare with the pdf integrated over
// each cell. Plus: every pdf integrates to 1, and a wrong pdf is rejected (so the machinery can
// fail). Streams are fixed, so each test gives the same verdict every run.
#include "common/core/warp.h"
#include "common/stats/chi_square.h"
#include "common/stats/integrate.h"
#include "common/stats/sidak.h"
#include "common/stats/spherical_histogram.h"
#include "common/stats/warp_chi2.h"

#include <gtest/gtest.h>

#include <functional>
#include <iostream>

namespace alphorn {
namespace {

constexpr int kSampleCount = 1000000;
constexpr double kSignificance = 0.01;
// Šidák over the chi-square tests that are expected to pass in this file, so that the chance
// of a correct warp failing anywhere here is 1%.
constexpr int kPassingChi2Tests = 14;  // 4 planar, 3 spherical, 2 caps, 5 Beckmann

double alpha() {
    return stats::sidakAlpha(kSignificance, kPassingChi2Tests);
}

// Each test draws from its own fixed stream `id`, so tests do not share samples.
stats::WarpChi2Options options(uint64_t id) {
    stats::WarpChi2Options o;
    o.sampleCount = kSampleCount;
    o.alpha = alpha();
    o.stream = id;
    return o;
}

stats::Chi2Result planarChi2(uint64_t id, const std::function<Point2f(const Point2f&)>& warp,
                             const std::function<double(double, double)>& pdf,
                             const stats::PlanarGrid& grid) {
    stats::Chi2Result r = stats::planarChi2(warp, pdf, grid, options(id));
    std::cout << "  " << r.message << "\n";
    return r;
}

stats::Chi2Result sphericalChi2(uint64_t id, const std::function<Vector3f(const Point2f&)>& warp,
                                const std::function<double(const Vector3f&)>& pdf,
                                const stats::SphericalGrid& grid = stats::SphericalGrid()) {
    stats::Chi2Result r = stats::sphericalChi2(warp, pdf, grid, options(id));
    std::cout << "  " << r.message << "\n";
    return r;
}

double sum(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v) s += x;
    return s;
}

// Beckmann mass beyond tan^2(theta) = 9 alpha^2 is exp(-9): bin [cos theta(3 alpha), 1] finely
// and leave the rest (~1e-4 of the samples) to the rest cell.
stats::SphericalGrid beckmannGrid(float alpha) {
    stats::SphericalGrid grid;
    grid.cosThetaMin = 1.0 / std::sqrt(1.0 + 9.0 * alpha * alpha);
    return grid;
}

double trianglePdf(double u, double v) {
    return u >= 0 && v >= 0 && u + v <= 1 ? 2.0 : 0.0;
}

TEST(WarpChi2, UniformSquare) {
    auto r =
        planarChi2(1, warp::squareToUniformSquare,
                   [](double x, double y) { return warp::squareToUniformSquarePdf(Point2f(x, y)); },
                   {0, 0, 1, 1});
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, Tent) {
    auto r = planarChi2(2, warp::squareToTent,
                        [](double x, double y) { return warp::squareToTentPdf(Point2f(x, y)); },
                        {-1, -1, 1, 1});
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, UniformDisk) {
    auto r =
        planarChi2(3, warp::squareToUniformDisk,
                   [](double x, double y) { return warp::squareToUniformDiskPdf(Point2f(x, y)); },
                   {-1, -1, 1, 1});
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, UniformTriangle) {
    // Barycentrics (u, v) are uniform over the unit triangle u, v >= 0, u + v <= 1: density 2.
    auto r = planarChi2(4, warp::squareToUniformTriangle, trianglePdf, {0, 0, 1, 1});
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, UniformSphere) {
    auto r = sphericalChi2(5, warp::squareToUniformSphere,
                           [](const Vector3f& w) { return warp::squareToUniformSpherePdf(w); });
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, UniformHemisphere) {
    auto r = sphericalChi2(6, warp::squareToUniformHemisphere,
                           [](const Vector3f& w) { return warp::squareToUniformHemispherePdf(w); });
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, CosineHemisphere) {
    auto r = sphericalChi2(7, warp::squareToCosineHemisphere,
                           [](const Vector3f& w) { return warp::squareToCosineHemispherePdf(w); });
    EXPECT_TRUE(r.passed) << r.message;
}

TEST(WarpChi2, UniformSphereCap) {
    // A narrow cap on a grid over the cap itself, and a wide cap whose edge cuts through cells.
    const float narrow = 0.9f, wide = -0.3f;
    stats::SphericalGrid capGrid;
    capGrid.cosThetaMin = narrow;
    auto r1 = sphericalChi2(
        8, [&](const Point2f& u) { return warp::squareToUniformSphereCap(u, narrow); },
        [&](const Vector3f& w) { return warp::squareToUniformSphereCapPdf(w, narrow); }, capGrid);
    EXPECT_TRUE(r1.passed) << r1.message;
    auto r2 = sphericalChi2(
        9, [&](const Point2f& u) { return warp::squareToUniformSphereCap(u, wide); },
        [&](const Vector3f& w) { return warp::squareToUniformSphereCapPdf(w, wide); });
    EXPECT_TRUE(r2.passed) << r2.message;
}

class WarpBeckmann : public ::testing::TestWithParam<float> {};

TEST_P(WarpBeckmann, Chi2) {
    const float a = GetParam();
    auto r = sphericalChi2(
        10 + static_cast<uint64_t>(a * 1000),
        [&](const Point2f& u) { return warp::squareToBeckmann(u, a); },
        [&](const Vector3f& m) { return warp::squareToBeckmannPdf(m, a); }, beckmannGrid(a));
    EXPECT_TRUE(r.passed) << "alpha " << a << ": " << r.message;
}

TEST_P(WarpBeckmann, PdfIntegratesToOne) {
    const float a = GetParam();
    const double total = stats::integrateOverSphere(
        [&](const Vector3f& m) { return warp::squareToBeckmannPdf(m, a); }, beckmannGrid(a));
    EXPECT_NEAR(total, 1.0, 1e-3) << "alpha " << a;
}

// From a near-mirror to very rough.
INSTANTIATE_TEST_SUITE_P(Alphas, WarpBeckmann, ::testing::Values(0.05f, 0.1f, 0.3f, 0.6f, 1.0f));

TEST(WarpPdf, PlanarPdfsIntegrateToOne) {
    const stats::PlanarGrid unit{0, 0, 1, 1}, centred{-1, -1, 1, 1};
    EXPECT_NEAR(
        sum(unit.integrate(
            [](double x, double y) { return warp::squareToUniformSquarePdf(Point2f(x, y)); }, 1)),
        1.0, 1e-6);
    EXPECT_NEAR(sum(centred.integrate(
                    [](double x, double y) { return warp::squareToTentPdf(Point2f(x, y)); }, 1)),
                1.0, 1e-6);
    EXPECT_NEAR(
        sum(centred.integrate(
            [](double x, double y) { return warp::squareToUniformDiskPdf(Point2f(x, y)); }, 1)),
        1.0, 1e-4);
    EXPECT_NEAR(sum(unit.integrate(trianglePdf, 1)), 1.0, 1e-4);
}

TEST(WarpPdf, SphericalPdfsIntegrateToOne) {
    EXPECT_NEAR(stats::integrateOverSphere(
                    [](const Vector3f& w) { return warp::squareToUniformSpherePdf(w); }),
                1.0, 1e-6);
    EXPECT_NEAR(stats::integrateOverSphere(
                    [](const Vector3f& w) { return warp::squareToUniformHemispherePdf(w); }),
                1.0, 1e-6);
    EXPECT_NEAR(stats::integrateOverSphere(
                    [](const Vector3f& w) { return warp::squareToCosineHemispherePdf(w); }),
                1.0, 1e-6);
    for (float cosMax : {0.9f, 0.5f, -0.3f}) {
        // A grid that starts at the cap's edge, so no cell is cut by it.
        stats::SphericalGrid grid;
        grid.cosThetaMin = cosMax;
        EXPECT_NEAR(
            stats::integrateOverSphere(
                [&](const Vector3f& w) { return warp::squareToUniformSphereCapPdf(w, cosMax); },
                grid),
            1.0, 1e-6)
            << "cosThetaMax " << cosMax;
    }
}

// Negative controls: the same machinery must reject a pdf that does not match the samples.
TEST(WarpChi2NegativeControl, CosineSamplesAgainstUniformPdf) {
    auto r = sphericalChi2(100, warp::squareToCosineHemisphere,
                           [](const Vector3f& w) { return warp::squareToUniformHemispherePdf(w); });
    EXPECT_FALSE(r.passed) << r.message;
    EXPECT_LT(r.pValue, 1e-12);
}

TEST(WarpChi2NegativeControl, BeckmannWithRoughnessOffByFivePercent) {
    // A subtle error: samples with alpha 0.3, pdf with alpha 0.315.
    auto r = sphericalChi2(
        101, [](const Point2f& u) { return warp::squareToBeckmann(u, 0.3f); },
        [](const Vector3f& m) { return warp::squareToBeckmannPdf(m, 0.315f); }, beckmannGrid(0.3f));
    EXPECT_FALSE(r.passed) << r.message;
}

TEST(WarpChi2NegativeControl, BeckmannPdfMissingTheCosine) {
    // D(m) alone, renormalised numerically: the classic bug of forgetting that Beckmann
    // sampling draws normals in proportion to D(m) cos(theta_m).
    const float a = 0.6f;
    auto d = [&](const Vector3f& m) {
        return m.z() > 0 ? warp::squareToBeckmannPdf(m, a) / m.z() : 0.0;
    };
    const double norm = stats::integrateOverSphere(d, beckmannGrid(a));
    auto r = sphericalChi2(
        102, [&](const Point2f& u) { return warp::squareToBeckmann(u, a); },
        [&](const Vector3f& m) { return d(m) / norm; }, beckmannGrid(a));
    EXPECT_FALSE(r.passed) << r.message;
}

TEST(WarpChi2NegativeControl, TentSamplesAgainstUniformPdf) {
    auto r =
        planarChi2(103, warp::squareToTent, [](double, double) { return 0.25; }, {-1, -1, 1, 1});
    EXPECT_FALSE(r.passed) << r.message;
}

}  // namespace
}  // namespace alphorn
