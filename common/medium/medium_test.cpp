// Media against closed forms: Beer–Lambert transmittance, the exponential
// atmosphere's optical depth (s0/k)(e^(-k z0) - e^(-k z1)), the ratio-tracking variance
// exp(-2cd)(exp(c^2 d/mu) - 1), free-flight distances by chi-square, chromatic media per channel,
// constant heterogeneous == homogeneous, zero density == vacuum (no random numbers), dense media
// in bounded time, and the errors for bad parameters. Every random stream is fixed.
#include "common/medium/medium.h"
#include "common/core/rng.h"
#include "common/stats/chi_square.h"
#include "common/stats/sidak.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>

#include <functional>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

// Uniform numbers from a fixed stream, counting how many were drawn.
class CountingSampler : public Sampler {
  public:
    explicit CountingSampler(uint64_t stream) : m_rng(2024, 0, stream, StreamPurpose::Test) {}
    std::unique_ptr<Sampler> clone() const override {
        return std::make_unique<CountingSampler>(*this);
    }
    void startStream(uint64_t, uint64_t, uint64_t, StreamPurpose) override {}
    float next1D() override {
        ++draws;
        return m_rng.nextFloat();
    }
    Point2f next2D() override {
        const float u = next1D();
        return Point2f(u, next1D());
    }
    uint64_t draws = 0;

  private:
    Rng m_rng;
};

std::shared_ptr<Medium> homogeneous(const std::string& sigmaS, const std::string& sigmaA) {
    return parseAs<Medium>(
        "homogeneous.xml",
        absl::StrFormat("<medium type=\"homogeneous\"><color name=\"sigmaS\" value=\"%s\"/>"
                        "<color name=\"sigmaA\" value=\"%s\"/></medium>",
                        sigmaS, sigmaA));
}

// A heterogeneous medium whose sigmaS and sigmaA are constant textures. Without a declared
// majorant it is rendered as the homogeneous medium it is; pass a majorant in `extra` to test the
// tracking itself.
std::shared_ptr<Medium> constantHeterogeneous(const std::string& sigmaS, const std::string& sigmaA,
                                              const std::string& extra = "") {
    return parseAs<Medium>("constant_heterogeneous.xml",
                           absl::StrFormat("<medium type=\"heterogeneous\">%s"
                                           "<texture type=\"constant\" name=\"sigmaS\"><color "
                                           "name=\"value\" value=\"%s\"/></texture>"
                                           "<texture type=\"constant\" name=\"sigmaA\"><color "
                                           "name=\"value\" value=\"%s\"/></texture>"
                                           "</medium>",
                                           extra, sigmaS, sigmaA));
}

// Exponential atmosphere s0 exp(-k z) for z >= 0 (scattering only).
std::shared_ptr<Medium> exponentialAtmosphere(float s0, float k, bool residual) {
    return parseAs<Medium>(
        "exponential.xml",
        absl::StrFormat("<medium type=\"heterogeneous\"><boolean name=\"residual\" value=\"%s\"/>"
                        "<texture type=\"exponential3d\" name=\"sigmaS\">"
                        "<color name=\"color0\" value=\"%g\"/><color name=\"color1\" value=\"0\"/>"
                        "<float name=\"falloff\" value=\"%g\"/></texture></medium>",
                        residual ? "true" : "false", s0, k));
}

const Ray3f kRay(Point3f(0.2f, -0.1f, 0.0f), Vector3f(0.0f, 0.0f, 1.0f));

struct Moments {
    stats::RunningStats stats[3];
    void add(const Color3f& c) {
        for (int i = 0; i < 3; ++i) stats[i].add(double(c[i]));
    }
};

// Expects the per-channel means of `m` to equal `reference` (t-test, Šidák over `tests`).
void expectMeans(const Moments& m, const Color3f& reference, int tests, const std::string& what) {
    const double alpha = stats::sidakAlpha(0.01, tests);
    for (int c = 0; c < 3; ++c) {
        const stats::TTestResult r = stats::studentTTest(m.stats[c].mean, m.stats[c].variance(),
                                                         reference[c], m.stats[c].count, alpha);
        EXPECT_TRUE(r.passed) << what << " channel " << c << ": " << r.message;
    }
}

TEST(HomogeneousMedium, TransmittanceIsBeerLambertAndDrawsNothing) {
    auto medium = homogeneous("1, 2, 0", "0, 1, 0.5");
    CountingSampler sampler(1);
    const Color3f t = medium->transmittance(kRay, 0.7f, sampler);
    EXPECT_FLOAT_EQ(t[0], std::exp(-0.7f));
    EXPECT_FLOAT_EQ(t[1], std::exp(-2.1f));
    EXPECT_FLOAT_EQ(t[2], std::exp(-0.35f));
    EXPECT_EQ(sampler.draws, 0u);
    // A channel without extinction transmits everything even along an infinite ray.
    auto partial = homogeneous("1, 0, 0", "0");
    const Color3f inf = partial->transmittance(kRay, Infinity, sampler);
    EXPECT_EQ(inf[0], 0.0f);
    EXPECT_EQ(inf[1], 1.0f);
    EXPECT_EQ(inf[2], 1.0f);
    // A unit slab: e^-1 (sigmaT = 1) and e^-3 (sigmaT = 3).
    EXPECT_NEAR(homogeneous("0.5", "0.5")->transmittance(kRay, 1.0f, sampler)[0], 0.367879f, 1e-6f);
    EXPECT_NEAR(homogeneous("1", "2")->transmittance(kRay, 1.0f, sampler)[0], 0.049787f, 1e-6f);
}

// Free-flight sampling is unbiased in every channel, also with unequal extinction: the expected
// scattering weight is sigmaS/sigmaT (1 - e^(-sigmaT L)) and the expected pass-through weight
// e^(-sigmaT L), per channel. A tracer that used the chosen channel's pdf alone fails this.
void expectUnbiasedFreeFlight(const Medium& medium, const Color3f& sigmaS, const Color3f& sigmaT,
                              float length, uint64_t stream, const std::string& what) {
    Moments scattered, passed;
    CountingSampler sampler(stream);
    for (int i = 0; i < 200000; ++i) {
        int hero = -1;  // a new path each time
        const MediumSample s = medium.sampleDistance(kRay, length, sampler, hero);
        ASSERT_TRUE(s.weight.allFinite() && s.pdfRatio.allFinite());
        // The one-event path's estimate under spectral MIS.
        const Color3f estimate = s.weight / s.pdfRatio.mean();
        const bool isScatter = s.event == MediumSample::Event::Scattered;
        const bool isPass = s.event == MediumSample::Event::Passed;
        if (isScatter) {
            ASSERT_TRUE(s.t > 0.0f && s.t < length) << s.t;
        }
        scattered.add(isScatter ? estimate : Color3f(0.0f));
        passed.add(isPass ? estimate : Color3f(0.0f));
    }
    Color3f scatterRef, passRef;
    for (int c = 0; c < 3; ++c) {
        passRef[c] = std::exp(-sigmaT[c] * length);
        scatterRef[c] = sigmaT[c] > 0 ? sigmaS[c] / sigmaT[c] * (1 - passRef[c]) : 0.0f;
    }
    expectMeans(scattered, scatterRef, 6, what + " scattered");
    expectMeans(passed, passRef, 6, what + " passed");
}

TEST(HomogeneousMedium, ChromaticFreeFlightIsUnbiasedPerChannel) {
    expectUnbiasedFreeFlight(*homogeneous("1.8, 1.8, 0.2", "0.2, 0.2, 1.8"), Color3f(1.8, 1.8, 0.2),
                             Color3f(2.0f), 0.8f, 1, "grey extinction");
    expectUnbiasedFreeFlight(*homogeneous("0.5, 3, 0", "0.2, 0, 1"), Color3f(0.5, 3, 0),
                             Color3f(0.7, 3, 1), 0.9f, 2, "chromatic extinction");
}

TEST(HeterogeneousMedium, ConstantDensityEqualsHomogeneous) {
    // Delta tracking with a hero channel and spectral MIS against the homogeneous closed forms
    // (the declared majorant is the largest extinction: the tracking has no null collisions).
    expectUnbiasedFreeFlight(
        *constantHeterogeneous("0.5, 3, 0", "0.2, 0, 1", "<float name=\"majorant\" value=\"3\"/>"),
        Color3f(0.5, 3, 0), Color3f(0.7, 3, 1), 0.9f, 3, "constant heterogeneous");
    // With a larger declared majorant the tracking takes null collisions; still unbiased.
    expectUnbiasedFreeFlight(*constantHeterogeneous("1.8, 1.8, 0.2", "0.2, 0.2, 1.8",
                                                    "<float name=\"majorant\" value=\"5\"/>"),
                             Color3f(1.8, 1.8, 0.2), Color3f(2.0f), 0.8f, 4,
                             "constant heterogeneous, majorant 5");
    // Residual ratio tracking with the density's lower bound as control is exact here.
    auto residual = constantHeterogeneous(
        "0.5, 3, 0", "0.2, 0, 1",
        "<boolean name=\"residual\" value=\"true\"/><float name=\"majorant\" value=\"3\"/>");
    auto reference = homogeneous("0.5, 3, 0", "0.2, 0, 1");
    CountingSampler sampler(5);
    const Color3f a = residual->transmittance(kRay, 0.9f, sampler);
    const Color3f b = reference->transmittance(kRay, 0.9f, sampler);
    for (int c = 0; c < 3; ++c) EXPECT_EQ(a[c], b[c]);
    EXPECT_EQ(sampler.draws, 0u);
}

// Without a declared majorant a constant medium is the homogeneous one: the same numbers drawn
// and the same results, bit for bit, for free flight and transmittance alike; with one (or with
// a texture that varies) it tracks.
TEST(HeterogeneousMedium, ConstantCoefficientsRenderAsHomogeneous) {
    for (const auto& [sigmaS, sigmaA] : {std::pair("0.5, 3, 0", "0.2, 0, 1"),
                                         std::pair("1.8", "0.2"), std::pair("4, 4, 4", "0")}) {
        auto constant = constantHeterogeneous(sigmaS, sigmaA);
        auto reference = homogeneous(sigmaS, sigmaA);
        CountingSampler a(21), b(21);
        for (int i = 0; i < 2000; ++i) {
            int heroA = -1, heroB = -1;
            const float tMax = 0.1f + 0.001f * float(i);
            const MediumSample x = constant->sampleDistance(kRay, tMax, a, heroA);
            const MediumSample y = reference->sampleDistance(kRay, tMax, b, heroB);
            ASSERT_EQ(x.event, y.event) << sigmaS << " / " << sigmaA << " sample " << i;
            ASSERT_EQ(x.t, y.t);
            ASSERT_TRUE((x.weight == y.weight).all() && (x.pdfRatio == y.pdfRatio).all());
            ASSERT_TRUE(
                (constant->transmittance(kRay, tMax, a) == reference->transmittance(kRay, tMax, b))
                    .all());
        }
        EXPECT_EQ(a.draws, b.draws);
        EXPECT_EQ(constant->greyHomogeneous().has_value(),
                  reference->greyHomogeneous().has_value());
    }
    // A declared majorant keeps the tracking: its transmittance is a ratio-tracking estimate.
    auto tracked = constantHeterogeneous("1", "0", "<float name=\"majorant\" value=\"2\"/>");
    CountingSampler sampler(22);
    tracked->transmittance(kRay, 1.0f, sampler);
    EXPECT_GT(sampler.draws, 0u);
}

// Fog whose sigmaA is written exactly as its sigmaS (the stage's) evaluates the texture once
// for both, with the same numbers bit for bit as evaluating each: compared with the same fog
// whose sigmaA is the same noise written another way (min/max instead of color0/color1), which is
// evaluated on its own. Texts that differ in any value are not taken for equal.
TEST(HeterogeneousMedium, SigmaAWrittenAsSigmaSIsEvaluatedOnceWithTheSameNumbers) {
    const auto fog = [](const std::string& sigmaA) {
        const std::string noise =
            "<texture type=\"perlin3d\" name=\"sigmaS\"><!-- clouds -->\n"
            "  <float name=\"min\" value=\"0.1\"/><float name=\"max\" value=\"0.9\"/>"
            "<float name=\"frequency\" value=\"2.5\"/><integer name=\"seed\" value=\"3\"/>"
            "</texture>";
        return parseAs<Medium>("fog.xml",
                               "<medium type=\"heterogeneous\">"
                               "<float name=\"density\" value=\"1.5\"/>" +
                                   noise + sigmaA + "</medium>");
    };
    // The same element: only its name, whitespace and comments differ.
    auto shared =
        fog("<texture name=\"sigmaA\"   type=\"perlin3d\">"
            "<float name=\"min\" value=\"0.1\"/>\n<float name=\"max\" value=\"0.9\"/>"
            "<float name=\"frequency\" value=\"2.5\"/><integer name=\"seed\" value=\"3\"/>"
            "</texture>");
    auto separate =
        fog("<texture type=\"perlin3d\" name=\"sigmaA\">"
            "<color name=\"color0\" value=\"0.1\"/><color name=\"color1\" value=\"0.9\"/>"
            "<float name=\"frequency\" value=\"2.5\"/><integer name=\"seed\" value=\"3\"/>"
            "</texture>");
    auto otherSeed =
        fog("<texture type=\"perlin3d\" name=\"sigmaA\">"
            "<float name=\"min\" value=\"0.1\"/><float name=\"max\" value=\"0.9\"/>"
            "<float name=\"frequency\" value=\"2.5\"/><integer name=\"seed\" value=\"4\"/>"
            "</texture>");
    const std::string once = "written as sigmaS: evaluated once";
    EXPECT_NE(shared->toString().find(once), std::string::npos) << shared->toString();
    EXPECT_EQ(separate->toString().find(once), std::string::npos) << separate->toString();
    EXPECT_EQ(otherSeed->toString().find(once), std::string::npos) << otherSeed->toString();

    CountingSampler a(31), b(31), c(31);
    int differences = 0;
    for (int i = 0; i < 4000; ++i) {
        const Ray3f ray(Point3f(0.01f * float(i % 97), -0.3f, 0.02f * float(i % 31)),
                        Vector3f(0.3f, 0.2f, 1.0f).normalized());
        const float tMax = 0.2f + 0.001f * float(i);
        int heroA = -1, heroB = -1, heroC = -1;
        const MediumSample x = shared->sampleDistance(ray, tMax, a, heroA);
        const MediumSample y = separate->sampleDistance(ray, tMax, b, heroB);
        const MediumSample z = otherSeed->sampleDistance(ray, tMax, c, heroC);
        ASSERT_EQ(x.event, y.event) << "sample " << i;
        ASSERT_EQ(x.t, y.t) << "sample " << i;
        ASSERT_TRUE((x.weight == y.weight).all() && (x.pdfRatio == y.pdfRatio).all());
        ASSERT_TRUE(
            (shared->transmittance(ray, tMax, a) == separate->transmittance(ray, tMax, b)).all())
            << "sample " << i;
        differences += x.event != z.event || x.t != z.t;
        otherSeed->transmittance(ray, tMax, c);
    }
    EXPECT_EQ(a.draws, b.draws);
    EXPECT_GT(differences, 100) << "a different seed gave the same fog";
}

// Ratio tracking with density c under majorant mu along d: mean e^(-cd), variance
// e^(-2cd)(e^(c^2 d / mu) - 1). The variance of the sample variance is estimated
// from the fourth central moment.
TEST(HeterogeneousMedium, RatioTrackingMeanAndVarianceMatchTheFormula) {
    const double c = 1.0, mu = 2.0, d = 1.0;
    auto medium = constantHeterogeneous("1", "0", "<float name=\"majorant\" value=\"2\"/>");
    CountingSampler sampler(6);
    const int n = 400000;
    std::vector<double> values(n);
    for (int i = 0; i < n; ++i) values[i] = medium->transmittance(kRay, float(d), sampler)[1];
    const stats::MeanVariance mv = stats::meanAndVariance(values.data(), values.size());
    double m4 = 0.0;
    for (double v : values) m4 += std::pow(v - mv.mean, 4);
    m4 /= n;
    const double expectedMean = std::exp(-c * d);
    const double expectedVariance = std::exp(-2 * c * d) * (std::exp(c * c * d / mu) - 1);
    EXPECT_NEAR(mv.mean, expectedMean, 5 * std::sqrt(mv.variance / n));
    const double varianceError = std::sqrt((m4 - mv.variance * mv.variance) / n);
    EXPECT_NEAR(mv.variance, expectedVariance, 5 * varianceError)
        << "expected " << expectedVariance << ", got " << mv.variance;
    // About mu d = 2 tentative collisions per estimate, never more than the Poisson tail allows.
    EXPECT_NEAR(double(sampler.draws) / n, mu * d + 1, 0.02);
}

// The exponential atmosphere s0 e^(-kz) from z0 to z1: optical depth (s0/k)(e^(-k z0) - e^(-k z1)).
TEST(HeterogeneousMedium, ExponentialDensityOpticalDepth) {
    const float s0 = 2.0f, k = 1.5f, z0 = 0.2f, z1 = 1.7f;
    const double tau = s0 / k * (std::exp(-k * z0) - std::exp(-k * z1));
    const Ray3f ray(Point3f(0.3f, 0.4f, z0), Vector3f(0, 0, 1));
    double variance[2];
    for (bool residual : {false, true}) {
        auto medium = exponentialAtmosphere(s0, k, residual);
        CountingSampler sampler(7 + residual);
        Moments m;
        for (int i = 0; i < 200000; ++i) m.add(medium->transmittance(ray, z1 - z0, sampler));
        expectMeans(m, Color3f(float(std::exp(-tau))), 6,
                    residual ? "residual ratio tracking" : "ratio tracking");
        variance[residual] = m.stats[0].variance();
    }
    // The exponential's lower bound is 0, so the control is 0 and both estimators are the same
    // algorithm on the same majorant: equal variance within noise.
    EXPECT_NEAR(variance[1] / variance[0], 1.0, 0.05);
}

// Residual ratio tracking measurably lowers variance where the density has a floor: a
// checkerboard of densities 2 and 3 (control 2, residual majorant 1 instead of 3).
TEST(HeterogeneousMedium, ResidualRatioTrackingLowersVariance) {
    double variance[2], mean[2];
    for (bool residual : {false, true}) {
        auto medium = parseAs<Medium>(
            "checker.xml",
            absl::StrFormat(
                "<medium type=\"heterogeneous\"><boolean name=\"residual\" value=\"%s\"/>"
                "<texture type=\"checkerboard3d\" name=\"sigmaS\"><color name=\"color0\" "
                "value=\"2\"/><color name=\"color1\" value=\"3\"/>"
                "<float name=\"scale\" value=\"0.25\"/></texture></medium>",
                residual ? "true" : "false"));
        CountingSampler sampler(9);
        Moments m;
        for (int i = 0; i < 100000; ++i) m.add(medium->transmittance(kRay, 1.0f, sampler));
        variance[residual] = m.stats[0].variance();
        mean[residual] = m.stats[0].mean;
    }
    // Along x = 0.2, y = -0.1 (cells 0 and -1 of side 0.25) the cell parity is that of
    // floor(4z) - 1: densities 3, 2, 3, 2 over the four quarters of [0, 1], optical depth 2.5.
    const double expected = std::exp(-0.25 * (3 + 2 + 3 + 2));
    EXPECT_NEAR(mean[0], expected, 5 * std::sqrt(variance[0] / 100000));
    EXPECT_NEAR(mean[1], expected, 5 * std::sqrt(variance[1] / 100000) + 1e-6);
    // Closed forms: plain e^-5 (e^(6.5/3) - 1) = 0.0521, residual e^-4 (e^-0.5 - e^-1) = 0.00437.
    EXPECT_NEAR(variance[0], 0.0521, 0.003);
    EXPECT_NEAR(variance[1], 0.00437, 0.0003);
    RecordProperty("variance_plain", std::to_string(variance[0]));
    RecordProperty("variance_residual", std::to_string(variance[1]));
}

// Free-flight distances follow sigmaT(t) exp(-tau(t)): chi-square on 30 cells of [0, L) plus a
// cell for passing through, with expected counts from the closed form T(a) - T(b). For delta
// tracking in the exponential atmosphere and for the closed-form sampling of a grey homogeneous
// medium (scattering only, so every interaction is a scattering event of weight 1).
void expectFreeFlightChiSquare(const Medium& medium, const std::function<double(double)>& tr,
                               float length, uint64_t stream) {
    const int bins = 30, n = 300000;
    std::vector<double> observed(bins + 1, 0.0), expected(bins + 1, 0.0);
    CountingSampler sampler(stream);
    for (int i = 0; i < n; ++i) {
        int hero = -1;
        const MediumSample s = medium.sampleDistance(kRay, length, sampler, hero);
        ASSERT_NE(s.event, MediumSample::Event::Absorbed);  // no absorption in these media
        ASSERT_NEAR(s.weight[0], 1.0f, 1e-5f);              // grey, albedo 1
        if (s.event == MediumSample::Event::Passed)
            observed[bins] += 1;
        else
            observed[std::min(bins - 1, int(s.t / length * bins))] += 1;
    }
    for (int b = 0; b < bins; ++b)
        expected[b] = n * (tr(length * b / bins) - tr(length * (b + 1) / bins));
    expected[bins] = n * tr(length);
    const stats::Chi2Result r = stats::chi2Test(observed, expected, n, 5, 0.01 / 2);
    EXPECT_TRUE(r.passed) << medium.toString() << ": " << r.message;
}

TEST(Medium, FreeFlightDistancesChiSquare) {
    const float s0 = 3.0f, k = 2.0f;
    expectFreeFlightChiSquare(
        *exponentialAtmosphere(s0, k, false),
        [&](double t) { return std::exp(-s0 / k * (1 - std::exp(-k * t))); }, 1.5f, 10);
    expectFreeFlightChiSquare(
        *homogeneous("2", "0"), [](double t) { return std::exp(-2.0 * t); }, 1.2f, 13);
}

// A medium that does not interact draws no random numbers, so it renders exactly like vacuum.
TEST(Medium, ZeroDensityIsVacuum) {
    std::vector<std::shared_ptr<Medium>> media = {
        homogeneous("0", "0"),
        constantHeterogeneous("1, 2, 3", "4", "<float name=\"density\" value=\"0\"/>"),
        parseAs<Medium>("vacuum.xml", "<medium type=\"vacuum\"/>")};
    for (const auto& medium : media) {
        EXPECT_TRUE(medium->isVacuum()) << medium->toString();
        CountingSampler sampler(11);
        int hero = -1;
        const MediumSample s = medium->sampleDistance(kRay, 5.0f, sampler, hero);
        EXPECT_EQ(s.event, MediumSample::Event::Passed);
        EXPECT_TRUE((s.weight == Color3f(1.0f)).all());
        EXPECT_TRUE((medium->transmittance(kRay, Infinity, sampler) == Color3f(1.0f)).all());
        EXPECT_EQ(sampler.draws, 0u);
    }
}

// sigma_t d = 1e4: finite results in bounded work; transmittance 0 (e^-1e4 underflows exactly
// as it should); scattering happens within the first few mean free paths.
TEST(Medium, DenseMediaStayFiniteAndBounded) {
    auto dense = homogeneous("5000, 5000, 100", "5000, 5000, 9900");
    // Tracked (a declared majorant): a constant one would be rendered as the homogeneous one.
    auto denseHeterogeneous = constantHeterogeneous("5000, 5000, 100", "5000, 5000, 9900",
                                                    "<float name=\"majorant\" value=\"1e4\"/>");
    for (const auto& medium : {dense, denseHeterogeneous}) {
        CountingSampler sampler(12);
        for (int i = 0; i < 10000; ++i) {
            int hero = -1;
            const MediumSample s = medium->sampleDistance(kRay, 1.0f, sampler, hero);
            ASSERT_TRUE(s.weight.allFinite());
            ASSERT_TRUE(std::isfinite(s.t));
            const Color3f t = medium->transmittance(kRay, 1.0f, sampler);
            ASSERT_TRUE(t.allFinite());
            ASSERT_LT(t.maxCoeff(), 1e-30f);
        }
        // Homogeneous: 1 number per sample (grey: no hero channel; closed-form transmittance).
        // Heterogeneous: 4 (the hero channel; majorant == sigma_t, so the first tentative
        // collision is real, 2 numbers; ratio tracking stops at its first step, 1 number).
        EXPECT_LT(sampler.draws, 10000u * 5) << medium->toString();
    }
}

// Factors of 0.6 (sigma 4e5 under a majorant of 1e6) take the estimate down to the smallest
// subnormal float within ~200 steps, where 0.6 times it rounds back to itself: without Russian
// roulette every estimate then walked all ~10^6 steps of majorant * distance.
TEST(HeterogeneousMedium, RatioTrackingStopsOnceTheEstimateIsNegligible) {
    auto medium = constantHeterogeneous("4e5", "0", "<float name=\"majorant\" value=\"1e6\"/>");
    CountingSampler sampler(14);
    const int n = 1000;
    for (int i = 0; i < n; ++i) {
        const uint64_t before = sampler.draws;
        const Color3f t = medium->transmittance(kRay, 1.0f, sampler);
        // ~14 steps down to the roulette's threshold, then a few more while the roulette lasts.
        ASSERT_LT(sampler.draws - before, 200u) << "estimate " << i;
        ASSERT_TRUE((t == Color3f(0.0f)).all()) << t.toString();
    }
}

// The roulette leaves the expectation alone: sigma 7 under a majorant of 14 along d = 1 (factors
// 1/2, Poisson(14) steps) falls below the threshold in about half the estimates; the mean must
// still be e^-7.
TEST(HeterogeneousMedium, RatioTrackingRouletteKeepsTheMean) {
    auto medium = constantHeterogeneous("7", "0", "<float name=\"majorant\" value=\"14\"/>");
    CountingSampler sampler(15);
    Moments m;
    int rouletted = 0;
    for (int i = 0; i < 400000; ++i) {
        const Color3f t = medium->transmittance(kRay, 1.0f, sampler);
        // Without the roulette every estimate is a power of 1/2 of at least 2^-9 or below 10^-3;
        // a kept one is lifted to exactly 10^-3.
        if (t[0] == 1e-3f) ++rouletted;
        m.add(t);
    }
    expectMeans(m, Color3f(float(std::exp(-7.0))), 3, "ratio tracking with roulette");
    EXPECT_GT(rouletted, 1000) << "the roulette must have kept some estimates";
}

TEST(Medium, BadParametersNameTheLine) {
    expectParseError(
        "neg_sigma.xml",
        "<medium type=\"homogeneous\">\n  <color name=\"sigmaS\" value=\"1, -1, 1\"/>\n"
        "</medium>",
        1, "\"sigmaS\" must have finite components >= 0");
    expectParseError(
        "neg_sigma_het.xml",
        "<medium type=\"heterogeneous\"><color name=\"sigmaA\" value=\"-2\"/></medium>", 1,
        "\"sigmaA\" must have finite components >= 0");
    expectParseError(
        "neg_density.xml",
        "<medium type=\"heterogeneous\"><float name=\"density\" value=\"-1\"/></medium>", 1,
        "density");
    // A uv texture has no meaning at a point in space.
    expectParseError(
        "uv_density.xml",
        "<medium type=\"heterogeneous\">\n<texture type=\"uv\" name=\"sigmaS\"/></medium>", 1,
        "depends on surface uv");
    // 3e38 + 3e38 overflows: no finite bound, so no majorant.
    expectParseError(
        "unbounded.xml",
        "<medium type=\"heterogeneous\"><texture type=\"combination\" name=\"sigmaS\">"
        "<texture type=\"constant\" name=\"a\"><color name=\"value\" value=\"3e38\"/></texture>"
        "<texture type=\"constant\" name=\"b\"><color name=\"value\" value=\"3e38\"/></texture>"
        "</texture></medium>",
        1, "no finite upper bound");
    // The density can reach 4 (checkerboard up to 2, times density 2): above the declared 3.
    expectParseError("above_majorant.xml",
                     "<medium type=\"heterogeneous\">\n<float name=\"density\" value=\"2\"/>"
                     "<float name=\"majorant\" value=\"3\"/>"
                     "<texture type=\"checkerboard3d\" name=\"sigmaS\"><color name=\"color0\" "
                     "value=\"2\"/></texture></medium>",
                     1, "the density can reach 4, above the declared majorant 3");
    expectParseError(
        "wrong_name.xml",
        "<medium type=\"heterogeneous\"><texture type=\"constant\" name=\"sigmaT\"/></medium>", 1,
        "textures named \"sigmaS\" or \"sigmaA\", got \"sigmaT\"");
    expectParseError(
        "two_phases.xml",
        "<medium type=\"homogeneous\"><phase type=\"isotropic\"/><phase type=\"isotropic\"/>"
        "</medium>",
        1, "more than one phase function");
}

}  // namespace
}  // namespace alphorn
