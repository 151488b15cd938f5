// A job's scene resolves files only inside its bundle, on the coordinator and on workers alike,
// and `alphorn submit` refuses what the farm would refuse before uploading anything.
#include "common/farm/job_scene.h"

#include "common/core/error.h"
#include "common/farm/bundle.h"
#include "common/farm/files.h"
#include "common/farm/sha256.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>

#include <unistd.h>

namespace alphorn::farm {
namespace {

namespace fs = std::filesystem;

std::string sceneNaming(const std::string& filename) {
    return "<scene>\n  <integrator type=\"normals\"/>\n"
           "  <camera type=\"perspective\"><integer name=\"width\" value=\"8\"/>"
           "<integer name=\"height\" value=\"8\"/></camera>\n"
           "  <mesh type=\"obj\"><string name=\"filename\" value=\"" +
           filename + "\"/></mesh>\n</scene>\n";
}

class JobSceneTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir =
            fs::temp_directory_path() / ("alphorn_job_scene_test_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir / "blobs");
        m_server = m_dir / "server";
        fs::copy_file(sourcePath("scenes/meshes/triangle.obj"), m_dir / "triangle.obj");
    }
    void TearDown() override { fs::remove_all(m_dir); }

    // A bundle as a client could craft it (any manifest), materialized where a daemon would.
    std::string materialize(const std::map<std::string, std::string>& files,
                            const std::string& scenePath) {
        Bundle bundle;
        for (const auto& [path, contents] : files) {
            const std::string sha = sha256Hex(contents);
            writeFileAtomically((m_dir / "blobs" / sha).string(), contents);
            bundle.files.push_back({path, sha, contents.size(), ""});
        }
        bundle.scenePath = scenePath;
        return materializeBundle(bundle, m_server.string(), [&](const std::string& sha) {
            return (m_dir / "blobs" / sha).string();
        });
    }
    // Expects loading the job to fail with every fragment and without a server path.
    void expectRefused(const std::string& scenePath, std::initializer_list<std::string> fragments) {
        try {
            loadJobScene(m_server.string(), scenePath, "");
            FAIL() << "the scene was accepted";
        } catch (const Error& e) {
            const std::string message = e.what();
            for (const std::string& f : fragments)
                EXPECT_NE(message.find(f), std::string::npos)
                    << "message \"" << message << "\" lacks \"" << f << "\"";
            EXPECT_EQ(message.find(m_server.string()), std::string::npos) << message;
        }
    }

    fs::path m_dir, m_server;
};

TEST_F(JobSceneTest, BundleHoldingOnlyTheSceneCannotReachServerFiles) {
    const std::string outside = (m_dir / "triangle.obj").string();
    expectRefused(materialize({{"scene.xml", sceneNaming(outside)}}, "scene.xml"),
                  {"scene.xml:4:", "\"" + outside + "\" is an absolute path"});
    const std::string escape = "../../../../../../../../.." + outside;
    expectRefused(materialize({{"scene.xml", sceneNaming(escape)}}, "scene.xml"),
                  {"scene.xml:4:", "\"" + escape + "\" leaves the scene bundle"});
    expectRefused(materialize({{"scene.xml", sceneNaming("../triangle.obj")}}, "scene.xml"),
                  {"scene.xml:4:", "\"../triangle.obj\" leaves the scene bundle"});
}

TEST_F(JobSceneTest, MissingFilesAreNamedByTheirBundlePath) {
    expectRefused(materialize({{"a/scene.xml", sceneNaming("../meshes/none.obj")}}, "a/scene.xml"),
                  {"a/scene.xml:4:", "\"meshes/none.obj\""});
}

TEST_F(JobSceneTest, FilesInsideTheBundleLoad) {
    const std::string scene =
        materialize({{"scenes/s.xml", sceneNaming("../meshes/t.obj")},
                     {"meshes/t.obj", readFile((m_dir / "triangle.obj").string())}},
                    "scenes/s.xml");
    EXPECT_EQ(loadJobScene(m_server.string(), scene, "")->meshes().size(), 1u);
    // Workers may be given a relative cache directory.
    const fs::path previous = fs::current_path();
    fs::current_path(m_dir);
    EXPECT_NO_THROW(loadJobScene("server", "server/scenes/s.xml", ""));
    fs::current_path(previous);
}

TEST_F(JobSceneTest, SubmitRefusesAbsoluteReferencesBeforeUpload) {
    std::ofstream(m_dir / "abs.xml") << sceneNaming((m_dir / "triangle.obj").string());
    try {
        gatherBundle((m_dir / "abs.xml").string());
        FAIL() << "a scene naming an absolute path was gathered";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("abs.xml:4:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("is an absolute path"), std::string::npos) << e.what();
    }
}

// `alphorn submit` lists the scene's files without loading it (loading a scene of thousands of
// meshes took it longer than the upload): an OBJ file that loading refuses (a face beyond its
// vertices) is bundled, for the coordinator to refuse at submit; a file that is missing is
// refused before anything is uploaded, naming the scene's file and line.
TEST_F(JobSceneTest, SubmitListsTheFilesWithoutLoadingTheScene) {
    std::ofstream(m_dir / "bad.obj") << "v 0 0 0\nf 1 2 3\n";
    std::ofstream(m_dir / "s.xml") << sceneNaming("bad.obj");
    EXPECT_THROW(loadScene((m_dir / "s.xml").string()), Error);
    const Bundle bundle = gatherBundle((m_dir / "s.xml").string());
    ASSERT_EQ(bundle.files.size(), 2u);
    EXPECT_EQ(bundle.files[0].path, "bad.obj");
    EXPECT_EQ(bundle.files[0].sha256, sha256OfFile((m_dir / "bad.obj").string()));

    std::ofstream(m_dir / "missing.xml") << sceneNaming("meshes/none.obj");
    try {
        gatherBundle((m_dir / "missing.xml").string());
        FAIL() << "a scene naming a missing file was gathered";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("missing.xml:4:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("cannot open OBJ file"), std::string::npos)
            << e.what();
    }
}

TEST_F(JobSceneTest, SubmitBundlesLinkedFilesWhereTheSceneNamesThem) {
    // The scene reaches its meshes through a symbolic link to a folder elsewhere: the bundle
    // holds them under the linked name, which is where the farm looks (it has no links).
    fs::create_directories(m_dir / "project/scene");
    fs::create_directories(m_dir / "library");
    fs::copy_file(m_dir / "triangle.obj", m_dir / "library/t.obj");
    fs::create_directory_symlink(m_dir / "library", m_dir / "project/scene/meshes");
    std::ofstream(m_dir / "project/scene/s.xml") << sceneNaming("meshes/t.obj");
    const Bundle bundle = gatherBundle((m_dir / "project/scene/s.xml").string());
    EXPECT_EQ(bundle.scenePath, "s.xml");
    ASSERT_EQ(bundle.files.size(), 2u);
    EXPECT_EQ(bundle.files[0].path, "meshes/t.obj");
    std::map<std::string, std::string> blobs;
    for (const BundleEntry& entry : bundle.files) blobs[entry.sha256] = entry.sourcePath;
    const std::string scene = materializeBundle(
        bundle, m_server.string(), [&](const std::string& sha) { return blobs.at(sha); });
    EXPECT_FALSE(fs::is_symlink(m_server / "meshes"));
    EXPECT_EQ(loadJobScene(m_server.string(), scene, "")->meshes().size(), 1u);
}

TEST(MaterializeBundle, MessagesShowNoServerPaths) {
    Bundle bundle;
    bundle.files.push_back({"scene.xml", sha256Hex("x"), 1, ""});
    bundle.scenePath = "scene.xml";
    const std::string directory =
        (fs::temp_directory_path() / ("alphorn_materialize_" + std::to_string(::getpid())))
            .string();
    try {
        materializeBundle(bundle, directory,
                          [](const std::string& sha) { return "/nonexistent/blobs/" + sha; });
        FAIL() << "a missing blob was materialized";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("\"scene.xml\""), std::string::npos) << message;
        EXPECT_EQ(message.find("/nonexistent"), std::string::npos) << message;
        EXPECT_EQ(message.find(directory), std::string::npos) << message;
    }
    fs::remove_all(directory);
}

}  // namespace
}  // namespace alphorn::farm
