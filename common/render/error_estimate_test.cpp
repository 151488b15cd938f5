// The error estimate from the film's halves by pass parity: its arithmetic on hand-made films,
// its decision points, its agreement with the true error of a path-traced image (against an
// independent long reference), and that the halves and the stopping pass depend on nothing but
// the scene, seed and target (threads and tiles change no byte).
#include "common/render/error_estimate.h"

#include "common/integrator/integrator.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

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
    return loadScene(ALPHORN_SOURCE_DIR "/tests/integration/scenes/farm_path.xml", {}, overrides);
}

std::vector<double> luminances(const FilmBlock& film, int width, int height) {
    const Image image = resolveImage(film, width, height);
    std::vector<double> values;
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) values.push_back(image.get(x, y).luminance());
    return values;
}

// The estimate against the truth: the relative RMSE of renders of n passes against a reference
// of N passes made with another seed. The reference's own noise adds n/N of the render's mean
// squared error to the measured one (same per-pass variance, independent), which is taken out.
// Unbiased path tracing: the estimate must be within 25% of the truth, for each seed.
TEST(ErrorEstimate, MatchesTheTrueErrorOfAnUnbiasedRender) {
    const int width = 40, height = 30;
    const uint32_t passes = 16, referencePasses = 256;
    const std::shared_ptr<Scene> scene = smallPathTracedScene(width, height);
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    const std::vector<double> reference = luminances(renderLocal(*scene, settings), width, height);
    double referenceMean = 0.0;
    for (double y : reference) referenceMean += y / reference.size();
    for (uint64_t seed : {1, 2, 3, 4}) {
        settings.seed = seed;
        settings.passes = passes;
        RenderStatus status;
        const FilmBlock film = renderLocal(*scene, settings, {}, nullptr, &status);
        ASSERT_TRUE(status.estimate);
        EXPECT_EQ(status.estimate->passes, passes);
        const std::vector<double> image = luminances(film, width, height);
        double squaredError = 0.0;
        for (size_t i = 0; i < image.size(); ++i)
            squaredError += (image[i] - reference[i]) * (image[i] - reference[i]);
        squaredError /= image.size() * (1.0 + double(passes) / referencePasses);
        const double truth = std::sqrt(squaredError) / referenceMean;
        const double ratio = status.estimate->relativeRmse / truth;
        EXPECT_GT(ratio, 0.75) << "seed " << seed << ": estimate " << status.estimate->relativeRmse
                               << ", truth " << truth;
        EXPECT_LT(ratio, 1.25) << "seed " << seed << ": estimate " << status.estimate->relativeRmse
                               << ", truth " << truth;
        std::printf("seed %llu: estimated relative RMSE %.4f, true %.4f, ratio %.3f\n",
                    (unsigned long long)seed, status.estimate->relativeRmse, truth, ratio);
    }
}

// Progressive photon mapping is biased: the halves (odd and even passes, with the same shrinking
// radii) differ by noise only, so the estimate misses the bias of the radius. Measured here
// against a reference of 64 passes of the same method with another seed (a point light's
// caustic through glass, which no path tracer here renders); its radius has shrunk further, but
// it shares the bias that remains, so this bounds the estimate against the error a user can
// measure, not against the exact image. The factor is documented in docs/error-estimate.md.
TEST(ErrorEstimate, ProgressivePhotonMappingEstimateCoversTheNoiseOnly) {
    const float kRadius = 0.3f;
    const int width = 20, height = 15;
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(width, height);
    const std::shared_ptr<Scene> scene =
        loadScene(ALPHORN_SOURCE_DIR "/tests/cli/scenes/ok_photonmapper.xml", {}, overrides);
    PropertyList props;
    props.setInteger("photonCount", 2000);
    props.setFloat("surfacePhotonRadius", kRadius);
    props.setBoolean("progressive", true);
    auto integrator = std::static_pointer_cast<Integrator>(
        ObjectFactory::create(ObjectKind::Integrator, "photonmapper", props));
    integrator->activate();
    scene->setIntegrator(integrator);
    const uint32_t referencePasses = 64;
    RenderSettings settings;
    settings.seed = 1000;
    settings.passes = referencePasses;
    RenderStatus referenceStatus;
    const std::vector<double> reference =
        luminances(renderLocal(*scene, settings, {}, nullptr, &referenceStatus), width, height);
    ASSERT_TRUE(referenceStatus.estimate);
    double referenceMean = 0.0;
    for (double y : reference) referenceMean += y / reference.size();
    std::printf("photonmapper reference, %u passes: estimated relative RMSE %.4f\n",
                referencePasses, referenceStatus.estimate->relativeRmse);
    for (uint32_t passes : {4u, 16u}) {
        settings.seed = 1;
        settings.passes = passes;
        RenderStatus status;
        const std::vector<double> image =
            luminances(renderLocal(*scene, settings, {}, nullptr, &status), width, height);
        ASSERT_TRUE(status.estimate);
        double squaredError = 0.0;
        for (size_t i = 0; i < image.size(); ++i)
            squaredError += (image[i] - reference[i]) * (image[i] - reference[i]);
        const double truth = std::sqrt(squaredError / image.size()) / referenceMean;
        const double ratio = status.estimate->relativeRmse / truth;
        std::printf(
            "photonmapper, %u passes: estimated relative RMSE %.4f, true %.4f, ratio %.3f\n",
            passes, status.estimate->relativeRmse, truth, ratio);
        EXPECT_GT(ratio, 0.75) << passes << " passes";
        EXPECT_LT(ratio, 1.25) << passes << " passes";
    }
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
            settings.targetError = 0.3;
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

}  // namespace
}  // namespace alphorn
