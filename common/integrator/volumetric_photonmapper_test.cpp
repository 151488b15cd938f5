// The volumetric_photonmapper integrator's pass data and stability: no volume map without media,
// one count per map, both radii on the shared schedule (fixed radii and kNN radii alike), which
// photons next-event estimation leaves out, and finite, not inflated, estimates
// where density estimation fails (no photons; fewer volume photons than k). Its accuracy is
// tested by tests/statistical/volumetric_photonmapper_*_ttest.xml.
#include "common/core/rng.h"
#include "common/core/system_memory.h"
#include "common/integrator/integrator.h"
#include "common/integrator/photon_mapping_testing.h"
#include "common/integrator/photon_pass.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/radius_schedule.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

using namespace photon_testing;

const std::string kFog =
    "<medium type=\"homogeneous\"><color name=\"sigmaS\" value=\"1\"/></medium>";

class VolumetricPhotonMapperTest : public PhotonMappingTest {
  protected:
    VolumetricPhotonMapperTest() : PhotonMappingTest("volumetric_photonmapper") {}
};

TEST_F(VolumetricPhotonMapperTest, NoMediumNoVolumeMap) {
    auto scene = load(integer("photonCount", 2000), furnace(""));
    const auto data = scene->integrator()->preparePass(*scene, 1, 0);
    EXPECT_FALSE(passData(data).surface.empty());
    EXPECT_TRUE(passData(data).volume.empty());
    EXPECT_EQ(passData(data).volumeEmitted, 0u);
}

TEST_F(VolumetricPhotonMapperTest, EachMapHasItsOwnCount) {
    auto scene = load(integer("surfacePhotonCount", 3000) + integer("volumePhotonCount", 1000),
                      furnace(kFog));
    const auto owner = scene->integrator()->preparePass(*scene, 1, 0);
    const PhotonPassData& data = passData(owner);
    EXPECT_EQ(data.emitted, 3000u);
    EXPECT_DOUBLE_EQ(data.powerScale, 1.0 / 3000.0);
    EXPECT_EQ(data.volumeEmitted, 1000u);
    EXPECT_DOUBLE_EQ(data.volumePowerScale, 1.0 / 1000.0);
    EXPECT_FALSE(data.volume.empty());
    // The volume photons come from the first 1000 paths only; the surface photons from all.
    auto fewer = load(integer("surfacePhotonCount", 3000) + integer("volumePhotonCount", 500),
                      furnace(kFog));
    const auto halfOwner = fewer->integrator()->preparePass(*fewer, 1, 0);
    const PhotonPassData& half = passData(halfOwner);
    EXPECT_LT(half.volume.size(), data.volume.size());
    EXPECT_EQ(half.surface.size(), data.surface.size());
}

// The larger of the two counts is what a pass traces, whatever photonCount says: 2^31 - 1
// surface photon paths need at least 72 GiB and are refused at load (they grew without limit).
TEST_F(VolumetricPhotonMapperTest, CountsBeyondMemoryAreErrorsNamingFileAndLine) {
    const uint64_t needed = uint64_t(std::numeric_limits<int>::max()) * sizeof(Photon);
    if (physicalMemoryBytes() >= needed) GTEST_SKIP() << "this machine holds " << needed;
    for (const std::string& params :
         {integer("photonCount", 2000) +
              integer("surfacePhotonCount", std::numeric_limits<int>::max()),
          integer("volumeK", std::numeric_limits<int>::max())}) {
        try {
            load(params, furnace(kFog));
            ADD_FAILURE() << "no error for " << params;
        } catch (const ResourceLimitError& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("scene.xml:2:"), std::string::npos) << message;
            EXPECT_NE(message.find("2147483647"), std::string::npos) << message;
            EXPECT_NE(message.find("memory"), std::string::npos) << message;
        }
    }
}

TEST_F(VolumetricPhotonMapperTest, BothRadiiFollowTheSchedule) {
    auto scene =
        load(integer("photonCount", 300) + floating("surfacePhotonRadius", "0.2") +
                 floating("volumePhotonRadius", "0.1") + floating("alpha", "0.7") + kProgressive,
             furnace(kFog));
    const Integrator& integrator = *scene->integrator();
    ASSERT_TRUE(integrator.radiusSchedule().has_value());
    EXPECT_DOUBLE_EQ(integrator.radiusSchedule()->initialRadius, 0.2f);
    EXPECT_DOUBLE_EQ(integrator.radiusSchedule()->alpha, 0.7f);
    for (uint64_t pass : {0, 1, 7, 1000}) {
        const auto passOwner = integrator.preparePass(*scene, 3, pass);  // owns the maps
        const PhotonPassData& data = passData(passOwner);
        EXPECT_EQ(data.surfaceRadius, static_cast<float>(progressiveRadius(0.2f, 0.7f, pass)));
        EXPECT_EQ(data.volumeRadius, static_cast<float>(progressiveRadius(0.1f, 0.7f, pass)));
        ASSERT_FALSE(data.volume.empty());
        EXPECT_EQ(data.volume.radius(0), data.volumeRadius);
    }
}

TEST_F(VolumetricPhotonMapperTest, NoPhotonsGiveAFiniteBlackImage) {
    // No emitter: both maps empty; every mode must give 0, not NaN.
    const std::string dark =
        "<camera type=\"perspective\"><integer name=\"width\" value=\"6\"/><integer "
        "name=\"height\" value=\"4\"/>" +
        kFog + "</camera><mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "cube_inward.obj\"/></mesh>";
    for (const std::string& params :
         {integer("photonCount", 100),
          integer("photonCount", 100) + integer("surfaceK", 8) + integer("volumeK", 8),
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

TEST_F(VolumetricPhotonMapperTest, FewerVolumePhotonsThanKUseTheLargestRadius) {
    // A few photon paths in the fog and volumeK = 1000: no photon has 1000 neighbours, so every
    // radius is volumePhotonRadius and the image equals the fixed-radius one (same photons),
    // finite, not inflated by radii shrunk to the few photons there are.
    auto knn =
        load(integer("photonCount", 30) + integer("volumeK", 1000) +
                 floating("volumePhotonRadius", "0.5") + floating("surfacePhotonRadius", "0.3"),
             furnace(kFog));
    auto fixed = load(integer("photonCount", 30) + floating("volumePhotonRadius", "0.5") +
                          floating("surfacePhotonRadius", "0.3"),
                      furnace(kFog));
    const auto knnPass = knn->integrator()->preparePass(*knn, 2, 0);
    const auto fixedPass = fixed->integrator()->preparePass(*fixed, 2, 0);
    ASSERT_FALSE(passData(knnPass).volume.empty());
    ASSERT_LT(passData(knnPass).volume.size(), 1000u);
    // photons seen: the attenuated emission alone is < 0.37
    const int lit = countLitWhileComparing(*knn, knnPass.get(), *fixed, fixedPass.get(), 200, 0.5f);
    EXPECT_GT(lit, 20) << "too few rays lit: the comparison is vacuous";
}

TEST_F(VolumetricPhotonMapperTest, ProgressiveKnnRadiiShrinkByTheSchedule) {
    // Progressive mode with volumeK (and surfaceK) is accepted; pass p's volume photons get their
    // kNN radii (at most volumePhotonRadius) times r_p / r_0 of the shared schedule; the surface
    // search radius stays as given and carries the same factor.
    const std::string params = integer("photonCount", 3000) + integer("volumeK", 10) +
                               integer("surfaceK", 10) + floating("volumePhotonRadius", "0.4") +
                               floating("surfacePhotonRadius", "0.5") + floating("alpha", "0.7");
    auto progressive = load(params + kProgressive, furnace(kFog));
    const Integrator& integrator = *progressive->integrator();
    EXPECT_FALSE(integrator.radiusSchedule().has_value()) << "kNN radii have no one value";
    for (uint64_t pass : {0, 3, 100}) {
        const auto owner = integrator.preparePass(*progressive, 4, pass);
        const PhotonPassData& data = passData(owner);
        const float scale = static_cast<float>(progressiveRadius(1.0, 0.7f, pass));
        EXPECT_EQ(data.surfaceRadius, 0.5f);
        EXPECT_EQ(data.surfaceRadiusScale, scale);
        // The same photons indexed without the schedule.
        TracedPhotons traced = tracePhotonsThroughMedia(*progressive, 4, pass, 3000, 3000);
        ASSERT_EQ(traced.volume.size(), data.volume.size());
        ASSERT_GT(traced.volume.size(), 100u);
        const VolumePhotonMap unscaled(std::move(traced.volume), std::move(traced.volumeMedia), 10,
                                       0.4f);
        int shrunk = 0;
        for (uint32_t i = 0; i < data.volume.size(); ++i) {
            EXPECT_EQ(data.volume.radius(i), unscaled.radius(i) * scale) << pass << " " << i;
            shrunk += unscaled.radius(i) < 0.4f;
        }
        EXPECT_GT(shrunk, 100) << "no photon had k neighbours: the test is vacuous";
    }
}

TEST_F(VolumetricPhotonMapperTest, SampledDirectLightLeavesOutOnlyUnscatteredSurfacePhotons) {
    // In the fog-filled furnace, directLight "nee" keeps every volume photon and those surface
    // photons whose light scattered before (in the fog or at a wall): a subsequence of the
    // "photons" map from the same streams, shorter by the photons emitted by one wall that
    // reach another without scattering.
    const std::string params =
        integer("photonCount", 2000) + floating("surfacePhotonRadius", "0.2");
    auto all = load(params, furnace(kFog));
    auto indirect = load(params + "<string name=\"directLight\" value=\"nee\"/>", furnace(kFog));
    const auto allOwner = all->integrator()->preparePass(*all, 6, 0);
    const auto indirectOwner = indirect->integrator()->preparePass(*indirect, 6, 0);
    const PhotonPassData& a = passData(allOwner);
    const PhotonPassData& b = passData(indirectOwner);
    ASSERT_EQ(a.volume.size(), b.volume.size());
    EXPECT_EQ(std::memcmp(a.volume.photons().data(), b.volume.photons().data(),
                          a.volume.size() * sizeof(Photon)),
              0);
    const Photons& full = a.surface.photons();
    const Photons& kept = b.surface.photons();
    // Fog of sigmaS 1 in a box of side 2: about a third of the light crosses it unscattered.
    EXPECT_LT(kept.size(), full.size() - 300);
    EXPECT_GT(kept.size(), full.size() / 3);
    size_t next = 0;
    for (const Photon& photon : kept) {
        while (next < full.size() && std::memcmp(&full[next], &photon, sizeof(Photon)) != 0) ++next;
        ASSERT_LT(next, full.size()) << "a kept photon is not in the full map, or out of order";
        ++next;
    }
}

}  // namespace
}  // namespace alphorn
