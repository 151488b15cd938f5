// Volume photons: the media tracer's determinism, that purely absorbing media store none, that
// photons in a scattering medium carry the power the closed form says, and the kNN radii of the
// volume photon map.
#include "common/core/rng.h"
#include "common/photon/photon_tracer.h"
#include "common/photon/volume_photon_map.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

class VolumePhotonTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_volume_photon_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    // A black closed box [-1, 1]³ around a point light of power 1 at the origin, the camera
    // (and so the whole box) in a homogeneous medium.
    std::shared_ptr<Scene> litFog(const std::string& sigmaS, const std::string& sigmaA) {
        const std::string text =
            "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">"
            "<medium type=\"homogeneous\"><color name=\"sigmaS\" value=\"" +
            sigmaS + "\"/><color name=\"sigmaA\" value=\"" + sigmaA +
            "\"/></medium></camera>\n<mesh type=\"obj\"><string name=\"filename\" value=\"" +
            kMeshes +
            "cube_inward.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0\"/>"
            "</bsdf></mesh>\n<emitter type=\"point\"><point name=\"position\" value=\"0, 0, "
            "0\"/><color name=\"power\" value=\"1\"/></emitter>\n</scene>\n";
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << text;
        return loadScene(path.string());
    }

    std::filesystem::path m_dir;
};

TEST_F(VolumePhotonTest, PhotonsDoNotDependOnTheThreadCount) {
    auto scene = litFog("1.5", "0.2");
    auto traceWith = [&](int threads) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return tracePhotonsThroughMedia(*scene, 5, 3, 6000, 9000);
    };
    const TracedPhotons one = traceWith(1), two = traceWith(2);
    ASSERT_EQ(one.emitted, 6000u);
    ASSERT_EQ(one.volumeEmitted, 9000u);
    ASSERT_GT(one.volume.size(), 9000u);
    ASSERT_EQ(one.volume.size(), two.volume.size());
    ASSERT_EQ(one.surface.size(), two.surface.size());
    EXPECT_EQ(std::memcmp(one.volume.data(), two.volume.data(), one.volume.size() * sizeof(Photon)),
              0);
    EXPECT_EQ(one.volumeMedia, two.volumeMedia);
    ASSERT_EQ(one.volumeMedia.size(), one.volume.size());
    for (const Medium* m : one.volumeMedia) EXPECT_EQ(m, scene->camera()->medium());
    EXPECT_EQ(
        std::memcmp(one.surface.data(), two.surface.data(), one.surface.size() * sizeof(Photon)),
        0);
}

TEST_F(VolumePhotonTest, AbsorbingMediaStoreNoVolumePhotons) {
    // sigmaS = 0: photons cross the medium (attenuated) and land on the walls, never scattering.
    auto scene = litFog("0", "1");
    const TracedPhotons traced = tracePhotonsThroughMedia(*scene, 1, 0, 20000, 20000);
    EXPECT_TRUE(traced.volume.empty());
    ASSERT_GT(traced.surface.size(), 5000u);
    // Each photon reaching a wall at distance d carries exp(-d) of the power 1 (no roulette
    // below power 0.99 changes the expectation, but the mean stored power per emitted photon is
    // E[exp(-d)] over the wall hit distances d in [1, sqrt(3)]: between exp(-sqrt 3) and exp(-1)).
    double sum = 0.0;
    for (const Photon& p : traced.surface) sum += p.power.luminance();
    const double mean = sum / 20000.0;
    EXPECT_GT(mean, std::exp(-std::sqrt(3.0)));
    EXPECT_LT(mean, std::exp(-1.0));
}

TEST_F(VolumePhotonTest, ScatteringPhotonsCarryTheCollisionDensity) {
    // A point light of power 1 in an infinite-like medium of sigmaT = 2 with albedo 0.75 inside
    // a black box: the power stored at first scatterings per emitted photon is
    // albedo * P(collision before the wall) = 0.75 * E[1 - exp(-2 d)], d the wall distance. The
    // volume photons of the FIRST event of each path sum to it; later events add more. Weaker
    // but closed form: total stored volume power per emitted photon lies between the first
    // events' 0.75 (1 - exp(-2)) and the infinite medium's albedo / (1 - albedo) = 3.
    auto scene = litFog("1.5", "0.5");
    const TracedPhotons traced = tracePhotonsThroughMedia(*scene, 2, 0, 0, 40000);
    double sum = 0.0;
    for (const Photon& p : traced.volume) {
        sum += p.power.luminance();
        EXPECT_NEAR(p.direction.norm(), 1.0f, 1e-4f);
        EXPECT_LE(p.position.cwiseAbs().maxCoeff(), 1.0f + 1e-4f);
    }
    const double perPhoton = sum / 40000.0;
    EXPECT_GT(perPhoton, 0.75 * (1.0 - std::exp(-2.0)));
    EXPECT_LT(perPhoton, 3.0);
    EXPECT_TRUE(traced.surface.empty());  // surfaceCount 0: none kept
}

TEST_F(VolumePhotonTest, PointLightsStartInTheMediumAroundThem) {
    // A null sphere of radius 1 holding a scattering medium inside a black box, the camera in
    // vacuum, and one point light inside the sphere or outside it. The tracer finds each point
    // light's medium once per pass (not per photon): photons of the light inside must start in
    // the sphere's medium and scatter there, those of the light outside must fly through vacuum
    // and scatter only once they enter the sphere.
    auto sceneWithLightAt = [&](const std::string& position) {
        const std::string text =
            "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\"/>\n"
            "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
            kMeshes +
            "cube_inward.obj\"/><transform name=\"toWorld\"><scale value=\"4, 4, 4\"/></transform>"
            "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0\"/></bsdf></mesh>\n"
            "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
            kMeshes +
            "sphere.obj\"/><bsdf type=\"null\"/><medium type=\"homogeneous\" "
            "name=\"inside\"><color name=\"sigmaS\" value=\"2\"/><color name=\"sigmaA\" "
            "value=\"0\"/></medium></mesh>\n<emitter type=\"point\"><point "
            "name=\"position\" value=\"" +
            position + "\"/><color name=\"power\" value=\"1\"/></emitter>\n</scene>\n";
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << text;
        return loadScene(path.string());
    };
    for (const char* position : {"0.1, 0.2, 0", "0, 0, 2.5"}) {
        auto scene = sceneWithLightAt(position);
        const TracedPhotons traced = tracePhotonsThroughMedia(*scene, 3, 0, 0, 4000);
        ASSERT_GT(traced.volume.size(), 400u) << position;
        for (size_t i = 0; i < traced.volume.size(); ++i) {
            ASSERT_LE(traced.volume[i].position.norm(), 1.0f + 1e-4f) << position;
            ASSERT_NE(traced.volumeMedia[i], nullptr) << position;
        }
    }
}

TEST(VolumePhotonMapTest, NearestNeighbourRadiiAreTheKthDistances) {
    Rng rng(3, 0, 0, StreamPurpose::Test);
    Photons photons(800);
    for (Photon& p : photons) {
        p.position = Point3f(rng.nextFloat(), rng.nextFloat(), rng.nextFloat());
        p.direction = Vector3f(0, 0, 1);
        p.power = Color3f(1.0f);
    }
    const size_t k = 6;
    const float maxRadius = 0.12f;
    const Photons copy = photons;
    const VolumePhotonMap map(std::move(photons), {}, k, maxRadius);
    size_t capped = 0;
    for (uint32_t i = 0; i < copy.size(); ++i) {
        std::vector<float> distances;
        for (const Photon& q : copy) distances.push_back((q.position - copy[i].position).norm());
        std::sort(distances.begin(), distances.end());
        // The photon itself is the first neighbour (distance 0).
        const float expected = distances[k - 1] < maxRadius ? distances[k - 1] : maxRadius;
        if (expected == maxRadius) ++capped;
        EXPECT_NEAR(map.radius(i), expected, 1e-5f) << i;
    }
    EXPECT_LT(capped, copy.size() / 2);  // most radii come from neighbours, not the cap
}

}  // namespace
}  // namespace alphorn
