// Helpers shared by the photon mappers' unit tests (photonmapper_test.cpp,
// volumetric_photonmapper_test.cpp): the furnace scene, property snippets, loading a scene whose
// integrator element sits on line 2, and the kNN-versus-fixed-radius comparison along rays.
#pragma once

#include "common/core/rng.h"
#include "common/integrator/integrator.h"
#include "common/integrator/photon_pass.h"
#include "common/sampler/sampler.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

namespace alphorn::photon_testing {

inline const std::string kMeshes = sourcePath("scenes/meshes/");

// The furnace: a closed box of albedo 0.5 emitting radiance 1, seen from its centre looking at
// the middle of the wall x = 1; radiance is 1/(1 - a) = 2 everywhere. `cameraMedium` (a
// <medium> element, or empty) fills it.
inline std::string furnace(const std::string& cameraMedium = "") {
    return "<camera type=\"perspective\"><transform name=\"toWorld\"><lookat origin=\"0,0,0\" "
           "target=\"1,0,0\" up=\"0,1,0\"/></transform><float name=\"fov\" value=\"30\"/><integer "
           "name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/>" +
           cameraMedium + "</camera>\n<mesh type=\"obj\"><string name=\"filename\" value=\"" +
           kMeshes +
           "cube_inward.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.5\"/>"
           "</bsdf><emitter type=\"area\"><color name=\"radiance\" value=\"1\"/></emitter></mesh>";
}

inline std::string integer(const std::string& name, int value) {
    return "<integer name=\"" + name + "\" value=\"" + std::to_string(value) + "\"/>";
}
inline std::string floating(const std::string& name, const std::string& value) {
    return "<float name=\"" + name + "\" value=\"" + value + "\"/>";
}
inline const std::string kProgressive = "<boolean name=\"progressive\" value=\"true\"/>";
// directLight "photons": photons carry all direct light (the volumetric photon mapper's default).
inline const std::string kDirectFromPhotons = "<string name=\"directLight\" value=\"photons\"/>";

inline const PhotonPassData& passData(const std::shared_ptr<const PassData>& data) {
    return photonPassData(data.get());
}

// A fixture writing scenes into a directory of its own; the integrator element is on line 2,
// so errors must name "scene.xml:2:".
class PhotonMappingTest : public ::testing::Test {
  protected:
    explicit PhotonMappingTest(std::string integratorType)
        : m_integratorType(std::move(integratorType)) {}

    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_" + m_integratorType + "_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::shared_ptr<Scene> load(const std::string& integratorParams,
                                const std::string& body = furnace()) {
        const std::string text = "<scene>\n<integrator type=\"" + m_integratorType + "\">" +
                                 integratorParams + "</integrator>\n" + body + "\n</scene>\n";
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << text;
        return loadScene(path.string());
    }

    std::filesystem::path m_dir;

  private:
    std::string m_integratorType;
};

// Renders `rays` rays from the centre of the furnace towards points spread over the wall x = 1
// and beyond with both scenes (same camera streams) and expects equal radiance; returns how many
// exceeded `litAbove` in `a`, so a caller can reject a vacuous comparison.
inline int countLitWhileComparing(const Scene& a, const PassData* passA, const Scene& b,
                                  const PassData* passB, int rays, float litAbove) {
    std::unique_ptr<Sampler> sampler = a.sampler()->clone();
    int lit = 0;
    for (int i = 0; i < rays; ++i) {
        Rng rng(8, 0, i, StreamPurpose::Test);
        const Vector3f d(1.0f, 2.0f * rng.nextFloat() - 1.0f, 2.0f * rng.nextFloat() - 1.0f);
        const Ray3f ray(Point3f::Zero(), d.normalized());
        sampler->startStream(1, 0, i, StreamPurpose::Camera);
        const Color3f ra = a.integrator()->Li(a, *sampler, ray, passA);
        sampler->startStream(1, 0, i, StreamPurpose::Camera);
        const Color3f rb = b.integrator()->Li(b, *sampler, ray, passB);
        EXPECT_TRUE(ra.allFinite()) << i;
        EXPECT_NEAR(ra.r(), rb.r(), 1e-5f * rb.r()) << i;
        if (ra.r() > litAbove) ++lit;
    }
    return lit;
}

}  // namespace alphorn::photon_testing
