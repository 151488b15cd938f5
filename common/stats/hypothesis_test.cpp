// The statistical machinery against textbook table values and closed forms.
#include "common/stats/chi_square.h"
#include "common/stats/integrate.h"
#include "common/stats/sidak.h"
#include "common/stats/spherical_histogram.h"
#include "common/stats/student_t.h"

#include <gtest/gtest.h>

#include <cmath>

namespace alphorn::stats {
namespace {

TEST(StudentT, TwoSidedPValueMatchesTables) {
    // Critical values of Student's t for a two-sided 5% / 1% test.
    EXPECT_NEAR(studentTTwoSidedPValue(12.706, 1), 0.05, 1e-4);
    EXPECT_NEAR(studentTTwoSidedPValue(2.228, 10), 0.05, 1e-4);
    EXPECT_NEAR(studentTTwoSidedPValue(3.169, 10), 0.01, 1e-4);
    EXPECT_NEAR(studentTTwoSidedPValue(2.042, 30), 0.05, 1e-4);
    // Large dof: the normal distribution.
    EXPECT_NEAR(studentTTwoSidedPValue(1.959964, 1e7), 0.05, 1e-5);
    EXPECT_NEAR(studentTTwoSidedPValue(2.575829, 1e7), 0.01, 1e-5);
    EXPECT_DOUBLE_EQ(studentTTwoSidedPValue(0.0, 100), 1.0);
    EXPECT_EQ(studentTTwoSidedPValue(INFINITY, 100), 0.0);
    EXPECT_TRUE(std::isnan(studentTTwoSidedPValue(NAN, 100)));
    // Far tails stay positive and accurate instead of rounding to zero.
    EXPECT_GT(studentTTwoSidedPValue(30.0, 1e5), 0.0);  // ~1e-197
}

TEST(StudentT, TestStatisticAndDecision) {
    // t = |1.01 - 1| * sqrt(10000 / 0.25) = 2: p = 0.0455 (normal), passes at 1%, fails at 5%.
    TTestResult r = studentTTest(1.01, 0.25, 1.0, 10000, 0.01);
    EXPECT_NEAR(r.t, 2.0, 1e-9);
    EXPECT_NEAR(r.pValue, 0.0455, 2e-4);
    EXPECT_TRUE(r.passed) << r.message;
    EXPECT_FALSE(studentTTest(1.01, 0.25, 1.0, 10000, 0.05).passed);
    // Zero variance is floored at 1e-5 (Nori): an exact match passes, a tiny offset does not.
    EXPECT_TRUE(studentTTest(2.0, 0.0, 2.0, 100000, 0.01).passed);
    EXPECT_FALSE(studentTTest(2.001, 0.0, 2.0, 100000, 0.01).passed);
}

TEST(StudentT, NonFiniteStatisticsFail) {
    // NaN compares false with everything, so a naive "p < alpha -> fail" lets it pass.
    EXPECT_FALSE(studentTTest(NAN, 0.1, 1.0, 1000, 0.01).passed);
    EXPECT_FALSE(studentTTest(1.0, NAN, 1.0, 1000, 0.01).passed);
    EXPECT_FALSE(studentTTest(INFINITY, 0.1, 1.0, 1000, 0.01).passed);
    EXPECT_FALSE(studentTTest(1.0, INFINITY, 1.0, 1000, 0.01).passed);
    EXPECT_FALSE(studentTTest(1.0, 0.1, NAN, 1000, 0.01).passed);
    EXPECT_NE(studentTTest(NAN, 0.1, 1.0, 1000, 0.01).message.find("non-finite"),
              std::string::npos);
}

TEST(StudentT, MeanAndVariance) {
    const double values[] = {1.0, 2.0, 3.0, 4.0};
    MeanVariance mv = meanAndVariance(values, 4);
    EXPECT_DOUBLE_EQ(mv.mean, 2.5);
    EXPECT_DOUBLE_EQ(mv.variance, 5.0 / 3.0);
    const double withNan[] = {1.0, NAN, 3.0};
    EXPECT_TRUE(std::isnan(meanAndVariance(withNan, 3).mean));
}

TEST(StudentT, ChunkedRunningStatsMatchOnePass) {
    std::vector<double> values;
    for (int i = 0; i < 10007; ++i) values.push_back(std::sin(i * 0.37) * 3.0 + 1e3);
    MeanVariance one = meanAndVariance(values.data(), values.size());
    RunningStats total;
    for (size_t begin = 0; begin < values.size(); begin += 1000) {
        RunningStats chunk;
        for (size_t k = begin; k < std::min(values.size(), begin + 1000); ++k) chunk.add(values[k]);
        total.merge(chunk);
    }
    EXPECT_EQ(total.count, values.size());
    EXPECT_NEAR(total.mean, one.mean, 1e-9);
    EXPECT_NEAR(total.variance(), one.variance, 1e-9);
    RunningStats empty;
    empty.merge(RunningStats());
    EXPECT_EQ(empty.count, 0u);
    EXPECT_EQ(empty.variance(), 0.0);
}

TEST(Sidak, CorrectedLevels) {
    EXPECT_DOUBLE_EQ(sidakAlpha(0.01, 1), 0.01);
    EXPECT_NEAR(sidakAlpha(0.05, 2), 1.0 - std::sqrt(0.95), 1e-15);
    EXPECT_NEAR(sidakAlpha(0.01, 5), 1.0 - std::pow(0.99, 0.2), 1e-15);
    // m tests at alpha' reject nothing with probability exactly 1 - alpha.
    EXPECT_NEAR(std::pow(1.0 - sidakAlpha(0.01, 37), 37), 0.99, 1e-14);
}

TEST(ChiSquare, UpperTailMatchesTables) {
    EXPECT_NEAR(chiSquareUpperTail(3.841, 1), 0.05, 1e-4);
    EXPECT_NEAR(chiSquareUpperTail(6.635, 1), 0.01, 1e-4);
    EXPECT_NEAR(chiSquareUpperTail(18.307, 10), 0.05, 1e-4);
    EXPECT_NEAR(chiSquareUpperTail(23.209, 10), 0.01, 1e-4);
    EXPECT_NEAR(chiSquareUpperTail(124.342, 100), 0.05, 1e-4);
    // Two degrees of freedom: P(X >= x) = exp(-x / 2) exactly.
    EXPECT_NEAR(chiSquareUpperTail(10.0, 2), std::exp(-5.0), 1e-12);
    EXPECT_DOUBLE_EQ(chiSquareUpperTail(0.0, 5), 1.0);
}

TEST(ChiSquare, PearsonStatistic) {
    // (10 - 20)^2 / 20 + 0 + (30 - 20)^2 / 20 = 10 with 2 dof: p = exp(-5).
    Chi2Result r = chi2Test({10, 20, 30}, {20, 20, 20}, 60, 5, 0.01);
    EXPECT_DOUBLE_EQ(r.statistic, 10.0);
    EXPECT_EQ(r.dof, 2);
    EXPECT_NEAR(r.pValue, std::exp(-5.0), 1e-12);
    EXPECT_FALSE(r.passed) << r.message;
    EXPECT_TRUE(chi2Test({10, 20, 30}, {20, 20, 20}, 60, 5, 0.005).passed);
    Chi2Result exact = chi2Test({20, 20, 20}, {20, 20, 20}, 60, 5, 0.01);
    EXPECT_DOUBLE_EQ(exact.pValue, 1.0);
    EXPECT_TRUE(exact.passed);
}

TEST(ChiSquare, PoolsSmallExpectedCells) {
    // Cells 1, 2, 3 expect 1, 2, 3 (< 5): pooled in increasing order until the pool reaches 5,
    // i.e. 1 + 2 + 3 = 6 with observed 0 + 2 + 4 = 6. The pool and cells 0, 4 give 3 terms.
    Chi2Result r = chi2Test({50, 0, 2, 4, 44}, {50, 1, 2, 3, 44}, 100, 5, 0.01);
    EXPECT_EQ(r.pooledCells, 3);
    EXPECT_EQ(r.dof, 2);
    EXPECT_DOUBLE_EQ(r.statistic, 0.0);
    // A cell of expected 5 or more after the pool is complete is not pooled.
    Chi2Result r2 = chi2Test({1, 9, 30, 30}, {1, 9, 30, 30}, 70, 5, 0.01);
    EXPECT_EQ(r2.pooledCells, 2);  // 1 is pooled, then 9 joins because the pool is still < 5
    EXPECT_EQ(r2.dof, 2);
}

TEST(ChiSquare, RejectsSamplesWhereThePdfIsZero) {
    Chi2Result r = chi2Test({100, 100, 5}, {102.5, 102.5, 0}, 205, 5, 0.01);
    EXPECT_FALSE(r.passed);
    EXPECT_NE(r.message.find("integrates to 0"), std::string::npos) << r.message;
    // Too few cells left to test anything.
    EXPECT_FALSE(chi2Test({10}, {10}, 10, 5, 0.01).passed);
    EXPECT_FALSE(chi2Test({10, NAN}, {10, 10}, 20, 5, 0.01).passed);
}

TEST(Integrate, AdaptiveSimpson) {
    EXPECT_NEAR(adaptiveSimpson([](double x) { return std::sin(x); }, 0.0, M_PI), 2.0, 1e-8);
    EXPECT_NEAR(adaptiveSimpson([](double x) { return std::exp(-x * x); }, -6.0, 6.0),
                std::sqrt(M_PI), 1e-8);
    // A step inside the interval: the depth limit bounds both the work and the error.
    EXPECT_NEAR(adaptiveSimpson([](double x) { return x < 0.3 ? 1.0 : 0.0; }, 0.0, 1.0), 0.3, 1e-3);
    EXPECT_NEAR(adaptiveSimpson2D([](double x, double y) { return x * y; }, 0, 0, 1, 2), 1.0,
                1e-10);
    EXPECT_NEAR(adaptiveSimpson2D([](double x, double y) { return std::cos(x) * std::exp(y); }, 0,
                                  -1, 1, 1),
                std::sin(1.0) * (std::exp(1.0) - std::exp(-1.0)), 1e-8);
}

TEST(Integrate, SphericalGrid) {
    SphericalGrid grid;
    EXPECT_EQ(grid.cellOf(Vector3f(0, 0, 1)), (grid.cosThetaResolution - 1) * grid.phiResolution);
    EXPECT_EQ(grid.cellOf(Vector3f(1, 0, 0)), 5 * grid.phiResolution);
    EXPECT_EQ(grid.cellOf(Vector3f(0, -1, 0)), 5 * grid.phiResolution + 15);
    // Uniform density: every cell holds 1/200 of the sphere, and the total is 1.
    auto uniform = [](const Vector3f&) { return 1.0 / (4.0 * M_PI); };
    std::vector<double> cells = expectedFrequencies(grid, uniform, 200.0);
    for (double c : cells) EXPECT_NEAR(c, 1.0, 1e-9);
    EXPECT_NEAR(integrateOverSphere(uniform), 1.0, 1e-9);
    // A cosine lobe integrates to pi over the upper hemisphere.
    EXPECT_NEAR(integrateOverSphere([](const Vector3f& w) { return std::max(0.0f, w.z()); }), M_PI,
                1e-6);
    // With a restricted range the rest cell takes what lies outside it.
    SphericalGrid cap;
    cap.cosThetaMin = 0.5;
    EXPECT_EQ(cap.cellOf(Vector3f(1, 0, 0)), cap.gridCells());
    std::vector<double> capCells = expectedFrequencies(cap, uniform, 1.0);
    EXPECT_NEAR(capCells.back(), 0.75, 1e-9);
    EXPECT_NEAR(integrateOverSphere(uniform, cap), 1.0, 1e-9);
}

}  // namespace
}  // namespace alphorn::stats
