#include "common/scene/parser.h"

#include "common/core/image.h"
#include "common/scene/accel.h"
#include "common/scene/mesh.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

class ParserTest : public ::testing::Test {
  protected:
    std::string write(const std::string& name, const std::string& text) {
        std::filesystem::path path = m_dir / name;
        std::ofstream(path) << text;
        return path.string();
    }
    // Expects loading to fail with a message that contains every fragment.
    void expectError(const std::string& text, std::initializer_list<std::string> fragments) {
        std::string path = write("bad.xml", text);
        try {
            parseSceneFile(path);
            FAIL() << "no error for:\n" << text;
        } catch (const Error& e) {
            for (const std::string& f : fragments)
                EXPECT_NE(std::string(e.what()).find(f), std::string::npos)
                    << "message \"" << e.what() << "\" lacks \"" << f << "\"";
        }
    }
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_parser_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
        std::filesystem::copy_file(sourcePath("scenes/meshes/triangle.obj"), m_dir / "triangle.obj",
                                   std::filesystem::copy_options::overwrite_existing);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::filesystem::path m_dir;
};

const char* kCamera =
    R"(<camera type="perspective"><integer name="width" value="8"/><integer name="height" value="6"/></camera>)";

std::string sceneWith(const std::string& body) {
    return std::string("<scene>\n<integrator type=\"normals\"/>\n") + kCamera + "\n" + body +
           "\n</scene>\n";
}

// Nesting is limited (the parser recurses once per level): 10000 nested meshes are refused with
// the place of the first element too deep, instead of overflowing the stack (a crash of the
// process, at admission the coordinator's).
TEST_F(ParserTest, ElementsNestedThousandsDeepAreRefused) {
    std::string text = "<scene>\n";
    for (int i = 0; i < 10000; ++i) text += "<mesh type=\"obj\">";
    for (int i = 0; i < 10000; ++i) text += "</mesh>";
    text += "\n</scene>\n";
    // <scene> is level 0, its first <mesh> level 1; the name of the one at level 64 follows 63
    // tags of 17 characters and its '<' on line 2: column 63 * 17 + 2.
    expectError(text, {"bad.xml:2:1073", "<mesh> is nested more than 64 elements deep"});
}

// Files that are not regular files are refused before they are opened: a named pipe would block
// the loader forever (no writer), a device such as /dev/zero would fill the memory.
TEST_F(ParserTest, NamedPipesAndDevicesAreRefusedWithoutBeingOpened) {
    ASSERT_EQ(::mkfifo((m_dir / "pipe.obj").c_str(), 0600), 0);
    ASSERT_EQ(::mkfifo((m_dir / "pipe.xml").c_str(), 0600), 0);
    expectError(
        "<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"pipe.obj\"/></mesh>\n"
        "</scene>",
        {"bad.xml:2:2", "\"pipe.obj\" is a named pipe, not a file"});
    expectError(
        "<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"/dev/zero\"/></mesh>\n"
        "</scene>",
        {"bad.xml:2:2", "\"/dev/zero\" is a device, not a file"});
    for (const std::string& scene : {(m_dir / "pipe.xml").string(), std::string("/dev/zero")}) {
        try {
            parseSceneFile(scene);
            ADD_FAILURE() << scene << " was parsed";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(scene + ": is a named pipe, socket or device"),
                      std::string::npos)
                << e.what();
        }
    }
}

// Positions beyond +-1e15 (or NaN) would send rays Embree aborts the process on.
TEST_F(ParserTest, PositionsAndTransformsBeyondTheSceneBoundAreRefused) {
    expectError(
        "<scene>\n<camera type=\"perspective\"><transform name=\"toWorld\">\n"
        "<translate value=\"1e30, 0, 0\"/></transform></camera></scene>",
        {"bad.xml:3:2", "\"1e30, 0, 0\" must have finite components within +-1e+15"});
    expectError(
        "<scene>\n<emitter type=\"point\">\n<point name=\"position\" value=\"nan, 0, 0\"/>"
        "</emitter></scene>",
        {"bad.xml:3:2", "must have finite components"});
    expectError(
        "<scene>\n<camera type=\"perspective\"><transform name=\"toWorld\">\n"
        "<scale value=\"1e10, 1e10, 1e10\"/><scale value=\"1e10, 1e10, 1e10\"/>"
        "</transform></camera></scene>",
        {"bad.xml:2:29", "the transform \"toWorld\" has an entry beyond 1e+15"});
}

// Eigen's maxCoeff passed over a NaN after the first component: lookat origin="2,nan,6" was
// reported as the origin and target coinciding, and such a point or vector was accepted.
TEST_F(ParserTest, NaNInAnyComponentOfAPointIsRefused) {
    for (const std::string origin : {"nan,2,6", "2,nan,6", "2,6,nan", "2,6,-inf"})
        expectError(
            "<scene>\n<camera type=\"perspective\"><transform name=\"toWorld\">\n"
            "<lookat origin=\"" +
                origin + "\" target=\"0,0,0\" up=\"0,1,0\"/></transform></camera></scene>",
            {"bad.xml:3:2", "\"" + origin + "\" must have finite components"});
    expectError(
        "<scene>\n<emitter type=\"point\">\n<point name=\"position\" value=\"0, 0, nan\"/>"
        "</emitter></scene>",
        {"bad.xml:3:2", "\"0, 0, nan\" must have finite components"});
}

// A file name the system cannot resolve (a symbolic link loop, a name of 5000 characters) is
// reported at the element that names it, for textures as for meshes, also on the farm (inside a
// confinement root), never as a bare filesystem error.
TEST_F(ParserTest, UnresolvableFileNamesNameTheElement) {
    std::filesystem::create_symlink("loop_b.png", m_dir / "loop_a.png");
    std::filesystem::create_symlink("loop_a.png", m_dir / "loop_b.png");
    const std::string longName = std::string(5000, 'a') + ".png";
    for (const std::string& name : {std::string("loop_a.png"), longName}) {
        const std::string texture =
            "<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/>\n"
            "<bsdf type=\"diffuse\">\n<texture type=\"bitmap\" name=\"albedo\"><string "
            "name=\"filename\" value=\"" +
            name + "\"/></texture></bsdf></mesh></scene>";
        const std::string mesh = "<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"" +
                                 name + "\"/></mesh></scene>";
        for (const auto& [text, where] : {std::pair(texture, std::string("bad.xml:4:2 (texture "
                                                                         "type=\"bitmap\")")),
                                          std::pair(mesh, std::string("bad.xml:2:2 (mesh "
                                                                      "type=\"obj\")"))}) {
            const std::string path = write("bad.xml", text);
            for (const bool confined : {false, true}) {
                FileReferencePolicy policy;
                if (confined) policy.confinementRoot = m_dir.string();
                try {
                    parseSceneFile(path, policy);
                    ADD_FAILURE() << "no error for " << text.substr(0, 200);
                } catch (const Error& e) {
                    const std::string message = e.what();
                    EXPECT_NE(message.find(where), std::string::npos) << message.substr(0, 300);
                    EXPECT_EQ(message.find("filesystem error"), std::string::npos)
                        << message.substr(0, 300);
                }
            }
        }
    }
}

TEST_F(ParserTest, LoadsMinimalSceneWithNoriDefaults) {
    std::string path = write(
        "ok.xml",
        "<scene><integrator type=\"normals\"/><camera type=\"perspective\"/>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/></mesh></scene>");
    ParseResult result = parseSceneFile(path);
    auto scene = std::static_pointer_cast<Scene>(result.root);
    EXPECT_EQ(scene->camera()->outputSize(), Vector2i(1280, 720));
    EXPECT_FLOAT_EQ(scene->camera()->filter()->radius(), 2.0f);  // gaussian default
    EXPECT_EQ(scene->sampler()->sampleCount(), 1);
    ASSERT_EQ(scene->meshes().size(), 1u);
    EXPECT_EQ(scene->meshes()[0]->triangleCount(), 1u);
    ASSERT_EQ(result.dependencies.size(), 1u);
    EXPECT_EQ(result.dependencies[0], (m_dir / "triangle.obj").string());
}

TEST_F(ParserTest, TransformOperationsApplyInOrder) {
    // scale then translate: the vertex (1, 0, -1) goes to (2, 0, -2) then to (3, 0, -2).
    // (Faces list it third, so it is the third unique vertex.)
    std::string path =
        write("t.xml", sceneWith(R"(<mesh type="obj"><string name="filename" value="triangle.obj"/>
        <transform name="toWorld"><scale value="2, 2, 2"/><translate value="1, 0, 0"/></transform></mesh>)"));
    auto scene = loadScene(path);
    const auto& p = scene->meshes()[0]->positions();
    EXPECT_FLOAT_EQ(p(0, 2), 3.0f);
    EXPECT_FLOAT_EQ(p(2, 2), -2.0f);
}

// Scales of any size whose inverse float can hold load and shade: a mesh with vertex normals
// scaled by 1e-13 or 1e13, whose determinants (1e-39, 1e39) are no normal floats, lost its
// normals (its inverse, taken in float, was not finite; shading fell back to the flat triangle
// normals), and a scale of 1e-20 was refused as singular.
// A zero scale collapses space and has no inverse: refused, naming the transform and why.
TEST_F(ParserTest, TinyAndHugeScalesLoadAndOnlySingularTransformsAreRefused) {
    std::filesystem::copy_file(sourcePath("scenes/meshes/quad.obj"), m_dir / "quad.obj",
                               std::filesystem::copy_options::overwrite_existing);
    auto scaled = [](const std::string& scale, const std::string& extra = "") {
        return sceneWith(
            "<mesh type=\"obj\"><string name=\"filename\" value=\"quad.obj\"/>\n"
            "<transform name=\"toWorld\"><scale value=\"" +
            scale + "\"/>" + extra + "</transform></mesh>");
    };
    for (const std::string s : {"1e-13", "1e13", "1e-20", "1e-3", "1e5"}) {
        auto scene = loadScene(write("ok.xml", scaled(s + ", " + s + ", " + s)));
        const Mesh& mesh = *scene->meshes()[0];
        ASSERT_EQ(mesh.normals().cols(), mesh.positions().cols()) << s;
        for (int i = 0; i < mesh.normals().cols(); ++i) {
            EXPECT_TRUE(mesh.normals().col(i).isApprox(Normal3f(0, 1, 0), 1e-6f))
                << s << ": " << mesh.normals().col(i).transpose();
        }
        const float size = std::stof(s);
        EXPECT_NEAR(mesh.positions().cwiseAbs().maxCoeff(), size, 1e-6f * size) << s;
    }
    // Anisotropic: a floor stretched a billionfold keeps its normal.
    auto stretched = loadScene(write("ok.xml", scaled("1e9, 1, 1e9")));
    EXPECT_TRUE(stretched->meshes()[0]->normals().col(0).isApprox(Normal3f(0, 1, 0), 1e-6f));
    expectError(scaled("1, 0, 1"),
                {"bad.xml:5:", "the transform \"toWorld\" is singular (it collapses space"});
    expectError(scaled("1, 1, 1", "<matrix value=\"1 2 3 0  2 4 6 0  0 0 1 0  0 0 0 1\"/>"),
                {"bad.xml:5:", "the transform \"toWorld\" is singular"});
}

TEST_F(ParserTest, RotateAndMatrixAgree) {
    std::string a =
        write("a.xml", sceneWith(R"(<mesh type="obj"><string name="filename" value="triangle.obj"/>
        <transform name="toWorld"><rotate axis="0, 0, 1" angle="90"/></transform></mesh>)"));
    std::string b =
        write("b.xml", sceneWith(R"(<mesh type="obj"><string name="filename" value="triangle.obj"/>
        <transform name="toWorld"><matrix value="0 -1 0 0  1 0 0 0  0 0 1 0  0 0 0 1"/></transform></mesh>)"));
    auto pa = loadScene(a)->meshes()[0]->positions();
    auto pb = loadScene(b)->meshes()[0]->positions();
    EXPECT_TRUE(pa.isApprox(pb, 1e-6f)) << pa << "\n\n" << pb;
}

TEST_F(ParserTest, ErrorsNameFileLineAndProblem) {
    expectError("<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n",
                {"bad.xml:", "malformed XML"});
    expectError(sceneWith("<bsdf type=\"nosuchbsdf\"/>"),
                {"bad.xml:4:", "unknown bsdf type \"nosuchbsdf\""});
    expectError(
        sceneWith("<mesh type=\"obj\"><string name=\"filename\" value=\"missing.obj\"/></mesh>"),
        {"bad.xml:4:", "missing.obj"});
    expectError("<scene>\n<integrator type=\"normals\"/>\n</scene>", {"bad.xml:1:", "no camera"});
    expectError(sceneWith("<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/>\n"
                          "<float name=\"x\" value=\"1\"/><float name=\"x\" value=\"2\"/></mesh>"),
                {"bad.xml:", "more than once"});
    expectError(
        sceneWith(
            "<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/>"
            "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"-1, 0, 0\"/></bsdf></mesh>"),
        {"bad.xml:4:", "albedo"});
    expectError(
        sceneWith(
            "<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/>"
            "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"nan, 0, 0\"/></bsdf></mesh>"),
        {"bad.xml:4:", "albedo"});
    expectError(sceneWith("<float name=\"fov\" value=\"abc\"/>"), {"bad.xml:4:", "abc"});
    expectError(sceneWith("<transform name=\"t\"><rotate axis=\"0,0,0\" angle=\"3\"/></transform>"),
                {"bad.xml:4:", "axis"});
    expectError(sceneWith("<mesh type=\"obj\"><integer name=\"filename\" value=\"3\"/></mesh>"),
                {"bad.xml:4:", "filename"});
}

// Numbers are decimal: strtof alone read fov="0x10" as 16 degrees. inf and nan still parse, so
// that the plugin's own check refuses them naming the parameter.
TEST_F(ParserTest, NumbersAreDecimalOnly) {
    auto camera = [](const std::string& property) {
        return "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n"
               "<integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"6\"/>\n" +
               property + "\n</camera>\n</scene>\n";
    };
    for (const std::string number : {"0x10", "0x1p4", "-0X1.8P+3", "nan(123)", "1e", "1e+", ".",
                                     "e5", "1.2.3", "1,5", "0x", "infinit", "--1", "-+inf", "1e5f"})
        expectError(
            camera("<float name=\"fov\" value=\"" + number + "\"/>"),
            {"bad.xml:5:", "could not parse the number \"" + number + "\"", "numbers are decimal"});
    expectError(sceneWith("<sampler type=\"independent\">\n<integer name=\"sampleCount\" "
                          "value=\"0x10\"/></sampler>"),
                {"bad.xml:5:", "could not parse the integer \"0x10\""});
    expectError(camera("<float name=\"fov\" value=\"inf\"/>"),
                {"bad.xml:3:", "fov must be in (0, 180) degrees, got inf"});
    expectError(camera("<float name=\"fov\" value=\"-NaN\"/>"),
                {"bad.xml:3:", "fov must be in (0, 180) degrees, got"});
    expectError(camera("<point name=\"x\" value=\"0x1, 0, 0\"/>"),
                {"bad.xml:5:", "could not parse the number \"0x1\""});
    for (const std::string number : {"16", "+16", "16.", ".5e2", "1.6E1", "160e-1", " 16 "})
        EXPECT_NO_THROW(parseSceneFile(
            write("ok.xml", camera("<float name=\"fov\" value=\"" + number + "\"/>"))))
            << number;
}

// Nori's statistical test files aim every camera sample along one direction with fov 1e-6 (a
// 1x1 image): `alphorn test` must load them. Every fov in (0, 180) that float precision can
// render loads; what is no field of view at all is refused at the camera's line, naming the
// value, and so is a fov too narrow for float, saying why.
TEST_F(ParserTest, EveryFieldOfViewThatRendersIsAccepted) {
    auto camera = [](const std::string& fov) {
        return "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n"
               "<integer name=\"width\" value=\"1\"/><integer name=\"height\" value=\"1\"/>\n"
               "<float name=\"fov\" value=\"" +
               fov + "\"/>\n</camera>\n</scene>\n";
    };
    for (const std::string fov : {"1e-6", "1e-6 ", "0.001", "1e-20", "179.99998"})
        EXPECT_NO_THROW(parseSceneFile(write("ok.xml", camera(fov)))) << fov;
    for (const std::string fov : {"nan", "-nan", "inf", "-inf", "0", "-0", "-1e-6", "180", "360"})
        expectError(camera(fov), {"bad.xml:3:", "fov must be in (0, 180) degrees, got "});
    expectError(camera("1e-38"),
                {"bad.xml:3:", "fov 1e-38 degrees is too narrow to render in float precision"});
}

// The values at the edges of the ranges that Nori scenes and course assignments use all load:
// albedo 0 and 1, radiance and power 0, one sample per pixel, roughness 1e-3 and kd 1 (no
// specular lobe), index-matched and below-1 indices of refraction, g close to +-1, a spotlight
// cone as wide as the sphere, a zero uv scale, a light of zero area.
TEST_F(ParserTest, ValuesAtTheEdgesOfTheirRangesLoad) {
    std::ofstream(m_dir / "zero_area.obj") << "v 0 1 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\n";
    auto mesh = [](const std::string& file, const std::string& inner) {
        return "<mesh type=\"obj\"><string name=\"filename\" value=\"" + file + "\"/>" + inner +
               "</mesh>\n";
    };
    const std::string body =
        "<sampler type=\"$sampler\"><integer name=\"sampleCount\" value=\"1\"/></sampler>\n" +
        mesh("triangle.obj", R"(<bsdf type="diffuse"><color name="albedo" value="0"/></bsdf>)") +
        mesh("triangle.obj", R"(<bsdf type="diffuse"><color name="albedo" value="1"/></bsdf>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="microfacet"><float name="alpha" value="1e-3"/><color name="kd" value="1"/></bsdf>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="microfacet"><float name="alpha" value="0.001"/><color name="kd" value="0"/>
                <float name="intIOR" value="1"/><float name="extIOR" value="1"/></bsdf>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="dielectric"><float name="intIOR" value="0.7"/><float name="extIOR" value="1"/></bsdf>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="dielectric"><float name="intIOR" value="1.33"/><float name="extIOR" value="1.33"/></bsdf>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="diffuse"><texture type="checkerboard2d" name="albedo"><float name="uscale" value="0"/></texture></bsdf>)") +
        mesh("triangle.obj",
             R"(<emitter type="area"><color name="radiance" value="0"/></emitter>)") +
        mesh("zero_area.obj",
             R"(<emitter type="area"><color name="radiance" value="1"/></emitter>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="null"/><medium type="homogeneous" name="inside"><color name="sigmaS" value="1"/>
                <phase type="hg"><float name="g" value="0.999"/></phase></medium>)") +
        mesh(
            "triangle.obj",
            R"(<bsdf type="null"/><medium type="homogeneous" name="inside"><color name="sigmaS" value="1"/>
                <phase type="hg"><float name="g" value="-0.999"/></phase></medium>)") +
        R"(<emitter type="point"><color name="power" value="0"/></emitter>
           <emitter type="spotlight"><color name="power" value="1"/><float name="totalAngle" value="180"/></emitter>)";
    for (const char* sampler : {"independent", "stratified", "sobol"}) {
        SceneOverrides overrides;
        overrides.parameters = {{"sampler", sampler}};
        std::shared_ptr<Scene> scene;
        ASSERT_NO_THROW(scene = loadScene(write("edges.xml", sceneWith(body)), {}, overrides))
            << sampler;
        EXPECT_EQ(scene->emitters().size(), 4u);
    }
}

// XML that is not well-formed: pugixml accepts an attribute written twice (the loader used the
// first) and elements after the root (the loader ignored them).
TEST_F(ParserTest, RepeatedAttributesAndSecondRootElementsAreRefused) {
    expectError(
        "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n"
        "  <float name=\"fov\" value=\"45\" value=\"50\"/>\n</camera>\n</scene>\n",
        {"bad.xml:4:4", "malformed XML: <float> has the attribute \"value\" more than once"});
    expectError(sceneWith("<mesh type=\"obj\" type=\"obj\"/>"),
                {"bad.xml:4:2", "<mesh> has the attribute \"type\" more than once"});
    expectError(sceneWith("") + "<scene>\n</scene>\n",
                {"bad.xml:6:2", "malformed XML: a second root element <scene> after <scene>"});
    expectError(sceneWith("") + "<mesh type=\"obj\"/>\n",
                {"bad.xml:6:2", "a second root element <mesh>"});
    expectError(sceneWith("") + "stray text\n",
                {"bad.xml:5:", "text \"stray text\" outside the root element <scene>"});
    expectError("text first\n" + sceneWith(""),
                {"bad.xml:1:1", "text \"text first\" outside the root element"});
    // Comments, processing instructions and whitespace after the root are well-formed.
    EXPECT_NO_THROW(parseSceneFile(write("ok.xml", sceneWith("") + "<!-- end -->\n<?pi x?>\n\n")));
}

TEST_F(ParserTest, MisspeltNamesAreRefusedWithTheNearestKnownOne) {
    auto camera = [](const std::string& property) {
        return "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n"
               "<integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"6\"/>\n"
               "<float name=\"" +
               property + "\" value=\"40\"/>\n</camera>\n</scene>\n";
    };
    expectError(camera("fovv"),
                {"bad.xml:5:", "<camera type=\"perspective\"> has no property \"fovv\"",
                 "did you mean \"fov\"?"});
    expectError(camera("FOV"), {"bad.xml:5:", "did you mean \"fov\"?"});
    expectError(sceneWith("<flaot name=\"fov\" value=\"1\"/>"),
                {"bad.xml:4:", "unknown element <flaot>; did you mean <float>?"});
    // A required property written with a typo is reported as missing, naming the typo.
    expectError(sceneWith("<mesh type=\"obj\"><string name=\"filenme\" value=\"x.obj\"/></mesh>"),
                {"bad.xml:4:", "missing required string property \"filename\"",
                 "\"filenme\" a misspelling"});
}

TEST_F(ParserTest, UnusedPropertiesFarFromEveryKnownNameOnlyWarn) {
    const std::string path =
        write("extra.xml",
              sceneWith("<mesh type=\"obj\"><string name=\"filename\" value=\"triangle.obj\"/>"
                        "<string name=\"mitsubaOnlyOption\" value=\"x\"/></mesh>"));
    EXPECT_NO_THROW(parseSceneFile(path));
}

TEST(ClosestName, PicksTheNearestWithinOneEditPerThreeLetters) {
    const std::vector<std::string> names = {"fov", "width", "height", "toWorld", "filename"};
    EXPECT_EQ(closestName("fovv", names), "fov");
    EXPECT_EQ(closestName("wdith", names), "width");  // neighbouring letters swapped: one edit
    EXPECT_EQ(closestName("TOWORLD", names), "toWorld");
    EXPECT_EQ(closestName("heihgt", names), "height");
    EXPECT_EQ(closestName("filenme", names), "filename");
    EXPECT_EQ(closestName("xyz", names), "");
    EXPECT_EQ(closestName("weight", names), "height");
    EXPECT_EQ(closestName("fov", names), "");       // a name is not a misspelling of itself
    EXPECT_EQ(closestName("fixxxame", names), "");  // three edits in eight letters: not close
    // Very long names are not compared (the work grows with the product of the lengths).
    EXPECT_EQ(closestName(std::string(300, 'a'), {std::string(299, 'a')}), "");
}

TEST_F(ParserTest, DollarNamesTakeTheirDefinedValues) {
    const std::string path = write(
        "params.xml",
        "<scene>\n<integrator type=\"$integrator\"/>\n<camera type=\"perspective\">\n"
        "<integer name=\"width\" value=\"$w\"/><integer name=\"height\" value=\"1$w\"/>\n"
        "<float name=\"fov\" value=\"$fov\"/>\n</camera>\n"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"$mesh.obj\"/></mesh>\n</scene>\n");
    SceneOverrides overrides;
    overrides.parameters = {
        {"integrator", "normals"}, {"w", "8"}, {"fov", "40"}, {"mesh", "triangle"}};
    // An integrator type left as "$integrator" would be an unknown type: loading proves it.
    auto scene = std::static_pointer_cast<Scene>(parseSceneFile(path, {}, overrides).root);
    EXPECT_EQ(scene->camera()->outputSize(), Vector2i(8, 18));

    overrides.parameters.erase("fov");
    try {
        parseSceneFile(path, {}, overrides);
        FAIL() << "an undefined $fov was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("params.xml:5:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("$fov in value=\"$fov\" is not defined"),
                  std::string::npos)
            << e.what();
    }
}

TEST_F(ParserTest, ImageSizeOverrideReplacesTheCameraSize) {
    const std::string path =
        write("sized.xml", sceneWith("<mesh type=\"obj\"><string name=\"filename\" "
                                     "value=\"triangle.obj\"/></mesh>"));
    SceneOverrides overrides;
    overrides.imageSize = Vector2i(5, 3);
    auto scene = std::static_pointer_cast<Scene>(parseSceneFile(path, {}, overrides).root);
    EXPECT_EQ(scene->camera()->outputSize(), Vector2i(5, 3));
    scene = std::static_pointer_cast<Scene>(parseSceneFile(path).root);
    EXPECT_EQ(scene->camera()->outputSize(), Vector2i(8, 6));
}

TEST_F(ParserTest, MissingSceneFileIsAnError) {
    EXPECT_THROW(parseSceneFile((m_dir / "nope.xml").string()), Error);
    EXPECT_THROW(parseSceneFile(m_dir.string()), Error);
}

// A farm job's bundle: the scene in scenes/, the meshes in meshes/, and a file beside the bundle
// standing in for the server's own files.
class ConfinedParserTest : public ParserTest {
  protected:
    void SetUp() override {
        ParserTest::SetUp();
        namespace fs = std::filesystem;
        m_bundle = m_dir / "bundle";
        fs::create_directories(m_bundle / "scenes");
        fs::create_directories(m_bundle / "meshes");
        fs::copy_file(m_dir / "triangle.obj", m_bundle / "meshes/triangle.obj");
        fs::copy_file(m_dir / "triangle.obj", m_dir / "outside.obj");
        m_policy.confinementRoot = m_bundle.string();
    }
    std::string sceneNaming(const std::string& filename) {
        const std::string path = (m_bundle / "scenes/s.xml").string();
        std::ofstream(path) << sceneWith("<mesh type=\"obj\"><string name=\"filename\" value=\"" +
                                         filename + "\"/></mesh>");
        return path;
    }
    // Expects the confined load to fail with every fragment, and never to show where the bundle
    // lies on disk.
    void expectRefused(const std::string& filename, std::initializer_list<std::string> fragments) {
        try {
            loadScene(sceneNaming(filename), m_policy);
            FAIL() << "\"" << filename << "\" was accepted";
        } catch (const Error& e) {
            const std::string message = e.what();
            for (const std::string& f : fragments)
                EXPECT_NE(message.find(f), std::string::npos)
                    << "message \"" << message << "\" lacks \"" << f << "\"";
            EXPECT_EQ(message.find(m_bundle.string()), std::string::npos) << message;
        }
    }

    std::filesystem::path m_bundle;
    FileReferencePolicy m_policy;
};

TEST_F(ConfinedParserTest, FilesInsideTheRootLoad) {
    auto scene = loadScene(sceneNaming("../meshes/triangle.obj"), m_policy);
    EXPECT_EQ(scene->meshes().size(), 1u);
    // ".." that comes back inside is fine; so is a link whose target is inside.
    EXPECT_NO_THROW(loadScene(sceneNaming("../meshes/../meshes/triangle.obj"), m_policy));
    std::filesystem::create_symlink("triangle.obj", m_bundle / "meshes/alias.obj");
    EXPECT_NO_THROW(loadScene(sceneNaming("../meshes/alias.obj"), m_policy));
}

TEST_F(ConfinedParserTest, AbsolutePathsAreRefused) {
    const std::string outside = (m_dir / "outside.obj").string();
    expectRefused(outside, {"scenes/s.xml:4:", "\"" + outside + "\" is an absolute path"});
    expectRefused("/etc/shadow", {"scenes/s.xml:4:", "\"/etc/shadow\" is an absolute path"});
    // Inside the root, but named absolutely: the scene must not know where its bundle lies.
    const std::string inside = (m_bundle / "meshes/triangle.obj").string();
    EXPECT_THROW(loadScene(sceneNaming(inside), m_policy), Error);
}

TEST_F(ConfinedParserTest, DotDotEscapesAreRefused) {
    for (const std::string& escape :
         {std::string("../../outside.obj"), std::string("../meshes/../../outside.obj"),
          std::string("../../../../../../../../../../etc/shadow"),
          std::string("../../bundle2/x.obj")})
        expectRefused(escape, {"scenes/s.xml:4:", "\"" + escape + "\" leaves the scene bundle",
                               "paths must stay inside it"});
}

TEST_F(ConfinedParserTest, SymbolicLinksLeadingOutAreRefused) {
    std::filesystem::create_symlink(m_dir / "outside.obj", m_bundle / "meshes/link.obj");
    expectRefused("../meshes/link.obj", {"scenes/s.xml:4:", "\"../meshes/link.obj\"",
                                         "leaves the scene bundle through a symbolic link"});
    std::filesystem::create_symlink(m_dir, m_bundle / "up");
    expectRefused("../up/outside.obj", {"scenes/s.xml:4:", "symbolic link"});
}

TEST_F(ConfinedParserTest, EveryFileValuedPropertyIsConfined) {
    const std::string texture = sourcePath("scenes/seed/textures/bumps_normal.png");
    const std::string path = (m_bundle / "scenes/t.xml").string();
    std::ofstream(path) << sceneWith(
        "<mesh type=\"obj\"><string name=\"filename\" value=\"../meshes/triangle.obj\"/>\n"
        "<bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"albedo\">"
        "<string name=\"filename\" value=\"" +
        texture + "\"/></texture></bsdf></mesh>");
    EXPECT_NO_THROW(loadScene(path));  // on disk the texture loads
    try {
        loadScene(path, m_policy);
        FAIL() << "the bitmap's absolute path was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("scenes/t.xml:5:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("is an absolute path"), std::string::npos) << e.what();
    }
}

TEST_F(ConfinedParserTest, MessagesNameFilesByTheirPlaceInTheRoot) {
    // A missing file and a broken scene are reported as the user knows them, without the
    // directory the bundle was materialized in.
    expectRefused("../meshes/missing.obj", {"scenes/s.xml:4:", "\"meshes/missing.obj\""});
    const std::string path = (m_bundle / "scenes/bad.xml").string();
    std::ofstream(path) << "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"nosuch\"/>\n";
    try {
        loadScene(path, m_policy);
        FAIL() << "a malformed scene was accepted";
    } catch (const Error& e) {
        EXPECT_EQ(std::string(e.what()).rfind("scenes/bad.xml:", 0), 0u) << e.what();
    }
}

TEST_F(ConfinedParserTest, LocalScenesMayNameAnyFile) {
    // Without a root, a scene on disk may reach outside its folder or name absolute paths.
    EXPECT_NO_THROW(loadScene(sceneNaming("../../outside.obj")));
    EXPECT_NO_THROW(loadScene(sceneNaming((m_dir / "outside.obj").string())));
    // Relative-only (what `alphorn submit` checks): ".." is fine, an absolute path is not.
    FileReferencePolicy relativeOnly;
    relativeOnly.relativeOnly = true;
    EXPECT_NO_THROW(loadScene(sceneNaming("../../outside.obj"), relativeOnly));
    EXPECT_THROW(loadScene(sceneNaming((m_dir / "outside.obj").string()), relativeOnly), Error);
}

// Every way a scene names a file (an OBJ file, named twice and through "..", and bitmap textures
// as a BSDF's albedo, a normal map, a projector's image and inside a combination texture) is
// listed without building the scene, as the files loading it reads. (Media take 3D textures
// only, so no medium names a file.)
TEST_F(ParserTest, ListingNamesTheFilesLoadingReads) {
    std::filesystem::create_directories(m_dir / "tex");
    Image image(2, 2);
    std::fill(image.rgb.begin(), image.rgb.end(), 0.5f);
    for (const char* name :
         {"tex/albedo.png", "tex/normals.png", "tex/slide.png", "tex/nested.png"})
        writePNG((m_dir / name).string(), image);
    const std::string path = write("files.xml", R"(<scene>
<integrator type="volume_path_mis"/>
<camera type="perspective"><integer name="width" value="8"/><integer name="height" value="6"/></camera>
<emitter type="projector"><texture type="bitmap"><string name="filename" value="tex/slide.png"/></texture></emitter>
<mesh type="obj"><string name="filename" value="triangle.obj"/>
  <bsdf type="normalmap">
    <bsdf type="diffuse"><texture type="bitmap" name="albedo"><string name="filename" value="tex/albedo.png"/></texture></bsdf>
    <texture type="bitmap" name="normalmap"><string name="filename" value="tex/normals.png"/><boolean name="raw" value="true"/></texture>
  </bsdf>
</mesh>
<mesh type="obj"><string name="filename" value="tex/../triangle.obj"/>
  <bsdf type="diffuse">
    <texture type="combination" name="albedo"><string name="operation" value="product"/>
      <texture type="bitmap" name="a"><string name="filename" value="tex/nested.png"/></texture>
      <texture type="constant" name="b"><color name="value" value="0.5"/></texture>
    </texture>
  </bsdf>
</mesh>
</scene>)");
    auto sorted = [](std::vector<std::string> paths) {
        std::sort(paths.begin(), paths.end());
        return paths;
    };
    const std::vector<std::string> listed = sorted(listSceneFiles(path));
    EXPECT_EQ(listed, sorted(parseSceneFile(path).dependencies));
    std::vector<std::string> expected;
    for (const char* name : {"triangle.obj", "triangle.obj", "tex/albedo.png", "tex/normals.png",
                             "tex/slide.png", "tex/nested.png"})
        expected.push_back((m_dir / name).string());
    EXPECT_EQ(listed, sorted(expected));
}

// Listing reads no mesh and decodes no image: an OBJ file with a face beyond its vertices and a
// PNG that is not one, both refused when the scene loads, are listed. The parser's own checks
// and files that cannot be opened are refused as loading refuses them, naming file and line.
TEST_F(ParserTest, ListingBuildsNothingButRefusesWhatTheParserAndMissingFilesWould) {
    std::ofstream(m_dir / "bad.obj") << "v 0 0 0\nv 1 0 0\nf 1 2 3\n";
    std::ofstream(m_dir / "bad.png") << "not a PNG";
    const std::string path =
        write("broken.xml", sceneWith(R"(<mesh type="obj"><string name="filename" value="bad.obj"/>
<bsdf type="diffuse"><texture type="bitmap" name="albedo"><string name="filename" value="bad.png"/></texture></bsdf></mesh>)"));
    EXPECT_THROW(parseSceneFile(path), Error);
    std::vector<std::string> listed = listSceneFiles(path);
    std::sort(listed.begin(), listed.end());
    EXPECT_EQ(listed, (std::vector<std::string>{(m_dir / "bad.obj").string(),
                                                (m_dir / "bad.png").string()}));

    auto expectListingError = [&](const std::string& body, const std::string& fragment) {
        const std::string bad = write("bad.xml", sceneWith(body));
        try {
            listSceneFiles(bad);
            ADD_FAILURE() << "listed: " << body;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find(bad + ":4:"), std::string::npos) << message;
            EXPECT_NE(message.find(fragment), std::string::npos) << message;
        }
    };
    expectListingError(R"(<mesh type="obj"><string name="filename" value="none.obj"/></mesh>)",
                       "cannot open OBJ file");
    expectListingError(
        R"(<mesh type="obj"><string name="filename" value="triangle.obj"/><bsdf type="diffuse"><texture type="bitmap" name="albedo"><string name="filename" value="none.png"/></texture></bsdf></mesh>)",
        "the texture file");
    expectListingError(R"(<mesh type="obj"/>)", "filename");
    expectListingError(R"(<mesh type="ojb"/>)", "unknown mesh type \"ojb\"");
    expectListingError(R"(<mesh type="obj"><float name="x" value="1.2.3"/></mesh>)",
                       "could not parse the number");
    expectListingError(R"(<mesh type="obj"><strnig name="filename" value="triangle.obj"/></mesh>)",
                       "unknown element <strnig>");
}

// A scene loaded to be checked builds every object but no BVH, with the bounds (and so the
// default radii) of a scene loaded to render.
TEST_F(ParserTest, CheckingASceneBuildsNoBvhButKeepsItsBounds) {
    const std::string path = write("photons.xml", R"(<scene>
<integrator type="photonmapper"><boolean name="progressive" value="true"/><integer name="photonCount" value="100"/></integrator>
<camera type="perspective"><integer name="width" value="8"/><integer name="height" value="6"/></camera>
<emitter type="point"><point name="position" value="0, 1, 3"/><color name="power" value="1"/></emitter>
<mesh type="obj"><string name="filename" value="triangle.obj"/>
  <transform name="toWorld"><scale value="3, 2, 1"/><translate value="0.1, 0.2, 0.3"/></transform></mesh>
</scene>)");
    const uint64_t built = embreeScenesBuilt();
    const std::shared_ptr<Scene> checked = loadScene(path, {}, {}, {}, SceneUse::Check);
    EXPECT_EQ(embreeScenesBuilt(), built);
    EXPECT_FALSE(checked->canTrace());
    const std::shared_ptr<Scene> rendered = loadScene(path);
    EXPECT_EQ(embreeScenesBuilt(), built + 1);
    EXPECT_TRUE(rendered->canTrace());
    EXPECT_EQ(checked->bounds().min(), rendered->bounds().min());
    EXPECT_EQ(checked->bounds().max(), rendered->bounds().max());
    ASSERT_TRUE(checked->integrator()->radiusSchedule());
    EXPECT_EQ(checked->integrator()->radiusSchedule()->initialRadius,
              rendered->integrator()->radiusSchedule()->initialRadius);
}

}  // namespace
}  // namespace alphorn
