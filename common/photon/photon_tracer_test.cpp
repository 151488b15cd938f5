// Photon tracing: determinism across thread counts, and conservation laws whose expected values
// are closed forms (total emitted power, the furnace's Neumann series, flux through glass).
#include "common/photon/photon_tracer.h"

#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <cstring>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

class PhotonTracerTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_photon_tracer_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::shared_ptr<Scene> load(const std::string& body) {
        const std::string text =
            "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\"/>\n" + body +
            "\n</scene>\n";
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << text;
        return loadScene(path.string());
    }

    // A closed box [-1, 1]³ with inward faces of the given albedo, optionally emitting.
    static std::string box(float albedo, const std::string& emitter = "") {
        return "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
               "cube_inward.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" value=\"" +
               std::to_string(albedo) + "\"/></bsdf>" + emitter + "</mesh>";
    }
    static std::string pointLight(const std::string& position, float power) {
        return "<emitter type=\"point\"><point name=\"position\" value=\"" + position +
               "\"/><color name=\"power\" value=\"" + std::to_string(power) + "\"/></emitter>";
    }

    // Stored power per emitted photon (luminance) over independent passes.
    static stats::RunningStats storedPowerPerPass(const Scene& scene, int passes,
                                                  uint64_t photons) {
        stats::RunningStats perPass;
        for (int pass = 0; pass < passes; ++pass) {
            const TracedPhotons traced = tracePhotons(scene, 11, pass, photons);
            double sum = 0.0;
            for (const Photon& p : traced.surface) sum += p.power.luminance();
            perPass.add(sum / static_cast<double>(traced.emitted));
        }
        return perPass;
    }

    std::filesystem::path m_dir;
};

TEST_F(PhotonTracerTest, PhotonsDoNotDependOnTheThreadCount) {
    auto scene = loadScene(sourcePath("scenes/cbox/cbox.xml"));
    auto traceWith = [&](int threads, uint64_t pass) {
        tbb::global_control limit(tbb::global_control::max_allowed_parallelism, threads);
        return tracePhotons(*scene, 5, pass, 30000);
    };
    const TracedPhotons one = traceWith(1, 3), two = traceWith(2, 3), other = traceWith(2, 4);
    ASSERT_EQ(one.emitted, 30000u);
    ASSERT_GT(one.surface.size(), 30000u);  // the cbox's diffuse walls store several per path
    ASSERT_EQ(one.surface.size(), two.surface.size());
    EXPECT_EQ(
        std::memcmp(one.surface.data(), two.surface.data(), one.surface.size() * sizeof(Photon)),
        0);
    // A different pass gives different photons (the pass index reaches the streams).
    EXPECT_FALSE(other.surface.size() == one.surface.size() &&
                 std::memcmp(one.surface.data(), other.surface.data(),
                             one.surface.size() * sizeof(Photon)) == 0);
}

TEST_F(PhotonTracerTest, LightsChosenByPowerGiveEveryPhotonTheTotalPower) {
    // Two point lights of power 1 and 3 in a black box: every photon is stored once, at its
    // first hit, and carries power / selection probability = the total power 4, whichever light
    // emitted it. About a quarter come from the weaker light (left half of the box).
    auto scene = load(box(0.0f) + pointLight("-0.5, 0, 0", 1.0f) + pointLight("0.5, 0, 0", 3.0f));
    const TracedPhotons traced = tracePhotons(*scene, 1, 0, 20000);
    ASSERT_EQ(traced.surface.size(), 20000u);
    size_t left = 0;
    for (const Photon& p : traced.surface) {
        EXPECT_NEAR(p.power.r(), 4.0f, 1e-5f);
        EXPECT_NEAR(p.direction.norm(), 1.0f, 1e-5f);
        // A photon from the light at x = -0.5 lands mostly, not only, on the left: count
        // photons whose direction points back towards that light instead.
        const Vector3f toLeft = (Point3f(-0.5f, 0.0f, 0.0f) - p.position).normalized();
        if (toLeft.dot(p.direction) > 0.99999f) ++left;
    }
    // Binomial(20000, 1/4): standard deviation 61; allow 5 of them.
    EXPECT_NEAR(double(left), 5000.0, 5 * 61.0);
}

TEST_F(PhotonTracerTest, FurnaceStoresTheNeumannSeriesOfTheEmittedPower) {
    // Walls of albedo a emitting radiance 1: total power pi * area * 1 = 24 pi, and each photon
    // is stored at every bounce, so E[stored power / emitted] = 24 pi / (1 - a). Russian
    // roulette must not bias it (a depth cap would, low).
    for (float albedo : {0.5f, 0.8f}) {
        auto scene = load(box(albedo,
                              "<emitter type=\"area\"><color name=\"radiance\" "
                              "value=\"1\"/></emitter>"));
        const stats::RunningStats s = storedPowerPerPass(*scene, 64, 4000);
        const double expected = 24.0 * 3.14159265358979 / (1.0 - albedo);
        const auto t = stats::studentTTest(s.mean, s.variance(), expected, s.count, 0.01);
        EXPECT_TRUE(t.passed) << "albedo " << albedo << ": " << t.message;
    }
}

TEST_F(PhotonTracerTest, GlassConservesPhotonFlux) {
    // A point light inside a glass sphere inside a black box: every photon leaves the glass
    // (after any number of reflections, total internal ones included) and is stored once on
    // the walls, so E[stored power / emitted] is the light's power, 2. The dielectric's sample
    // weight for radiance is 1/eta² on refraction; a photon tracer that forgot to undo it would
    // see 2.25 (glass to air) times too much from most photons.
    auto scene = load(box(0.0f) + pointLight("0.25, 0.1, 0", 2.0f) +
                      "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
                      "sphere.obj\"/><transform name=\"toWorld\"><scale value=\"0.5, 0.5, 0.5\"/>"
                      "</transform><bsdf type=\"dielectric\"/></mesh>");
    const stats::RunningStats s = storedPowerPerPass(*scene, 64, 4000);
    const auto t = stats::studentTTest(s.mean, s.variance(), 2.0, s.count, 0.01);
    EXPECT_TRUE(t.passed) << t.message;
    // The test has the power to see a 1% error.
    EXPECT_LT(std::sqrt(s.variance() / s.count), 0.004);
}

TEST_F(PhotonTracerTest, NoEmittersOrNoPhotonsGiveAnEmptyMap) {
    auto dark = load(box(0.5f));
    const TracedPhotons none = tracePhotons(*dark, 1, 0, 1000);
    EXPECT_TRUE(none.surface.empty());
    EXPECT_EQ(none.emitted, 1000u);
    auto lit = load(box(0.5f) + pointLight("0, 0, 0", 1.0f));
    EXPECT_TRUE(tracePhotons(*lit, 1, 0, 0).surface.empty());
}

}  // namespace
}  // namespace alphorn
