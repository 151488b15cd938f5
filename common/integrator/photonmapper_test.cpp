// The photonmapper integrator: parameter errors, pass data (one map, or one per pass with the
// shared radius schedule), stability where density estimation fails (no photons, fewer photons
// than k), which photons next-event estimation leaves out, the convergence rate of progressive
// photon mapping, and the convergence of progressive kNN. Its accuracy against closed forms is
// tested by the Nori-format files tests/statistical/photon_*_ttest.xml.
#include "common/core/system_memory.h"
#include "common/integrator/integrator.h"
#include "common/integrator/photon_mapping_testing.h"
#include "common/integrator/photon_pass.h"
#include "common/photon/radius_schedule.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"

#include <gtest/gtest.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

using namespace photon_testing;

class PhotonMapperTest : public PhotonMappingTest {
  protected:
    PhotonMapperTest() : PhotonMappingTest("photonmapper") {}

    void expectError(const std::string& params, const std::string& fragment) {
        try {
            load(params);
            ADD_FAILURE() << "no error for " << params;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("scene.xml:2:"), std::string::npos) << message;
            EXPECT_NE(message.find(fragment), std::string::npos) << message;
        }
    }
};

TEST_F(PhotonMapperTest, AbsurdParametersAreErrorsNamingFileAndLine) {
    expectError(integer("photonCount", 0), "photonCount");
    expectError(integer("photonCount", -5), "photonCount");
    expectError(floating("surfacePhotonRadius", "-0.1"), "surfacePhotonRadius");
    expectError(floating("surfacePhotonRadius", "0"), "surfacePhotonRadius");
    expectError(floating("surfacePhotonRadius", "nan"), "surfacePhotonRadius");
    expectError(floating("surfacePhotonRadius", "inf"), "surfacePhotonRadius");
    for (int k : {1, 0, -3}) expectError(integer("surfaceK", k), "surfaceK");
    for (const char* alpha : {"0", "1", "1.5", "-0.2", "nan"})
        expectError(floating("alpha", alpha), "alpha");
    for (const char* mode : {"both", "NEE", ""})
        expectError(std::string("<string name=\"directLight\" value=\"") + mode + "\"/>",
                    "directLight");
}

// 2^31 - 1 photon paths need at least 72 GiB (one 36-byte photon each), and k = 2^31 - 1 as
// many photons: refused when the scene loads, where they ended in a bare std::bad_alloc (36 s
// into tracing, and at once for k). Where a machine holds that much, there is nothing to refuse.
TEST_F(PhotonMapperTest, CountsBeyondMemoryAreErrorsNamingFileAndLine) {
    const uint64_t needed = uint64_t(std::numeric_limits<int>::max()) * sizeof(Photon);
    if (physicalMemoryBytes() >= needed) GTEST_SKIP() << "this machine holds " << needed;
    expectError(integer("photonCount", std::numeric_limits<int>::max()),
                "\"photonCount\" 2147483647 photon paths need at least 72.0 GiB per photon pass");
    expectError(integer("surfaceK", std::numeric_limits<int>::max()),
                "\"surfaceK\" 2147483647 asks for more photons than fit");
    // Beyond a limit, not malformed: the farm answers RESOURCE_EXHAUSTED.
    EXPECT_THROW(load(integer("photonCount", std::numeric_limits<int>::max())), ResourceLimitError);
    EXPECT_THROW(load(integer("surfaceK", std::numeric_limits<int>::max())), ResourceLimitError);
}

TEST_F(PhotonMapperTest, WithoutProgressiveEveryPassReadsOneMapPerSeed) {
    auto scene = load(integer("photonCount", 1000) + floating("surfacePhotonRadius", "0.1"));
    const Integrator& integrator = *scene->integrator();
    const auto a = integrator.preparePass(*scene, 3, 0);
    const auto b = integrator.preparePass(*scene, 3, 9);
    EXPECT_EQ(a.get(), b.get()) << "traced twice";
    EXPECT_EQ(passData(a).surfaceRadius, 0.1f);
    EXPECT_EQ(passData(a).emitted, 1000u);
    EXPECT_DOUBLE_EQ(passData(a).powerScale, 1e-3);
    const auto c = integrator.preparePass(*scene, 4, 0);
    ASSERT_FALSE(passData(c).surface.empty());
    EXPECT_NE(passData(c).surface.photons()[0].position, passData(a).surface.photons()[0].position)
        << "the seed does not reach the photons";
}

TEST_F(PhotonMapperTest, ProgressivePassesTraceTheirOwnPhotonsAtTheScheduledRadius) {
    auto scene = load(integer("photonCount", 500) + floating("surfacePhotonRadius", "0.2") +
                      floating("alpha", "0.7") + kProgressive);
    const Integrator& integrator = *scene->integrator();
    const auto first = integrator.preparePass(*scene, 3, 0);
    EXPECT_EQ(passData(first).surfaceRadius, 0.2f);
    for (uint64_t pass : {1, 7, 1000}) {
        const auto data = integrator.preparePass(*scene, 3, pass);
        EXPECT_EQ(passData(data).surfaceRadius,
                  static_cast<float>(progressiveRadius(0.2f, 0.7, pass)));
        EXPECT_NE(passData(data).surface.photons()[0].position,
                  passData(first).surface.photons()[0].position);
    }
    // The same (seed, pass) gives the same photons: any worker can build any pass.
    const auto once = integrator.preparePass(*scene, 3, 7);
    const auto twice = integrator.preparePass(*scene, 3, 7);
    const auto& p = passData(once).surface.photons();
    const auto& q = passData(twice).surface.photons();
    ASSERT_EQ(p.size(), q.size());
    EXPECT_EQ(std::memcmp(p.data(), q.data(), p.size() * sizeof(Photon)), 0);
}

TEST_F(PhotonMapperTest, NoPhotonsGiveAFiniteBlackImage) {
    // No emitter at all: the photon map is empty; kNN and fixed radius must give 0, not NaN.
    const std::string dark =
        "<camera type=\"perspective\"><integer name=\"width\" value=\"6\"/><integer "
        "name=\"height\" value=\"4\"/></camera><mesh type=\"obj\"><string name=\"filename\" "
        "value=\"" +
        kMeshes + "cube_inward.obj\"/></mesh>";
    for (const std::string& params :
         {integer("photonCount", 100), integer("photonCount", 100) + integer("surfaceK", 8),
          integer("photonCount", 100) + kProgressive}) {
        auto scene = load(params, dark);
        RenderSettings settings;
        settings.passes = 2;
        FilmBlock film = renderLocal(*scene, settings);
        EXPECT_EQ(film.invalidSamples, 0u) << params;
        Image image = resolveImage(film, 6, 4);
        for (float v : image.rgb) EXPECT_EQ(v, 0.0f) << params;
    }
}

TEST_F(PhotonMapperTest, FewerPhotonsThanKUseTheSearchRadius) {
    // ~40 photons in the whole furnace and k = 50: every kNN query finds fewer than k photons
    // within its search radius 0.5, so it must equal the fixed-radius estimate at 0.5 (same
    // seed, same photons) -- finite, and not inflated by a disk shrunk to the photons found.
    // Photons carry the direct light, so that a ray is lit above 1 only by photons.
    auto knn = load(integer("photonCount", 20) + integer("surfaceK", 50) +
                    floating("surfacePhotonRadius", "0.5") + kDirectFromPhotons);
    auto fixed = load(integer("photonCount", 20) + floating("surfacePhotonRadius", "0.5") +
                      kDirectFromPhotons);
    const auto knnPass = knn->integrator()->preparePass(*knn, 2, 0);
    const auto fixedPass = fixed->integrator()->preparePass(*fixed, 2, 0);
    ASSERT_LT(passData(knnPass).surface.size(), 50u);
    // emission 1 plus some photons
    const int lit = countLitWhileComparing(*knn, knnPass.get(), *fixed, fixedPass.get(), 400, 1.0f);
    EXPECT_GT(lit, 20) << "too few rays found photons: the comparison is vacuous";
}

// Progressive photon mapping: on a region without bias (the furnace, where irradiance is
// uniform), the standard deviation over independent seeds of the average of N passes falls as
// N^(-alpha/2): the variance of pass i grows as 1/r_i² ~ i^(1 - alpha), so the variance of the
// average as N^(-alpha): about -0.25 for alpha = 0.5. The expected slopes between
// 16 and 1024 passes, from the exact radii (sum of 1/r_i², closed form), are -0.257 for alpha
// 0.5 and -0.452 for alpha 0.9: measuring both shows the test resolves the schedule (a radius
// that never shrank would give -0.5, one with r² ~ 1/i, 0). Measured at one point (the centre
// of a wall) with 50 photons per pass and 64 seeds: the slope's standard error is about 0.03.
// The first radius, 0.7, keeps every gather sphere 0.3 away from the other walls.
struct ConvergenceCase {
    const char* alpha;
    double expectedSlope;
};

void PrintTo(const ConvergenceCase& c, std::ostream* os) {
    *os << "alpha " << c.alpha << ", expected slope " << c.expectedSlope;
}

class ProgressiveConvergence : public PhotonMapperTest,
                               public ::testing::WithParamInterface<ConvergenceCase> {};

TEST_P(ProgressiveConvergence, NoiseFallsAsTheScheduleDictates) {
    const auto [alpha, expectedSlope] = GetParam();
    // Photons only: a light sample's noise would not shrink with the radius.
    auto scene = load(integer("photonCount", 50) + floating("surfacePhotonRadius", "0.7") +
                      floating("alpha", alpha) + kProgressive + kDirectFromPhotons);
    constexpr int kSeeds = 64, kPasses = 1024, kEarly = 16;
    std::vector<double> early(kSeeds), late(kSeeds);
    const Ray3f ray(Point3f::Zero(), Vector3f(1.0f, 0.0f, 0.0f));
    tbb::parallel_for(0, kSeeds, [&](int seed) {
        std::unique_ptr<Sampler> sampler = scene->sampler()->clone();
        double sum = 0.0;
        for (int pass = 0; pass < kPasses; ++pass) {
            const auto data = scene->integrator()->preparePass(*scene, 100 + seed, pass);
            sampler->startStream(100 + seed, pass, 0, StreamPurpose::Camera);
            sum += scene->integrator()->Li(*scene, *sampler, ray, data.get()).r();
            if (pass + 1 == kEarly) early[seed] = sum / kEarly;
        }
        late[seed] = sum / kPasses;
    });
    auto meanAndStd = [](const std::vector<double>& v) {
        double mean = 0.0, m2 = 0.0;
        for (double x : v) mean += x / v.size();
        for (double x : v) m2 += (x - mean) * (x - mean);
        return std::make_pair(mean, std::sqrt(m2 / (v.size() - 1)));
    };
    const auto [earlyMean, earlyStd] = meanAndStd(early);
    const auto [lateMean, lateStd] = meanAndStd(late);
    const double slope = std::log(lateStd / earlyStd) / std::log(double(kPasses) / kEarly);
    RecordProperty("slope", std::to_string(slope));
    EXPECT_NEAR(slope, expectedSlope, 0.09)
        << "alpha " << alpha << ": std " << earlyStd << " at " << kEarly << " passes, " << lateStd
        << " at " << kPasses;
    // Unbiased here: both averages are 2 within 4 standard errors.
    EXPECT_NEAR(earlyMean, 2.0, 4.0 * earlyStd / std::sqrt(kSeeds));
    EXPECT_NEAR(lateMean, 2.0, 4.0 * lateStd / std::sqrt(kSeeds));
}

INSTANTIATE_TEST_SUITE_P(PhotonMapper, ProgressiveConvergence,
                         ::testing::Values(ConvergenceCase{"0.5", -0.257},
                                           ConvergenceCase{"0.9", -0.452}),
                         [](const ::testing::TestParamInfo<ConvergenceCase>& info) {
                             std::string name = std::string("Alpha") + info.param.alpha;
                             std::replace(name.begin(), name.end(), '.', '_');
                             return name;
                         });

// A point light over a black floor (photon paths end at their first floor hit) under a small
// mirror: every photon stored is direct light except those the mirror sends down. With
// directLight "nee" the map must hold exactly those: the photons of the "photons" map (same
// streams) minus the direct ones, in the same order, all inside the mirrored patch.
std::string pointLightUnderMirror() {
    return "<camera type=\"perspective\"><transform name=\"toWorld\"><lookat origin=\"0,0.6,0.8\" "
           "target=\"0,0,0\" up=\"0,1,0\"/></transform><integer name=\"width\" value=\"2\"/>"
           "<integer name=\"height\" value=\"2\"/></camera>"
           "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
           kMeshes +
           "quad.obj\"/><transform name=\"toWorld\"><scale value=\"20,1,20\"/></transform>"
           "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0\"/></bsdf></mesh>"
           "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
           kMeshes +
           "quad.obj\"/><transform name=\"toWorld\"><scale value=\"0.1,1,0.1\"/><rotate "
           "axis=\"1,0,0\" angle=\"180\"/><translate value=\"0,2,0\"/></transform><bsdf "
           "type=\"mirror\"/></mesh>"
           "<emitter type=\"point\"><point name=\"position\" value=\"0,1,0\"/><color "
           "name=\"power\" "
           "value=\"12.566370614359172\"/></emitter>";
}

TEST_F(PhotonMapperTest, SampledDirectLightLeavesOnlyDirectPhotonsOut) {
    const std::string params =
        integer("photonCount", 40000) + floating("surfacePhotonRadius", "0.1");
    auto all = load(params + kDirectFromPhotons, pointLightUnderMirror());
    auto indirect = load(params, pointLightUnderMirror());  // "nee", the default
    const auto allPass = all->integrator()->preparePass(*all, 5, 0);
    const auto indirectPass = indirect->integrator()->preparePass(*indirect, 5, 0);
    const Photons& full = passData(allPass).surface.photons();
    const Photons& kept = passData(indirectPass).surface.photons();
    // About half the photons go down and land directly; about 0.3% reach the mirror.
    EXPECT_GT(full.size(), 15000u);
    ASSERT_GT(kept.size(), 40u) << "the mirrored photons are lost";
    EXPECT_LT(kept.size(), 400u);
    size_t next = 0;
    for (const Photon& photon : kept) {
        // The mirror (|x|, |z| <= 0.1 at height 2) images the light at height 3: its light lands
        // within |x|, |z| <= 0.3 on the floor.
        EXPECT_LE(std::abs(photon.position.x()), 0.3f + 1e-4f);
        EXPECT_LE(std::abs(photon.position.z()), 0.3f + 1e-4f);
        while (next < full.size() && std::memcmp(&full[next], &photon, sizeof(Photon)) != 0) ++next;
        ASSERT_LT(next, full.size()) << "a kept photon is not in the full map, or out of order";
        ++next;
    }
    EXPECT_DOUBLE_EQ(passData(indirectPass).powerScale, passData(allPass).powerScale);
}

// A camera path meets glass: a horizontal glass interface (index 1.5 below, 1 above), a sky of
// radiance 1 above it and a floor-emitter of radiance 3 below it, and nothing else. A ray at 45°
// sees the sky in the reflection with the Fresnel weight F and the lower emitter through the
// refraction with (1 - F) / 1.5², the radiance's n² scaling. The camera path follows both lobes
// at its first glass surfaces, so every single path must return exactly F + (1 - F) 3 / 1.5²; a
// path that drew one lobe would return 1 or 3 / 1.5².
TEST_F(PhotonMapperTest, ACameraPathFollowsBothLobesOfGlassWithTheirFresnelWeights) {
    const std::string quad = "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
                             "quad.obj\"/><transform name=\"toWorld\"><scale value=\"100,1,100\"/>";
    const std::string body =
        "<camera type=\"perspective\"><transform name=\"toWorld\"><lookat origin=\"0,1,1\" "
        "target=\"0,0,0\" up=\"0,1,0\"/></transform><integer name=\"width\" value=\"1\"/>"
        "<integer name=\"height\" value=\"1\"/></camera>" +
        quad +
        "</transform><bsdf type=\"dielectric\"><float name=\"intIOR\" value=\"1.5\"/><float "
        "name=\"extIOR\" value=\"1\"/></bsdf></mesh>" +
        quad +
        "<rotate axis=\"1,0,0\" angle=\"180\"/><translate value=\"0,5,0\"/></transform>"
        "<emitter type=\"area\"><color name=\"radiance\" value=\"1\"/></emitter></mesh>" +
        quad +
        "<translate value=\"0,-5,0\"/></transform><emitter type=\"area\"><color "
        "name=\"radiance\" value=\"3\"/></emitter></mesh>";
    auto scene = load(integer("photonCount", 100), body);
    const auto pass = scene->integrator()->preparePass(*scene, 1, 0);
    // Unpolarised Fresnel reflectance at 45° from index 1 into 1.5.
    const double cosI = std::sqrt(0.5), sinT = std::sqrt(0.5) / 1.5;
    const double cosT = std::sqrt(1.0 - sinT * sinT);
    const double rs = (cosI - 1.5 * cosT) / (cosI + 1.5 * cosT);
    const double rp = (1.5 * cosI - cosT) / (1.5 * cosI + cosT);
    const double F = 0.5 * (rs * rs + rp * rp);
    const double expected = F * 1.0 + (1.0 - F) * 3.0 / (1.5 * 1.5);
    std::unique_ptr<Sampler> sampler = scene->sampler()->clone();
    const Ray3f ray(Point3f(0.0f, 1.0f, 1.0f), Vector3f(0.0f, -1.0f, -1.0f).normalized());
    for (int i = 0; i < 64; ++i) {
        sampler->startStream(1, 0, i, StreamPurpose::Camera);
        const Color3f radiance = scene->integrator()->Li(*scene, *sampler, ray, pass.get());
        EXPECT_NEAR(radiance.r(), expected, 1e-5 * expected) << i;
    }
}

// Progressive kNN: each pass's kNN radius shrinks by the schedule's r_i / r_0. At the foot of a
// point light over a plane the irradiance peaks (E ∝ h³ / (h² + s²)^(3/2) at distance s from the
// foot; radiance 0.5/π there), so a kNN estimate reads low: with k = 16 and 200 photons per pass
// the k-th neighbour lies at R² ≈ 0.4 h², and the estimate there is some 22% below the peak.
// Averaging passes of that fixed-k estimate (independent photon maps: one seed per pass, without
// `progressive`) converges to the biased value, so its error plateaus; the progressive estimate's
// blur shrinks with the radii, and its error keeps falling. RMS error over 24 seeds at 16 and 1024
// passes, relative to the true value. Expected from the kNN estimate's variance 1/(k − 2) and the
// schedule: fixed k about 0.2 at both, progressive about 0.15, then 0.04 (measured: 0.23 -> 0.22
// and 0.16 -> 0.04).
// Named like the convergence tests above, many passes of code the other tests run under the
// sanitizers too: the test command runs them in the release tree only.
class KnnProgressiveConvergence : public PhotonMapperTest {};

TEST_F(KnnProgressiveConvergence, ErrorKeepsFallingWhereAFixedKAveragePlateaus) {
    const std::string plane =
        "<camera type=\"perspective\"><transform name=\"toWorld\"><lookat origin=\"0,0.6,0.8\" "
        "target=\"0,0,0\" up=\"0,1,0\"/></transform><integer name=\"width\" value=\"1\"/>"
        "<integer name=\"height\" value=\"1\"/></camera>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"20,1,20\"/></transform>"
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.5\"/></bsdf></mesh>"
        "<emitter type=\"point\"><point name=\"position\" value=\"0,1,0\"/><color name=\"power\" "
        "value=\"12.566370614359172\"/></emitter>";
    // Photons carry the direct light, the whole of the light at the foot.
    const std::string params = integer("photonCount", 200) + integer("surfaceK", 16) +
                               floating("surfacePhotonRadius", "2") + kDirectFromPhotons;
    auto fixedK = load(params, plane);
    auto progressive = load(params + kProgressive, plane);
    const double truth = 0.5 / M_PI;
    constexpr int kSeeds = 24, kPasses = 1024, kEarly = 16;
    std::vector<double> fixedEarly(kSeeds), fixedLate(kSeeds), progEarly(kSeeds), progLate(kSeeds);
    const Ray3f ray(Point3f(0.0f, 0.6f, 0.8f), Vector3f(0.0f, -0.6f, -0.8f));
    tbb::parallel_for(0, kSeeds, [&](int seed) {
        std::unique_ptr<Sampler> sampler = fixedK->sampler()->clone();
        double fixedSum = 0.0, progSum = 0.0;
        for (int pass = 0; pass < kPasses; ++pass) {
            const uint64_t passSeed = 1000 + uint64_t(seed) * kPasses + pass;
            const auto fixedData = fixedK->integrator()->preparePass(*fixedK, passSeed, 0);
            sampler->startStream(passSeed, 0, 0, StreamPurpose::Camera);
            fixedSum += fixedK->integrator()->Li(*fixedK, *sampler, ray, fixedData.get()).r();
            const auto progData = progressive->integrator()->preparePass(*progressive, seed, pass);
            sampler->startStream(seed, pass, 0, StreamPurpose::Camera);
            progSum +=
                progressive->integrator()->Li(*progressive, *sampler, ray, progData.get()).r();
            if (pass + 1 == kEarly) {
                fixedEarly[seed] = fixedSum / kEarly;
                progEarly[seed] = progSum / kEarly;
            }
        }
        fixedLate[seed] = fixedSum / kPasses;
        progLate[seed] = progSum / kPasses;
    });
    auto relativeRms = [&](const std::vector<double>& v) {
        double sum = 0.0;
        for (double x : v) sum += (x / truth - 1.0) * (x / truth - 1.0);
        return std::sqrt(sum / v.size());
    };
    const double fixedE = relativeRms(fixedEarly), fixedL = relativeRms(fixedLate);
    const double progE = relativeRms(progEarly), progL = relativeRms(progLate);
    RecordProperty("fixedK", std::to_string(fixedE) + " -> " + std::to_string(fixedL));
    RecordProperty("progressive", std::to_string(progE) + " -> " + std::to_string(progL));
    EXPECT_GT(fixedL, 0.8 * fixedE) << "a fixed-k average should plateau at its bias";
    EXPECT_GT(fixedL, 0.05) << "the fixed-k bias is too small for the test to resolve";
    EXPECT_LT(progL, 0.6 * progE) << "progressive kNN error stopped falling";
    EXPECT_LT(progL, 0.6 * fixedL) << "progressive kNN no better than a fixed-k average";
    // The fixed-k average is measurably biased (t-test of the seeds' means against the truth);
    // the progressive one keeps a bias too, that of its finite radii (it falls as N^(-1/2) for
    // alpha 0.5: about 3% here after 1024 passes), but far smaller.
    const stats::MeanVariance fixedMv = stats::meanAndVariance(fixedLate.data(), fixedLate.size());
    const stats::TTestResult fixedT =
        stats::studentTTest(fixedMv.mean, fixedMv.variance, truth, kSeeds, 0.01);
    EXPECT_FALSE(fixedT.passed) << "the fixed-k average should be measurably biased: "
                                << fixedT.message;
    const stats::MeanVariance progMv = stats::meanAndVariance(progLate.data(), progLate.size());
    EXPECT_LT(std::abs(progMv.mean - truth), 0.25 * std::abs(fixedMv.mean - truth))
        << "progressive mean " << progMv.mean << ", fixed-k mean " << fixedMv.mean << ", truth "
        << truth;
}

}  // namespace
}  // namespace alphorn
