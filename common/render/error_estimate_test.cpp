// The error estimate from the film's halves by pass parity: its arithmetic on hand-made films,
// its decision points, its agreement with the true error of a path-traced image (against an
// independent long reference) and of a sobol render (against the spread over seeds), and that
// the halves and the stopping pass depend on nothing but the scene, seed and target (threads and
// tiles change no byte).
#include "common/render/error_estimate.h"

#include "common/integrator/integrator.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cmath>

namespace alphorn {
namespace {

void setPixel(PixelSum& sum, double luminanceValue, double weight) {
    // Grey: the luminance weights sum to 1.
    for (int c = 0; c < 3; ++c) sum.rgb[c] = toFixedPoint(luminanceValue * weight);
    sum.weight = toFixedPoint(weight);
}

// Two pixels whose even and odd halves differ by known amounts: with n_even = n_odd the squared
// error of the full pixel is (Y_even - Y_odd)^2 / 4, related to the mean luminance.
TEST(ErrorEstimate, ArithmeticOnAHandMadeFilm) {
    FilmBlock film(0, 0, 2, 1);
    PixelSum odd0, odd1, even0, even1;
    setPixel(odd0, 1.0, 2.0);
    setPixel(even0, 3.0, 2.0);  // difference 2
    setPixel(odd1, 2.0, 2.0);
    setPixel(even1, 2.0, 2.0);  // difference 0
    film.oddAt(0, 0) = odd0;
    film.oddAt(1, 0) = odd1;
    film.at(0, 0) = odd0;
    film.at(0, 0) += even0;
    film.at(1, 0) = odd1;
    film.at(1, 0) += even1;
    const auto estimate = estimateError(film, Tile{0, 0, 2, 1}, 4);
    ASSERT_TRUE(estimate);
    EXPECT_EQ(estimate->pixels, 2u);
    EXPECT_NEAR(estimate->meanLuminance, 2.0, 1e-5);
    // sqrt(mean(2^2 / 4, 0)) / 2
    EXPECT_NEAR(estimate->relativeRmse, std::sqrt(0.5) / 2.0, 1e-5);
    // 3 passes: 2 even, 1 odd; the full pixel's variance is s^2/3 where the difference's is
    // s^2 (1/2 + 1) = 3 s^2 / 2: the factor is 2/9.
    const auto threePasses = estimateError(film, Tile{0, 0, 2, 1}, 3);
    ASSERT_TRUE(threePasses);
    EXPECT_NEAR(threePasses->relativeRmse, std::sqrt(4.0 * 2.0 / 9.0 / 2.0) / 2.0, 1e-5);
}

// A one-pixel film of 4 passes whose even and odd halves have luminances `even` and `odd` (weight
// 2 each).
FilmBlock onePixelFilm(double even, double odd) {
    FilmBlock film(0, 0, 1, 1);
    PixelSum evenSum;
    setPixel(evenSum, even, 2.0);
    setPixel(film.oddAt(0, 0), odd, 2.0);
    film.at(0, 0) = film.oddAt(0, 0);
    film.at(0, 0) += evenSum;
    return film;
}

// The bias estimates' arithmetic: the difference's expected noise taken out, divided by the
// fraction of the bias the difference holds, related to the mean; and noise and bias adding in
// quadrature.
TEST(ErrorEstimate, BiasArithmeticOnHandMadeFilms) {
    const Tile pixel{0, 0, 1, 1};
    const FilmBlock film = onePixelFilm(2.0, 2.0);
    // Two radii without noise: Y(r) - Y(r / sqrt 2) = 0.2 is half the bias: 0.4, over the mean 2.
    const auto twoRadii = estimateRelativeBiasTwoRadii(film, onePixelFilm(1.8, 1.8), pixel, 4);
    ASSERT_TRUE(twoRadii);
    EXPECT_NEAR(*twoRadii, 0.2, 1e-6);
    // The same mean difference (0.2) from halves differing by 0.4: (0.4)^2 / 4 of expected noise
    // is all of the squared difference; nothing is left for bias.
    const auto noisy = estimateRelativeBiasTwoRadii(film, onePixelFilm(2.0, 1.6), pixel, 4);
    ASSERT_TRUE(noisy);
    EXPECT_NEAR(*noisy, 0.0, 1e-6);
    // Temporal, 4 passes at alpha 1/2: r^2 is 1, 3/4, 5/8, 35/64 of r_1^2; rho = (7/8) / (187/256).
    const double rho = (7.0 / 8.0) / (187.0 / 256.0);
    EXPECT_NEAR(temporalBiasRatio(4, 0.5), rho, 1e-12);
    const auto temporal = estimateRelativeBiasTemporal(film, onePixelFilm(2.5, 2.5), pixel, 4, 0.5);
    ASSERT_TRUE(temporal);
    EXPECT_NEAR(*temporal, 0.5 / (rho - 1.0) / 2.0, 1e-5);
    EXPECT_FALSE(estimateRelativeBiasTemporal(film, film, pixel, 2, 0.5)) << "no earlier point";
    EXPECT_FALSE(estimateRelativeBiasTwoRadii(film, FilmBlock(0, 0, 1, 1), pixel, 4))
        << "no samples at the second radius";
    ErrorEstimate noise;
    noise.relativeRmse = 0.03;
    const ErrorEstimate total = withBias(noise, 0.04);
    EXPECT_NEAR(total.relativeRmse, 0.05, 1e-12);
    ASSERT_TRUE(total.relativeBias);
    EXPECT_EQ(*total.relativeBias, 0.04);
}

TEST(ErrorEstimate, NothingWithoutTwoHalvesOrLight) {
    FilmBlock film(0, 0, 2, 2);
    EXPECT_FALSE(estimateError(film, Tile{0, 0, 2, 2}, 4)) << "no samples";
    setPixel(film.at(0, 0), 1.0, 1.0);
    EXPECT_FALSE(estimateError(film, Tile{0, 0, 2, 2}, 4)) << "no odd samples";
    EXPECT_FALSE(estimateError(film, Tile{0, 0, 2, 2}, 1)) << "one pass";
    FilmBlock black(0, 0, 1, 1);
    setPixel(black.at(0, 0), 0.0, 2.0);
    setPixel(black.oddAt(0, 0), 0.0, 1.0);
    EXPECT_FALSE(estimateError(black, Tile{0, 0, 1, 1}, 2)) << "a black image";
    EXPECT_FALSE(estimateError(FilmBlock(0, 0, 1, 1, PassHalves::None), Tile{0, 0, 1, 1}, 4));
}

TEST(ErrorEstimate, DecisionPointsAreFixedInAdvance) {
    EXPECT_EQ(nextDecisionPasses(0, 100), 4u);
    EXPECT_EQ(nextDecisionPasses(3, 100), 4u);
    EXPECT_EQ(nextDecisionPasses(4, 100), 8u);
    EXPECT_EQ(nextDecisionPasses(32, 100), 64u);
    EXPECT_EQ(nextDecisionPasses(64, 100), 100u);
    EXPECT_EQ(nextDecisionPasses(100, 100), 100u);
    EXPECT_EQ(nextDecisionPasses(0, 3), 3u);
    EXPECT_EQ(nextDecisionPasses(0xC0000000u, 0xFFFFFFFFu), 0xFFFFFFFFu);
    for (uint32_t p : {4u, 8u, 64u, 100u}) EXPECT_TRUE(isDecisionPasses(p, 100)) << p;
    for (uint32_t p : {1u, 2u, 3u, 6u, 12u, 128u}) EXPECT_FALSE(isDecisionPasses(p, 100)) << p;
    EXPECT_TRUE(isDecisionPasses(2, 2));
}

TEST(ErrorEstimate, ProjectsPassesAtTheMonteCarloRate) {
    ErrorEstimate estimate;
    estimate.passes = 16;
    estimate.relativeRmse = 0.04;
    EXPECT_DOUBLE_EQ(projectedPasses(estimate, 0.02), 64.0);
    EXPECT_DOUBLE_EQ(projectedPasses(estimate, 0.08), 16.0) << "never fewer than done";
    EXPECT_TRUE(reachesTarget(estimate, 0.04));
    EXPECT_FALSE(reachesTarget(estimate, 0.039));
    EXPECT_FALSE(reachesTarget(std::nullopt, 1.0));
}

// Diffuse surfaces under an area light, path_mis (the farm tests' scene), at a small size.
std::shared_ptr<Scene> smallPathTracedScene(int width, int height) {
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(width, height);
    return loadScene(sourcePath("tests/integration/scenes/farm_path.xml"), {}, overrides);
}

std::vector<double> luminances(const FilmBlock& film, int width, int height) {
    const Image image = resolveImage(film, width, height);
    std::vector<double> values;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) values.push_back(image.get(x, y).luminance());
    return values;
}

double mean(const std::vector<double>& values) {
    double sum = 0.0;
    for (double value : values) sum += value;
    return sum / double(values.size());
}

// The relative RMSE of `image` against `reference`, its squared error divided by
// `referenceNoiseFactor` (1 + n/N for a reference of N passes of the same per-pass variance and
// another seed: its own noise adds n/N of the render's squared error).
double trueRelativeRmse(const std::vector<double>& image, const std::vector<double>& reference,
                        double referenceNoiseFactor = 1.0) {
    double squaredError = 0.0;
    for (size_t i = 0; i < image.size(); ++i)
        squaredError += (image[i] - reference[i]) * (image[i] - reference[i]);
    return std::sqrt(squaredError / image.size() / referenceNoiseFactor) / mean(reference);
}

// The estimate is accurate over seeds when log(estimate / truth), one value per seed, has mean
// zero (Student's t-test, two-sided, at 1%) and its mean lies within log(1.25) of zero
// (equivalence: the one-sided t-tests that the mean is above -log(1.25) and below log(1.25) both
// reject at 5%). An estimate scaled by 1.3 fails the second.
inline constexpr double kStatedAccuracy = 1.25;

struct RatioTest {
    bool unbiased = false, withinAccuracy = false;
    double meanLogRatio = 0.0;
    std::string message;
};

RatioTest testLogRatios(const std::vector<double>& logRatios) {
    const stats::MeanVariance moments = stats::meanAndVariance(logRatios.data(), logRatios.size());
    const double n = double(logRatios.size());
    const double standardError = std::sqrt(moments.variance / n);
    RatioTest result;
    result.meanLogRatio = moments.mean;
    // Log ratios are of order 0.1: the t-test's variance floor (1e-5) is far below their
    // variance, so it compares with the measured one.
    const stats::TTestResult zero =
        stats::studentTTest(moments.mean, moments.variance, 0.0, logRatios.size(), 0.01);
    result.unbiased = zero.passed;
    const double margin = std::log(kStatedAccuracy) - std::abs(moments.mean);
    const double t = standardError > 0.0 ? margin / standardError : HUGE_VAL;
    const double oneSidedP = t > 0.0 ? 0.5 * stats::studentTTwoSidedPValue(t, n - 1.0) : 1.0;
    result.withinAccuracy = margin > 0.0 && oneSidedP < 0.05;
    char line[256];
    std::snprintf(line, sizeof line,
                  "mean log(estimate/truth) %.4f (ratio %.3f), standard error %.4f over %zu seeds; "
                  "t-test against 0: %s; within log(%.2f): one-sided p %.3g",
                  moments.mean, std::exp(moments.mean), standardError, logRatios.size(),
                  zero.passed ? "passed" : "failed", kStatedAccuracy, oneSidedP);
    result.message = line;
    return result;
}

// The estimate against the truth: the relative RMSE of renders of n passes against a reference
// of N passes made with another seed, the reference's own noise taken out. Unbiased path
// tracing: over eight seeds, the estimate / truth ratio is 1 and within the stated accuracy.
TEST(ErrorEstimateAccuracy, MatchesTheTrueErrorOfAnUnbiasedRender) {
    const int width = 40, height = 30;
    const uint32_t passes = 16, referencePasses = 256;
    const std::shared_ptr<Scene> scene = smallPathTracedScene(width, height);
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    const std::vector<double> reference = luminances(renderLocal(*scene, settings), width, height);
    std::vector<double> logRatios;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        settings.seed = seed;
        settings.passes = passes;
        RenderStatus status;
        const FilmBlock film = renderLocal(*scene, settings, {}, nullptr, &status);
        ASSERT_TRUE(status.estimate);
        EXPECT_EQ(status.estimate->passes, passes);
        EXPECT_FALSE(status.estimate->relativeBias) << "an unbiased render has no bias estimate";
        const double truth = trueRelativeRmse(luminances(film, width, height), reference,
                                              1.0 + double(passes) / referencePasses);
        logRatios.push_back(std::log(status.estimate->relativeRmse / truth));
        std::printf("seed %llu: estimated relative RMSE %.4f, true %.4f, ratio %.3f\n",
                    (unsigned long long)seed, status.estimate->relativeRmse, truth,
                    status.estimate->relativeRmse / truth);
    }
    const RatioTest test = testLogRatios(logRatios);
    std::printf("%s\n", test.message.c_str());
    EXPECT_TRUE(test.unbiased) << test.message;
    EXPECT_TRUE(test.withinAccuracy) << test.message;
}

// A sphere's soft shadow under an area light, direct light only (direct_mats: the light sample
// is a 2D draw of its own, so the stratification of a sampler decides the noise of the
// penumbra), with the given sampler: scenes/seed/sampler_independent.xml's subject.
std::shared_ptr<Scene> softShadowScene(const std::string& sampler, int width, int height) {
    const std::string xml = absl::StrFormat(R"(<scene>
  <integrator type="direct_mats"/>
  <sampler type="%s"/>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 2.5, 4" target="0, 0.3, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="40"/>
    <integer name="width" value="%d"/><integer name="height" value="%d"/>
  </camera>
  <mesh type="obj">
    <string name="filename" value="%s/scenes/meshes/quad.obj"/>
    <transform name="toWorld"><scale value="5, 1, 5"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.6"/></bsdf>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="%s/scenes/meshes/quad.obj"/>
    <transform name="toWorld"><rotate axis="1, 0, 0" angle="180"/><translate value="0, 2.5, 0"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0"/></bsdf>
    <emitter type="area"><color name="radiance" value="4, 4, 4"/></emitter>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="%s/scenes/meshes/sphere.obj"/>
    <transform name="toWorld"><scale value="0.5, 0.5, 0.5"/><translate value="0, 0.5, 0"/></transform>
    <bsdf type="diffuse"><color name="albedo" value="0.7"/></bsdf>
  </mesh>
</scene>)",
                                            sampler, width, height, sourceDirectory(),
                                            sourceDirectory(), sourceDirectory());
    return loadScene(plugin_testing::writeTempFile("soft_shadow_" + sampler + ".xml", xml));
}

// The estimate reads the error from the film's halves by pass parity, which is right only when
// the halves are independent estimates of the image. A quasi-Monte Carlo sampler whose pass is
// one sequence's sample index makes them complementary strata (the even passes in one half of
// every draw, the odd ones in the other), and their difference tends to that of two
// half-domain integrals, not to the error: on this soft shadow at 64 passes such an estimate is
// 1.78 times the truth (sobol with the pass as the sample index fails this test). sobol's
// replicates per pass parity make the halves independent (measured: 1.007).
// The truth here is the spread of the renders over seeds, which needs no reference whose own
// error would have to be known (an RQMC reference's error falls at a rate of its own): the
// sampler is unbiased, so a pixel's mean squared error is its variance over seeds, estimated
// without bias by the sample variance of 16 renders; the relative RMSE divides the root of its
// mean over the pixels by the mean luminance. Averaged over 1200 pixels, that truth's own error
// is a few per cent in the squared error, small against the accuracy tested. Over those 16
// seeds the mean of log(estimate / truth) must be 0 and within the stated accuracy
// (testLogRatios).
TEST(ErrorEstimateAccuracy, MatchesTheTrueErrorOfASobolRender) {
    const int width = 40, height = 30, seeds = 16;
    const uint32_t passes = 64;
    const std::shared_ptr<Scene> scene = softShadowScene("sobol", width, height);
    RenderSettings settings;
    settings.passes = passes;
    std::vector<std::vector<double>> images;
    std::vector<double> estimates;
    for (uint64_t seed = 1; seed <= uint64_t(seeds); ++seed) {
        settings.seed = seed;
        RenderStatus status;
        const FilmBlock film = renderLocal(*scene, settings, {}, nullptr, &status);
        ASSERT_TRUE(status.estimate);
        EXPECT_EQ(status.estimate->passes, passes);
        estimates.push_back(status.estimate->relativeRmse);
        images.push_back(luminances(film, width, height));
    }
    double meanSquaredError = 0.0, meanLuminance = 0.0;
    for (size_t pixel = 0; pixel < images[0].size(); ++pixel) {
        double sum = 0.0, sum2 = 0.0;
        for (const std::vector<double>& image : images) {
            sum += image[pixel];
            sum2 += image[pixel] * image[pixel];
        }
        const double pixelMean = sum / seeds;
        meanSquaredError += (sum2 - seeds * pixelMean * pixelMean) / (seeds - 1);
        meanLuminance += pixelMean;
    }
    meanSquaredError /= double(images[0].size());
    meanLuminance /= double(images[0].size());
    const double truth = std::sqrt(meanSquaredError) / meanLuminance;
    std::vector<double> logRatios;
    for (size_t i = 0; i < estimates.size(); ++i) {
        logRatios.push_back(std::log(estimates[i] / truth));
        std::printf("seed %zu: estimated relative RMSE %.4f, true %.4f, ratio %.3f\n", i + 1,
                    estimates[i], truth, estimates[i] / truth);
    }
    const RatioTest test = testLogRatios(logRatios);
    std::printf("%s\n", test.message.c_str());
    EXPECT_TRUE(test.unbiased) << test.message;
    EXPECT_TRUE(test.withinAccuracy) << test.message;
}

std::shared_ptr<Integrator> progressivePhotonMapper(int photons, float radius,
                                                    const char* directLight = "nee") {
    PropertyList props;
    props.setInteger("photonCount", photons);
    props.setFloat("surfacePhotonRadius", radius);
    props.setBoolean("progressive", true);
    props.setString("directLight", directLight);
    auto integrator = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, "photonmapper", props));
    integrator->activate();
    return integrator;
}

// Progressive photon mapping is biased: the halves (odd and even passes, with the same shrinking
// radii) differ by noise only, so the noise estimate misses the bias of the radius. Measured here
// against a reference of 64 passes of the same method with another seed (a point light's
// caustic through glass, which no path tracer here renders), its own estimated noise taken out;
// its radius has shrunk further, but it shares the bias that remains, so this bounds the
// estimate against the error a user can measure, not against the exact image: on this scene
// (20x15, 2000 photons per pass, initial radius 0.3) that error is the noise, and the noise
// estimate must be within its stated accuracy over eight seeds.
TEST(ErrorEstimateAccuracy, ProgressivePhotonMappingNoiseEstimateMatchesAShortRender) {
    const int width = 20, height = 15;
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(width, height);
    const std::shared_ptr<Scene> scene =
        loadScene(sourcePath("tests/cli/scenes/ok_photonmapper.xml"), {}, overrides);
    scene->setIntegrator(progressivePhotonMapper(2000, 0.3f));
    const uint32_t referencePasses = 64, passes = 16;
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    RenderStatus referenceStatus;
    const std::vector<double> reference =
        luminances(renderLocal(*scene, settings, {}, nullptr, &referenceStatus), width, height);
    ASSERT_TRUE(referenceStatus.estimate);
    const double referenceNoise = referenceStatus.estimate->relativeNoise();
    std::vector<double> logRatios;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        settings.seed = seed;
        settings.passes = passes;
        RenderStatus status;
        const std::vector<double> image =
            luminances(renderLocal(*scene, settings, {}, nullptr, &status), width, height);
        ASSERT_TRUE(status.estimate);
        const double measured = trueRelativeRmse(image, reference);
        const double truth =
            std::sqrt(std::max(0.0, measured * measured - referenceNoise * referenceNoise));
        // The film also estimates the radius's bias; the reference shares it, so the noise is
        // what is compared here.
        ASSERT_TRUE(status.estimate->relativeBias);
        const double noise = status.estimate->relativeNoise();
        logRatios.push_back(std::log(noise / truth));
        std::printf("photonmapper seed %llu, %u passes: estimated %.4f, true %.4f, ratio %.3f\n",
                    (unsigned long long)seed, passes, noise, truth, noise / truth);
    }
    const RatioTest test = testLogRatios(logRatios);
    std::printf("%s\n", test.message.c_str());
    EXPECT_TRUE(test.unbiased) << test.message;
    EXPECT_TRUE(test.withinAccuracy) << test.message;
}

// Where the radius's bias dominates, the noise estimate is far below the truth and the estimate
// with the bias added is not: diffuse surfaces under an area light (farm_path.xml, 40x30), all
// light from photons (directLight "photons": the sphere's shadow and the light's falloff are
// blurred by the gather disk), 20,000 photons per pass, a first radius of 0.6 on a floor 8
// wide, against an unbiased path-traced reference of 512 passes (its own noise taken out). Over
// eight seeds of 16 passes, log(noise estimate / truth) is far from zero (the t-test rejects it;
// measured ratio 0.38), while the noise with the two-radii bias estimate added has mean zero and
// lies within the stated accuracy (measured 1.01, standard error 0.034 in the log). The temporal
// estimate is printed beside it: as accurate on average (1.02) but with 3.5 times the spread
// (0.12), and 0 on one seed of eight, which is why the two radii were chosen.
TEST(ErrorEstimateAccuracy, BiasEstimateCoversTheRadiusBiasOfProgressivePhotonMapping) {
    const int width = 40, height = 30;
    const float radius = 0.6f;
    const uint32_t passes = 16, referencePasses = 512;
    const std::shared_ptr<Scene> scene = smallPathTracedScene(width, height);
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    RenderStatus referenceStatus;
    const std::vector<double> reference =
        luminances(renderLocal(*scene, settings, {}, nullptr, &referenceStatus), width, height);
    ASSERT_TRUE(referenceStatus.estimate);
    const double referenceNoise = referenceStatus.estimate->relativeRmse;
    scene->setIntegrator(progressivePhotonMapper(20000, radius, "photons"));
    const Tile region{0, 0, width, height};
    std::vector<double> noiseLogRatios, temporalLogRatios, twoRadiiLogRatios;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        settings.seed = seed;
        settings.passes = passes;
        RenderStatus status;
        const FilmBlock film = renderLocal(*scene, settings, {}, nullptr, &status);
        ASSERT_TRUE(status.estimate);
        ASSERT_TRUE(film.keepsSmallerRadius());
        settings.passes = passes / 2;
        const FilmBlock earlier = renderLocal(*scene, settings);
        const double measured = trueRelativeRmse(luminances(film, width, height), reference);
        const double truth =
            std::sqrt(std::max(0.0, measured * measured - referenceNoise * referenceNoise));
        // The render's own estimate: the film keeps the smaller radius's image, gathered from
        // the same camera paths and photons, and adds the two-radii bias to the noise.
        const auto twoRadii = status.estimate->relativeBias;
        const auto temporal = estimateRelativeBiasTemporal(film, earlier, region, passes, 0.5);
        ASSERT_TRUE(twoRadii && temporal);
        const double noise = status.estimate->relativeNoise();
        const double withTwoRadii = status.estimate->relativeRmse;
        const double withTemporal = std::hypot(noise, *temporal);
        noiseLogRatios.push_back(std::log(noise / truth));
        twoRadiiLogRatios.push_back(std::log(withTwoRadii / truth));
        temporalLogRatios.push_back(std::log(withTemporal / truth));
        std::printf(
            "seed %llu: truth %.4f; noise %.4f; bias two radii %.4f (total %.4f), "
            "temporal %.4f (total %.4f)\n",
            (unsigned long long)seed, truth, noise, *twoRadii, withTwoRadii, *temporal,
            withTemporal);
    }
    const RatioTest noiseTest = testLogRatios(noiseLogRatios);
    const RatioTest twoRadiiTest = testLogRatios(twoRadiiLogRatios);
    const RatioTest temporalTest = testLogRatios(temporalLogRatios);
    std::printf("noise only: %s\ntwo radii: %s\ntemporal: %s\n", noiseTest.message.c_str(),
                twoRadiiTest.message.c_str(), temporalTest.message.c_str());
    EXPECT_FALSE(noiseTest.unbiased)
        << "the noise alone must miss the truth here: " << noiseTest.message;
    EXPECT_LT(noiseTest.meanLogRatio, std::log(0.5)) << noiseTest.message;
    EXPECT_TRUE(twoRadiiTest.unbiased) << twoRadiiTest.message;
    EXPECT_TRUE(twoRadiiTest.withinAccuracy) << twoRadiiTest.message;
}

std::shared_ptr<Integrator> makeIntegrator(const char* type, const PropertyList& props) {
    auto integrator = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, type, props));
    integrator->activate();
    return integrator;
}

// The accuracy of a biased integrator's error estimate on `scene`: an unbiased reference of
// `referencePasses` with the scene's own integrator (seed 1000; its own noise taken out of each
// measured error), then `biased` over seeds 1 to 8 of `passes` each, whose films must keep the
// smaller radius's image. Returns the t-tests of log(estimate / truth) for the noise alone and
// for the noise with the two-radii bias, and prints every seed's figures.
struct BiasEstimateAccuracy {
    RatioTest noise, twoRadii;
};
BiasEstimateAccuracy measureBiasEstimate(Scene& scene, std::shared_ptr<Integrator> biased,
                                         int width, int height, uint32_t passes,
                                         uint32_t referencePasses) {
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    RenderStatus referenceStatus;
    const std::vector<double> reference =
        luminances(renderLocal(scene, settings, {}, nullptr, &referenceStatus), width, height);
    EXPECT_TRUE(referenceStatus.estimate);
    if (!referenceStatus.estimate) return {};
    const double referenceNoise = referenceStatus.estimate->relativeRmse;
    scene.setIntegrator(std::move(biased));
    std::vector<double> noiseLogRatios, twoRadiiLogRatios;
    for (uint64_t seed = 1; seed <= 8; ++seed) {
        settings.seed = seed;
        settings.passes = passes;
        RenderStatus status;
        const FilmBlock film = renderLocal(scene, settings, {}, nullptr, &status);
        EXPECT_TRUE(film.keepsSmallerRadius());
        EXPECT_TRUE(status.estimate && status.estimate->relativeBias);
        if (!status.estimate || !status.estimate->relativeBias) return {};
        const double measured = trueRelativeRmse(luminances(film, width, height), reference);
        const double truth =
            std::sqrt(std::max(0.0, measured * measured - referenceNoise * referenceNoise));
        const double noise = status.estimate->relativeNoise();
        const double withTwoRadii = status.estimate->relativeRmse;
        noiseLogRatios.push_back(std::log(noise / truth));
        twoRadiiLogRatios.push_back(std::log(withTwoRadii / truth));
        std::printf("seed %llu: truth %.4f; noise %.4f; bias two radii %.4f (total %.4f)\n",
                    (unsigned long long)seed, truth, noise, *status.estimate->relativeBias,
                    withTwoRadii);
    }
    BiasEstimateAccuracy result{testLogRatios(noiseLogRatios), testLogRatios(twoRadiiLogRatios)};
    std::printf("reference noise %.4f\nnoise only: %s\ntwo radii: %s\n", referenceNoise,
                result.noise.message.c_str(), result.twoRadii.message.c_str());
    return result;
}

// A progressive volumetric photon mapper, fixed radii, or volume radii from the volumeK nearest
// volume photons when volumeK > 0; next-event estimation on surfaces by default.
std::shared_ptr<Integrator> progressiveVolumetricPhotonMapper(int photons, float surfaceRadius,
                                                              float volumeRadius, int volumeK = 0,
                                                              const char* directLight = "nee") {
    PropertyList props;
    props.setString("directLight", directLight);
    props.setInteger("photonCount", photons);
    props.setFloat("surfacePhotonRadius", surfaceRadius);
    props.setFloat("volumePhotonRadius", volumeRadius);
    if (volumeK > 0) props.setInteger("volumeK", volumeK);
    props.setBoolean("progressive", true);
    return makeIntegrator("volumetric_photonmapper", props);
}

// The small medium scene of the farm tests (a sphere of scattering medium on a floor under an
// area light), at a small size.
std::shared_ptr<Scene> smallMediumScene(int width, int height) {
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(width, height);
    return loadScene(sourcePath("tests/integration/scenes/farm_vpm.xml"), {}, overrides);
}

// The volumetric photon mapper's bias estimate: the film's smaller-radius image gathers the
// surface disks and every photon's beam disk at half their areas. On a medium sphere (sigmaS 1,
// sigmaA 0.2, radius 0.9; farm_vpm.xml at 32x24, 10,000 photon paths per pass) whose volume
// radius starts at 0.5 (the surface radius at 0.1, direct light on the floor sampled), the beam
// estimate's blur dominates the error of 16 passes: against an unbiased volume_path_mis
// reference of 256 passes (its own noise taken out), over eight seeds, the noise estimate alone
// is 0.37 of the truth, the noise with the two-radii bias 0.90 (standard error 0.031 in the log),
// within the stated accuracy. With the beam disks left at full size in the second image (only
// the surface radius shrinks) it is 0.39 and fails.
TEST(ErrorEstimateAccuracy, BiasEstimateCoversTheVolumeRadiusBiasOfVolumetricPhotonMapping) {
    const int width = 32, height = 24;
    const std::shared_ptr<Scene> scene = smallMediumScene(width, height);
    scene->setIntegrator(makeIntegrator("volume_path_mis", PropertyList()));
    const BiasEstimateAccuracy accuracy = measureBiasEstimate(
        *scene, progressiveVolumetricPhotonMapper(10000, 0.1f, 0.5f), width, height, 16, 256);
    EXPECT_FALSE(accuracy.noise.unbiased)
        << "the noise alone must miss the truth here: " << accuracy.noise.message;
    EXPECT_LT(accuracy.noise.meanLogRatio, std::log(0.5)) << accuracy.noise.message;
    // Within the stated accuracy, not necessarily centred: the sphere's silhouette and the beams
    // entering it obliquely make the bias fall slower than r² at these radii, which the factor 2
    // of the two radii does not know (docs/error-estimate.md).
    EXPECT_TRUE(accuracy.twoRadii.withinAccuracy) << accuracy.twoRadii.message;
}

// vcm with a merge radius (connections on, the pixel count of light paths per pass).
std::shared_ptr<Integrator> vertexConnectionAndMerging(float radius) {
    PropertyList props;
    props.setFloat("radius", radius);
    return makeIntegrator("vcm", props);
}

// vcm's bias estimate: the film's smaller-radius image merges within r_i / sqrt(2), each merge
// weighted as in the image. On the diffuse scene of the photon mapper's test above (40x30,
// 1,200 light paths per pass) a first merge radius of 0.6 makes merging carry most of every
// path's MIS weight, direct light included, and its blur dominates the error of 16 passes:
// against the same unbiased path-traced reference of 512 passes (its own noise taken out), over
// eight seeds the noise estimate alone is 0.48 of the truth, the noise with the two-radii bias
// 1.04 (standard error 0.056 in the log), within the stated accuracy. With the second radius
// equal to the first the bias estimate is 0 and the test fails.
TEST(ErrorEstimateAccuracy, BiasEstimateCoversTheMergeRadiusBiasOfVcm) {
    const int width = 40, height = 30;
    const std::shared_ptr<Scene> scene = smallPathTracedScene(width, height);
    const BiasEstimateAccuracy accuracy =
        measureBiasEstimate(*scene, vertexConnectionAndMerging(0.6f), width, height, 16, 512);
    EXPECT_FALSE(accuracy.noise.unbiased)
        << "the noise alone must miss the truth here: " << accuracy.noise.message;
    EXPECT_LT(accuracy.noise.meanLogRatio, std::log(0.6)) << accuracy.noise.message;
    EXPECT_TRUE(accuracy.twoRadii.unbiased) << accuracy.twoRadii.message;
    EXPECT_TRUE(accuracy.twoRadii.withinAccuracy) << accuracy.twoRadii.message;
}

// The halves are as exact as the image: the same bytes at any thread count and tile size; and a
// target stops at the same decision point with the same bytes.
TEST(ErrorEstimate, HalvesAndStoppingPassIgnoreThreadsAndTiles) {
    const std::shared_ptr<Scene> scene = smallPathTracedScene(20, 14);
    std::string firstBytes;
    uint32_t firstStop = 0;
    std::string firstTargetBytes;
    for (int threads : {1, 2})
        for (int tile : {8, 5}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            RenderSettings settings;
            settings.seed = 7;
            settings.passes = 6;
            settings.tileSize = tile;
            settings.passesPerUnit = tile == 8 ? 4 : 1;
            const std::string bytes = renderLocal(*scene, settings).serialize();
            settings.passes = 256;
            settings.targetError = 0.25;
            RenderStatus status;
            const std::string targetBytes =
                renderLocal(*scene, settings, {}, nullptr, &status).serialize();
            ASSERT_TRUE(status.targetReached);
            if (firstBytes.empty()) {
                firstBytes = bytes;
                firstStop = status.passesDone;
                firstTargetBytes = targetBytes;
                continue;
            }
            EXPECT_EQ(bytes, firstBytes) << threads << " threads, tile " << tile;
            EXPECT_EQ(status.passesDone, firstStop) << threads << " threads, tile " << tile;
            EXPECT_EQ(targetBytes, firstTargetBytes) << threads << " threads, tile " << tile;
        }
    EXPECT_TRUE(isDecisionPasses(firstStop, 256));
    EXPECT_LT(firstStop, 256u);
    EXPECT_GT(firstStop, 4u) << "choose a target the first decision does not reach";
}

// A film with the smaller radius's image (and its bias estimate) has the same bytes at one and
// two threads and at tile sizes 8 and 5 (4 passes, seed 7).
void expectTwoRadiiFilmIgnoresThreadsAndTiles(const Scene& scene) {
    std::string firstBytes;
    for (int threads : {1, 2})
        for (int tile : {8, 5}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            RenderSettings settings;
            settings.seed = 7;
            settings.passes = 4;
            settings.tileSize = tile;
            settings.passesPerUnit = tile == 8 ? 4 : 1;
            RenderStatus status;
            const FilmBlock film = renderLocal(scene, settings, {}, nullptr, &status);
            ASSERT_TRUE(film.keepsSmallerRadius());
            ASSERT_TRUE(status.estimate && status.estimate->relativeBias);
            if (firstBytes.empty())
                firstBytes = film.serialize();
            else
                EXPECT_EQ(film.serialize(), firstBytes) << threads << " threads, tile " << tile;
        }
}

// A unit rendered into a block with the smaller radius's image and into one without: identical
// image sums, and the smaller radius's image differs from them (a different gather, not a copy).
void expectSmallerRadiusLeavesTheImageAlone(const Scene& scene) {
    const TileGrid grid(scene, 8);
    const Tile tile = grid.tiles()[3];
    const auto passData = preparePasses(scene, 7, 0, 3);
    FilmBlock twoRadii = grid.block(tile);
    ASSERT_TRUE(twoRadii.keepsSmallerRadius());
    FilmBlock oneRadius = unitBlock(tile, grid.border());
    ASSERT_FALSE(oneRadius.keepsSmallerRadius());
    ASSERT_TRUE(renderUnit(scene, 7, RenderUnit{0, 3, tile}, passData, twoRadii));
    ASSERT_TRUE(renderUnit(scene, 7, RenderUnit{0, 3, tile}, passData, oneRadius));
    const std::string imageBytes = oneRadius.serialize();
    EXPECT_EQ(twoRadii.serialize().substr(0, imageBytes.size()), imageBytes);
    EXPECT_NE(twoRadii.serialize().substr(imageBytes.size()), imageBytes);
}

// A progressive photon mapper's film keeps the smaller radius's image, as exact as the image:
// the same bytes (both radii, both halves) at any thread count and tile size, and the same
// stopping pass for a target. Gathering the second radius changes no float of the image: its
// sums equal those of a film without the second radius, and its estimate carries the bias.
TEST(ErrorEstimate, TwoRadiiSumsIgnoreThreadsAndTilesAndLeaveTheImageAlone) {
    const std::shared_ptr<Scene> scene = smallPathTracedScene(20, 14);
    EXPECT_EQ(filmSmallerRadius(*scene), SmallerRadius::None) << "a path tracer keeps one image";
    scene->setIntegrator(progressivePhotonMapper(2000, 0.6f, "photons"));
    ASSERT_EQ(filmSmallerRadius(*scene), SmallerRadius::Kept);
    std::string firstBytes, firstTargetBytes;
    uint32_t firstStop = 0;
    for (int threads : {1, 2})
        for (int tile : {8, 5}) {
            tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
            RenderSettings settings;
            settings.seed = 7;
            settings.passes = 6;
            settings.tileSize = tile;
            settings.passesPerUnit = tile == 8 ? 4 : 1;
            const FilmBlock film = renderLocal(*scene, settings);
            ASSERT_TRUE(film.keepsSmallerRadius());
            const std::string bytes = film.serialize();
            settings.passes = 64;
            settings.targetError = 0.25;
            RenderStatus status;
            const std::string targetBytes =
                renderLocal(*scene, settings, {}, nullptr, &status).serialize();
            ASSERT_TRUE(status.estimate && status.estimate->relativeBias);
            if (firstBytes.empty()) {
                firstBytes = bytes;
                firstStop = status.passesDone;
                firstTargetBytes = targetBytes;
                continue;
            }
            EXPECT_EQ(bytes, firstBytes) << threads << " threads, tile " << tile;
            EXPECT_EQ(status.passesDone, firstStop) << threads << " threads, tile " << tile;
            EXPECT_EQ(targetBytes, firstTargetBytes) << threads << " threads, tile " << tile;
        }
    EXPECT_GT(firstStop, 4u) << "choose a target the first decision does not reach";

    // The same unit rendered into a block without the smaller radius: identical image sums.
    expectSmallerRadiusLeavesTheImageAlone(*scene);
}

// The same for the volumetric photon mapper (fixed radii and volume kNN radii: the smaller image
// shrinks every photon's beam disk) and for photonmapper's progressive k nearest neighbours (the
// smaller image counts the photons of a disk of half the area of the shrunk kNN disk): the same
// bytes at any thread count and tile size, and the image's sums are those of a film without the
// smaller radius.
TEST(ErrorEstimate, TwoRadiiOfVolumeAndNearestNeighbourModesIgnoreThreadsAndLeaveTheImageAlone) {
    const std::shared_ptr<Scene> medium = smallMediumScene(20, 14);
    const std::shared_ptr<Scene> surface = smallPathTracedScene(20, 14);
    PropertyList knn;
    knn.setInteger("photonCount", 2000);
    knn.setInteger("surfaceK", 8);
    knn.setBoolean("progressive", true);
    knn.setString("directLight", "photons");
    const struct {
        const char* name;
        std::shared_ptr<Scene> scene;
        std::shared_ptr<Integrator> integrator;
    } cases[] = {
        {"volumetric_photonmapper, fixed radii", medium,
         progressiveVolumetricPhotonMapper(1000, 0.1f, 0.3f)},
        {"volumetric_photonmapper, volumeK", medium,
         progressiveVolumetricPhotonMapper(1000, 0.1f, 0.5f, 8)},
        {"photonmapper, surfaceK", surface, makeIntegrator("photonmapper", knn)},
    };
    for (const auto& c : cases) {
        SCOPED_TRACE(c.name);
        c.scene->setIntegrator(c.integrator);
        ASSERT_EQ(filmSmallerRadius(*c.scene), SmallerRadius::Kept);
        expectTwoRadiiFilmIgnoresThreadsAndTiles(*c.scene);
        expectSmallerRadiusLeavesTheImageAlone(*c.scene);
    }
}

// vcm's film keeps the smaller radius's image, light tracing's splats in both: the same bytes at
// any thread count and tile size, and the image's sums (camera samples and splats) are those of
// a unit rendered without the smaller radius. bdpt keeps one image.
TEST(ErrorEstimate, TwoRadiiOfVcmIgnoreThreadsAndTilesAndLeaveTheImageAlone) {
    const std::shared_ptr<Scene> scene = smallPathTracedScene(20, 14);
    scene->setIntegrator(makeIntegrator("bdpt", PropertyList()));
    EXPECT_EQ(filmSmallerRadius(*scene), SmallerRadius::None) << "bdpt merges nothing";
    scene->setIntegrator(vertexConnectionAndMerging(0.3f));
    ASSERT_EQ(filmSmallerRadius(*scene), SmallerRadius::Kept);
    ASSERT_TRUE(scene->integrator()->hasPassSplats());
    expectTwoRadiiFilmIgnoresThreadsAndTiles(*scene);
    expectSmallerRadiusLeavesTheImageAlone(*scene);
    const auto passData = preparePasses(*scene, 7, 0, 1);
    // Light tracing is a connection: its splats go into both images alike.
    FilmBlock splats(0, 0, 20, 14, PassHalves::None, SmallerRadius::Kept);
    scene->integrator()->addPassSplats(passData[0].get(), 0, 0, 20, 14, splats);
    bool anySplat = false;
    for (int y = 0; y < 14; ++y)
        for (int x = 0; x < 20; ++x) {
            anySplat = anySplat || splats.at(x, y).rgb[1] != 0;
            EXPECT_EQ(splats.smallerRadiusAt(x, y).rgb[1], splats.at(x, y).rgb[1]) << x << "," << y;
        }
    EXPECT_TRUE(anySplat);
}

// The bias a film's two radii show is the one estimateRelativeBiasTwoRadii finds in them, added
// to the noise in quadrature; a film without the smaller radius reports no bias.
TEST(ErrorEstimate, FilmWithTwoRadiiAddsTheBias) {
    FilmBlock film(0, 0, 2, 1, PassHalves::Kept, SmallerRadius::Kept);
    const auto set = [](PixelSum& sum, double value, double weight) {
        for (int c = 0; c < 3; ++c) sum.rgb[c] = toFixedPoint(value * weight);
        sum.weight = toFixedPoint(weight);
    };
    for (int x = 0; x < 2; ++x) {
        set(film.at(x, 0), 1.0 + 0.1 * x, 4.0);
        set(film.oddAt(x, 0), 1.05 + 0.1 * x, 2.0);
        set(film.smallerRadiusAt(x, 0), 0.8, 4.0);
        set(film.smallerRadiusOddAt(x, 0), 0.82, 2.0);
    }
    const Tile region{0, 0, 2, 1};
    const auto estimate = estimateError(film, region, 4);
    ASSERT_TRUE(estimate && estimate->relativeBias);
    const auto bias = estimateRelativeBiasTwoRadii(film, film.smallerRadiusFilm(), region, 4, 0.5);
    ASSERT_TRUE(bias);
    EXPECT_GT(*bias, 0.1);
    EXPECT_DOUBLE_EQ(*estimate->relativeBias, *bias);
    FilmBlock imageOnly(0, 0, 2, 1);
    for (int x = 0; x < 2; ++x) {
        imageOnly.at(x, 0) = film.at(x, 0);
        imageOnly.oddAt(x, 0) = film.oddAt(x, 0);
    }
    const auto noise = estimateError(imageOnly, region, 4);
    ASSERT_TRUE(noise);
    EXPECT_FALSE(noise->relativeBias);
    EXPECT_DOUBLE_EQ(estimate->relativeRmse, std::hypot(noise->relativeRmse, *bias));
    EXPECT_NEAR(estimate->relativeNoise(), noise->relativeRmse, 1e-12);
}

}  // namespace
}  // namespace alphorn
