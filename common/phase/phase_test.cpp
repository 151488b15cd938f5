// Phase functions against their own densities (chi-square), against closed forms (normalisation,
// mean cosine = g, the forward fraction for g = 0.9, which catches a flipped sign
// that the furnace cannot see) and at the edges of the parameter range.
#include "common/phase/phase.h"
#include "common/core/rng.h"
#include "common/stats/sidak.h"
#include "common/stats/spherical_histogram.h"
#include "common/stats/warp_chi2.h"
#include "common/texture/plugin_testing.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

std::shared_ptr<PhaseFunction> hg(float g) {
    return parseAs<PhaseFunction>(
        "hg.xml",
        absl::StrFormat("<phase type=\"hg\"><float name=\"g\" value=\"%.9g\"/></phase>", g));
}

// An incident direction that is not aligned with any axis, so frame bugs show.
const Vector3f kWi = Vector3f(0.3f, -0.5f, 0.81f).normalized();

TEST(PhaseFunction, ChiSquareAgainstOwnPdf) {
    std::vector<std::shared_ptr<PhaseFunction>> phases = {
        parseAs<PhaseFunction>("iso.xml", "<phase type=\"isotropic\"/>"), hg(0.0f), hg(0.3f),
        hg(-0.7f), hg(0.9f)};
    const double alpha = stats::sidakAlpha(0.01, static_cast<int>(phases.size()));
    for (size_t i = 0; i < phases.size(); ++i) {
        const PhaseFunction& phase = *phases[i];
        stats::WarpChi2Options options;
        options.sampleCount = 400000;
        options.alpha = alpha;
        options.stream = 100 + i;
        stats::Chi2Result result = stats::sphericalChi2(
            [&](const Point2f& u) {
                Vector3f wo;
                phase.sample(kWi, wo, u);
                return wo;
            },
            [&](const Vector3f& wo) { return double(phase.pdf(kWi, wo)); }, stats::SphericalGrid(),
            options);
        EXPECT_TRUE(result.passed) << phase.toString() << ": " << result.message;
    }
}

TEST(PhaseFunction, ChiSquareRejectsTheFlippedSign) {
    // The test must have the power to tell g from -g: sampling g = 0.5 against the pdf of -0.5.
    auto forward = hg(0.5f), backward = hg(-0.5f);
    stats::WarpChi2Options options;
    options.sampleCount = 100000;
    options.stream = 7;
    stats::Chi2Result result = stats::sphericalChi2(
        [&](const Point2f& u) {
            Vector3f wo;
            forward->sample(kWi, wo, u);
            return wo;
        },
        [&](const Vector3f& wo) { return double(backward->pdf(kWi, wo)); }, stats::SphericalGrid(),
        options);
    EXPECT_FALSE(result.passed) << result.message;
}

TEST(PhaseFunction, NormalisedAndReciprocal) {
    for (float g : {0.0f, 0.5f, -0.5f, 0.8f}) {
        auto phase = hg(g);
        // A finer grid resolves the forward peak.
        stats::SphericalGrid grid;
        grid.cosThetaResolution = 200;
        grid.phiResolution = 40;
        const double integral = stats::integrateOverSphere(
            [&](const Vector3f& wo) { return double(phase->eval(kWi, wo)); }, grid);
        EXPECT_NEAR(integral, 1.0, 2e-3) << "g = " << g;
        const Vector3f a = Vector3f(0.1f, 0.7f, -0.2f).normalized();
        EXPECT_FLOAT_EQ(phase->eval(kWi, a), phase->eval(a, kWi));
        EXPECT_FLOAT_EQ(phase->eval(kWi, a), phase->pdf(kWi, a));
    }
}

// Mean cosine g and, for g = 0.9, the forward fraction 0.977097 (the integral of the density
// over cos t > 0), measured on
// the angle between the directions of travel -wi and wo. Binomial and mean tolerances are five
// standard errors.
TEST(PhaseFunction, HenyeyGreensteinMeanCosineAndForwardFraction) {
    const int n = 400000;
    for (float g : {0.9f, 0.5f, -0.6f}) {
        auto phase = hg(g);
        Rng rng(11, static_cast<uint64_t>(g * 100 + 100), 0, StreamPurpose::Test);
        double sumCos = 0.0, sumCos2 = 0.0;
        int forward = 0;
        for (int i = 0; i < n; ++i) {
            const float u1 = rng.nextFloat();
            const Point2f u(u1, rng.nextFloat());
            Vector3f wo;
            ASSERT_EQ(phase->sample(kWi, wo, u), 1.0f);
            ASSERT_NEAR(wo.norm(), 1.0f, 1e-4f);
            const double c = -kWi.dot(wo);
            sumCos += c;
            sumCos2 += c * c;
            forward += c > 0.0;
        }
        const double mean = sumCos / n, var = sumCos2 / n - mean * mean;
        EXPECT_NEAR(mean, g, 5.0 * std::sqrt(var / n)) << "g = " << g;
        if (g == 0.9f) {
            const double p = 0.977097;
            EXPECT_NEAR(double(forward) / n, p, 5.0 * std::sqrt(p * (1 - p) / n));
        }
    }
}

TEST(PhaseFunction, NearlyDeltaStaysFinite) {
    for (float g : {0.999f, -0.999f}) {
        auto phase = hg(g);
        Rng rng(3, 0, 0, StreamPurpose::Test);
        for (int i = 0; i < 100000; ++i) {
            const float u1 = rng.nextFloat();
            const Point2f u(u1, rng.nextFloat());
            Vector3f wo;
            const float weight = phase->sample(kWi, wo, u);
            ASSERT_TRUE(wo.allFinite() && std::isfinite(weight));
            const float pdf = phase->pdf(kWi, wo);
            ASSERT_TRUE(std::isfinite(pdf) && pdf > 0.0f) << pdf;
        }
        // The peak (1 + |g|) / (4 pi (1 - |g|)^2) is large but finite.
        const Vector3f peak = g > 0 ? Vector3f(-kWi) : kWi;
        EXPECT_NEAR(phase->eval(kWi, peak), 1.999 / (4 * M_PI * 1e-6),
                    0.01 * 1.999 / (4 * M_PI * 1e-6));
    }
}

TEST(PhaseFunction, BadParametersNameTheLine) {
    expectParseError("hg_one.xml",
                     "<phase type=\"hg\">\n  <float name=\"g\" value=\"1\"/>\n</phase>", 1,
                     "g must be in the open interval (-1, 1), got 1");
    expectParseError("hg_minus.xml",
                     "<phase type=\"hg\"><float name=\"g\" value=\"-1.5\"/></phase>", 1,
                     "got -1.5");
    expectParseError("hg_nan.xml", "<phase type=\"hg\"><float name=\"g\" value=\"nan\"/></phase>",
                     1, "got nan");
}

}  // namespace
}  // namespace alphorn
