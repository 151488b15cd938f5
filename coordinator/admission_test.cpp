// Admission: a submission's defaults (passes from the scene's sampler, tile size, passes per
// unit, name) and its refusals (a blob not uploaded, a size that disagrees with the manifest,
// the limits), each leaving no staging directory behind.
#include "coordinator/admission.h"

#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/scene/accel.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "coordinator/farm_error.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <vector>

namespace alphorn::coordinator {
namespace {

namespace fs = std::filesystem;

class AdmissionTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("alphorn_admission_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir / "scene");
        fs::create_directories(m_dir / "staging");
        fs::copy_file(sourcePath("scenes/meshes/triangle.obj"), m_dir / "scene/triangle.obj");
        std::ofstream(m_dir / "scene/room.xml") << R"(<scene>
  <integrator type="normals"/>
  <sampler type="independent"><integer name="sampleCount" value="24"/></sampler>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 3, 0.5" target="0, 0, 0" up="0, 0, 1"/></transform>
    <integer name="width" value="200"/><integer name="height" value="100"/>
  </camera>
  <mesh type="obj"><string name="filename" value="triangle.obj"/></mesh>
</scene>)";
        m_blobs = std::make_unique<BlobStore>((m_dir / "blobs").string(), 1 << 20);
    }
    void TearDown() override { fs::remove_all(m_dir); }

    v1::SubmitJobRequest request(bool upload = true) {
        const farm::Bundle bundle = farm::gatherBundle((m_dir / "scene/room.xml").string());
        for (const auto& file : bundle.files) {
            if (!upload) break;
            BlobStore::Upload blob(*m_blobs, file.sha256);
            blob.append(farm::readFile(file.sourcePath));
            blob.commit();
        }
        v1::SubmitJobRequest submit;
        *submit.mutable_bundle() = farm::toProto(bundle);
        return submit;
    }
    AdmittedJob admit(const v1::SubmitJobRequest& submit, AdmissionLimits limits = {}) {
        return admitJob(submit, *m_blobs, limits, (m_dir / "staging").string());
    }
    bool stagingEmpty() const { return fs::is_empty(m_dir / "staging"); }

    fs::path m_dir;
    std::unique_ptr<BlobStore> m_blobs;
};

TEST_F(AdmissionTest, UnsetSettingsGetTheirDefaults) {
    AdmissionLimits limits;
    limits.defaultTileSize = 32;
    const AdmittedJob job = admit(request(), limits);
    const v1::JobSettings& settings = job.description.settings();
    EXPECT_EQ(settings.passes(), 24u) << "the scene's sample count";
    EXPECT_EQ(settings.tile_size(), 32u);
    // 65536 / (32 x 32) = 64 passes by samples, 24 / 4 = 6 by previews: 6.
    EXPECT_EQ(settings.passes_per_unit(), 6u);
    EXPECT_EQ(settings.name(), "room");
    EXPECT_EQ(job.grid.unitCount(), 7u * 4u * 4u);
    EXPECT_GT(job.filterBorder, 0) << "the default gaussian filter reaches beyond a tile";
    EXPECT_EQ(job.description.job_id(), 0u) << "the id is the store's to give";
    EXPECT_TRUE(fs::exists(job.stagingDirectory + "/bundle/room.xml"));

    v1::SubmitJobRequest explicitSettings = request();
    explicitSettings.mutable_settings()->set_passes(3);
    explicitSettings.mutable_settings()->set_passes_per_unit(9);
    explicitSettings.mutable_settings()->set_name("mine");
    const AdmittedJob clamped = admit(explicitSettings, limits);
    EXPECT_EQ(clamped.description.settings().passes_per_unit(), 3u) << "not clamped to passes";
    EXPECT_EQ(clamped.description.settings().name(), "mine");
}

TEST_F(AdmissionTest, RefusalsSayWhyAndLeaveNothingBehind) {
    const auto kindOf = [&](const v1::SubmitJobRequest& submit, AdmissionLimits limits) {
        try {
            admit(submit, limits);
        } catch (const FarmError& e) {
            return e.kind;
        }
        ADD_FAILURE() << "admitted";
        return FarmError::Kind::NotFound;
    };
    EXPECT_EQ(kindOf(request(false), {}), FarmError::Kind::FailedPrecondition)
        << "a blob not uploaded";
    v1::SubmitJobRequest wrongSize = request();
    wrongSize.mutable_bundle()->mutable_files(0)->set_size(1);
    EXPECT_EQ(kindOf(wrongSize, {}), FarmError::Kind::InvalidArgument);
    AdmissionLimits small;
    small.maxImagePixels = 200 * 100 - 1;
    EXPECT_EQ(kindOf(request(), small), FarmError::Kind::ResourceExhausted);
    AdmissionLimits fewPasses;
    fewPasses.maxPasses = 23;
    EXPECT_EQ(kindOf(request(), fewPasses), FarmError::Kind::ResourceExhausted);
    AdmissionLimits smallBundle;
    smallBundle.maxBundleBytes = 10;
    EXPECT_EQ(kindOf(request(), smallBundle), FarmError::Kind::ResourceExhausted);
    EXPECT_TRUE(stagingEmpty()) << "a refused job left its bundle behind";
}

// Free text is bounded and printable, and the request as a whole stays far inside the message
// limit its description travels to workers under (a job of an 8 MiB name made every worker that
// leased it fail).
TEST_F(AdmissionTest, LongOrControlTextAndHugeRequestsAreRefused) {
    const auto refusal = [&](const v1::SubmitJobRequest& submit) {
        try {
            admit(submit);
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::InvalidArgument) << e.what();
            return std::string(e.what());
        }
        ADD_FAILURE() << "admitted";
        return std::string();
    };
    v1::SubmitJobRequest longName = request();
    longName.mutable_settings()->set_name(std::string(300, 'n'));
    EXPECT_NE(refusal(longName).find("the job's name is 300 bytes long"), std::string::npos);
    v1::SubmitJobRequest escape = request();
    escape.mutable_settings()->set_owner("me\x1b[2J");
    EXPECT_NE(refusal(escape).find("the job's owner holds a control character"), std::string::npos);
    v1::SubmitJobRequest newlinePath = request();
    v1::BundleFile* extra = newlinePath.mutable_bundle()->add_files();
    *extra = newlinePath.bundle().files(0);
    extra->set_path("a\nlevel=error event=forged.xml");
    EXPECT_NE(refusal(newlinePath).find("a bundle path holds a control character"),
              std::string::npos);
    v1::SubmitJobRequest huge = request();
    for (int i = 0; i < 20000; ++i) {
        v1::BundleFile* file = huge.mutable_bundle()->add_files();
        *file = huge.bundle().files(0);
        file->set_path("padding/" + std::string(200, 'p') + std::to_string(i));
    }
    EXPECT_NE(refusal(huge).find("at most 4194304 are allowed"), std::string::npos);
    EXPECT_TRUE(stagingEmpty());
}

// A target error needs a cap and a value in (0, 1]; its job gets 1, 2 or 4 passes per unit, so
// that every decision point (4, 8, 16, ... passes) ends a pass chunk.
TEST_F(AdmissionTest, ATargetErrorNeedsACapAndChunksEndingAtDecisionPoints) {
    const auto refusal = [&](const v1::SubmitJobRequest& submit) -> std::string {
        try {
            admit(submit);
        } catch (const FarmError& e) {
            EXPECT_EQ(e.kind, FarmError::Kind::InvalidArgument);
            return e.what();
        }
        return "admitted";
    };
    v1::SubmitJobRequest noCap = request();
    noCap.mutable_settings()->set_target_error(0.05);
    EXPECT_NE(refusal(noCap).find("--max-passes"), std::string::npos) << refusal(noCap);
    v1::SubmitJobRequest badTarget = request();
    badTarget.mutable_settings()->set_passes(64);
    badTarget.mutable_settings()->set_target_error(0.0);
    EXPECT_NE(refusal(badTarget).find("target error"), std::string::npos) << refusal(badTarget);
    EXPECT_TRUE(stagingEmpty());

    for (const auto& [requested, expected] :
         std::vector<std::pair<uint32_t, uint32_t>>{{0, 4}, {16, 4}, {3, 2}, {1, 1}}) {
        v1::SubmitJobRequest target = request();
        target.mutable_settings()->set_passes(1000);
        target.mutable_settings()->set_target_error(0.05);
        target.mutable_settings()->set_passes_per_unit(requested);
        const AdmittedJob job = admit(target);
        EXPECT_EQ(job.description.settings().passes_per_unit(), expected) << requested;
        EXPECT_EQ(job.description.settings().passes(), 1000u);
    }
}

// The scene is loaded at submit to check it and to learn what the job needs, but without
// Embree's BVH (building it was most of a large scene's submit): the default radius of a
// progressive photon mapper (1/500 of the scene's diagonal) is still the one a full load derives.
TEST_F(AdmissionTest, CheckingTheSceneBuildsNoBvhAndGivesTheRadiusOfAFullLoad) {
    std::ofstream(m_dir / "scene/room.xml") << R"(<scene>
  <integrator type="photonmapper"><boolean name="progressive" value="true"/>
    <integer name="photonCount" value="100"/></integrator>
  <camera type="perspective"><integer name="width" value="20"/><integer name="height" value="10"/></camera>
  <emitter type="point"><point name="position" value="0, 2, 0"/><color name="power" value="1"/></emitter>
  <mesh type="obj"><string name="filename" value="triangle.obj"/>
    <transform name="toWorld"><scale value="3, 5, 1"/></transform></mesh>
</scene>)";
    const uint64_t built = embreeScenesBuilt();
    const AdmittedJob job = admit(request());
    EXPECT_EQ(embreeScenesBuilt(), built) << "admission built a BVH";
    ASSERT_TRUE(job.description.has_photon_radius_schedule());
    const auto full = loadScene((m_dir / "scene/room.xml").string());
    EXPECT_EQ(job.description.photon_radius_schedule().initial_radius(),
              full->integrator()->radiusSchedule()->initialRadius);
}

// The client only lists the files; admission still reads every one as the workers will, so a
// corrupt image or OBJ file is refused at submit with file:line. A count beyond memory is
// RESOURCE_EXHAUSTED, as the mesh memory is.
TEST_F(AdmissionTest, BrokenFilesAndCountsBeyondMemoryAreRefusedAtSubmit) {
    const auto refusal = [&](const std::string& body) -> std::pair<FarmError::Kind, std::string> {
        std::ofstream(m_dir / "scene/room.xml") << "<scene>\n<camera type=\"perspective\"/>\n"
                                                << body << "\n</scene>\n";
        try {
            admit(request());
        } catch (const FarmError& e) {
            return {e.kind, e.what()};
        }
        ADD_FAILURE() << "admitted: " << body;
        return {};
    };
    std::ofstream(m_dir / "scene/bad.obj") << "v 0 0 0\nf 1 2 3\n";
    std::ofstream(m_dir / "scene/bad.png") << "not a PNG";
    const auto [objKind, objMessage] = refusal(
        R"(<integrator type="normals"/><mesh type="obj"><string name="filename" value="bad.obj"/></mesh>)");
    EXPECT_EQ(objKind, FarmError::Kind::InvalidArgument);
    EXPECT_NE(objMessage.find("room.xml:3:"), std::string::npos) << objMessage;
    EXPECT_NE(objMessage.find("out-of-range index"), std::string::npos) << objMessage;
    const auto [pngKind, pngMessage] = refusal(
        R"(<integrator type="normals"/><mesh type="obj"><string name="filename" value="triangle.obj"/><bsdf type="diffuse"><texture type="bitmap" name="albedo"><string name="filename" value="bad.png"/></texture></bsdf></mesh>)");
    EXPECT_EQ(pngKind, FarmError::Kind::InvalidArgument);
    EXPECT_NE(pngMessage.find("room.xml:3:"), std::string::npos) << pngMessage;
    EXPECT_NE(pngMessage.find("cannot read PNG"), std::string::npos) << pngMessage;
    // At least one 152-byte vertex for each of 2^31 - 1 light paths: 304 GiB.
    const auto [countKind, countMessage] = refusal(
        R"(<integrator type="vcm"><integer name="lightPathCount" value="2147483647"/></integrator>)");
    EXPECT_EQ(countKind, FarmError::Kind::ResourceExhausted) << countMessage;
    EXPECT_NE(countMessage.find("room.xml:3:"), std::string::npos) << countMessage;
    EXPECT_NE(countMessage.find("memory"), std::string::npos) << countMessage;
    EXPECT_TRUE(stagingEmpty());
}

}  // namespace
}  // namespace alphorn::coordinator
