#include "common/pbrt/parser.h"

#include "common/core/error.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace alphorn::pbrt {
namespace {

// A scratch directory per test, for included files.
std::string scratch() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const auto dir = std::filesystem::temp_directory_path() /
                     (std::string("alphorn_pbrt_parser_") + info->name());
    std::filesystem::create_directories(dir);
    return dir.string();
}

PropertyList resolverIn(const std::string& directory) {
    PropertyList resolver("resolver");
    resolver.setBaseDirectory(directory);
    return resolver;
}

SceneDescription parse(const std::string& text, const std::string& directory = scratch()) {
    return parseSceneDescriptionText(text, "s.pbrt", resolverIn(directory));
}

// Expects parsing to fail with a message that starts with `where` and contains `what`.
void expectError(const std::string& text, const std::string& where, const std::string& what) {
    try {
        parse(text);
        ADD_FAILURE() << "no error for: " << text;
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_EQ(message.rfind(where, 0), 0u) << message;
        EXPECT_NE(message.find(what), std::string::npos) << message;
    }
}

Eigen::Matrix4d translation(double x, double y, double z) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    m.block<3, 1>(0, 3) = Eigen::Vector3d(x, y, z);
    return m;
}

TEST(PbrtParser, TransformsComposeAsPbrtsCurrentTransformMatrix) {
    const SceneDescription scene = parse(R"(
WorldBegin
Translate 1 2 3
Scale 2 2 2
Rotate 90 0 0 1
Shape "sphere"
Identity
ConcatTransform [1 0 0 0  0 1 0 0  0 0 1 0  5 6 7 1]
Transform 1 0 0 0  0 1 0 0  0 0 1 0  -1 0 0 1
Shape "sphere"
)");
    ASSERT_EQ(scene.shapes.size(), 2u);
    Eigen::Matrix4d rotation = Eigen::Matrix4d::Identity();
    rotation.block<3, 3>(0, 0) =
        Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Matrix4d expected =
        translation(1, 2, 3) * Eigen::Vector4d(2, 2, 2, 1).asDiagonal().toDenseMatrix() * rotation;
    EXPECT_TRUE(scene.shapes[0].toWorld.isApprox(expected, 1e-12));
    // Transform replaces, ConcatTransform multiplies; both take their 16 numbers column by column.
    EXPECT_TRUE(scene.shapes[1].toWorld.isApprox(translation(-1, 0, 0), 1e-12));
}

TEST(PbrtParser, LookAtAndTheCameraTransform) {
    const SceneDescription scene = parse(R"(
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 45
WorldBegin
CoordSysTransform "camera"
Shape "sphere"
)");
    ASSERT_TRUE(scene.camera);
    const Eigen::Matrix4d& toWorld = scene.camera->toWorld;  // world from camera
    // The camera sits at the eye and looks along its +z towards the origin.
    EXPECT_TRUE((toWorld.block<3, 1>(0, 3).isApprox(Eigen::Vector3d(0, 0, 5))));
    EXPECT_TRUE((toWorld.block<3, 1>(0, 2).isApprox(Eigen::Vector3d(0, 0, -1))));
    EXPECT_TRUE((toWorld.block<3, 1>(0, 1).isApprox(Eigen::Vector3d(0, 1, 0))));
    // pbrt's "right" is up x dir.
    EXPECT_TRUE((toWorld.block<3, 1>(0, 0).isApprox(Eigen::Vector3d(-1, 0, 0))));
    EXPECT_EQ(scene.camera->parameters.getFloat("fov", 0), 45.0f);
    // "camera" names the camera's space after Camera.
    EXPECT_TRUE(scene.shapes.at(0).toWorld.isApprox(toWorld, 1e-12));
}

TEST(PbrtParser, AttributeBlocksSaveAndRestoreTheGraphicsState) {
    const SceneDescription scene = parse(R"(
WorldBegin
Material "diffuse"
AttributeBegin
  Translate 1 0 0
  Material "conductor"
  ReverseOrientation
  AreaLightSource "diffuse" "rgb L" [1 1 1]
  Shape "sphere"
AttributeEnd
Shape "sphere"
TransformBegin
  Translate 0 2 0
  Material "dielectric"
TransformEnd
Shape "sphere"
)");
    ASSERT_EQ(scene.shapes.size(), 3u);
    const ShapeEntity &inner = scene.shapes[0], &outer = scene.shapes[1], &after = scene.shapes[2];
    EXPECT_EQ(scene.materials.at(inner.materialIndex).type, "conductor");
    EXPECT_TRUE(inner.reverseOrientation);
    EXPECT_TRUE(inner.areaLight.has_value());
    EXPECT_TRUE(inner.toWorld.isApprox(translation(1, 0, 0)));
    EXPECT_EQ(scene.materials.at(outer.materialIndex).type, "diffuse");
    EXPECT_FALSE(outer.reverseOrientation);
    EXPECT_FALSE(outer.areaLight.has_value());
    EXPECT_TRUE(outer.toWorld.isIdentity());
    // TransformEnd restores the transform only: the material set inside stays.
    EXPECT_TRUE(after.toWorld.isIdentity());
    EXPECT_EQ(scene.materials.at(after.materialIndex).type, "dielectric");
}

TEST(PbrtParser, ParametersKeepTheirTypesAndValues) {
    const SceneDescription scene = parse(R"(
WorldBegin
MakeNamedMaterial "gold" "string type" "conductor" "spectrum eta" "metal-Au-eta"
  "float roughness" 0.1 "bool remaproughness" false
NamedMaterial "gold"
Shape "trianglemesh" "point P" [0 0 0 1 0 0 0 1 0] "integer indices" [0 1 2]
  "normal N" [0 0 1 0 0 1 0 0 1] "point2 uv" [0 0 1 0 0 1]
)");
    const Entity& gold = scene.namedMaterials.at("gold");
    EXPECT_EQ(gold.type, "conductor");
    EXPECT_EQ(gold.parameters.find("eta")->strings.at(0), "metal-Au-eta");
    EXPECT_EQ(gold.parameters.getFloat("roughness", 0), 0.1f);
    EXPECT_FALSE(gold.parameters.getBool("remaproughness", true));
    const ShapeEntity& mesh = scene.shapes.at(0);
    EXPECT_EQ(mesh.materialName, "gold");
    EXPECT_EQ(mesh.parameters.getTriples("P", "point3").size(), 9u);  // "point" is point3
    EXPECT_EQ(mesh.parameters.getTriples("N", "normal3").size(), 9u);
    EXPECT_EQ(mesh.parameters.getIntegers("indices"), (std::vector<int>{0, 1, 2}));
    EXPECT_EQ(mesh.parameters.firstUnused()->name, "uv");
}

TEST(PbrtParser, IncludesResolveAgainstTheMainFilesDirectory) {
    const std::string dir = scratch();
    std::filesystem::create_directories(dir + "/geometry");
    std::ofstream(dir + "/geometry/a.pbrt") << "Include \"geometry/b.pbrt\"\nShape \"disk\"\n";
    std::ofstream(dir + "/geometry/b.pbrt") << "Shape \"sphere\" \"float radius\" 2\n";
    const SceneDescription scene =
        parse("WorldBegin\nInclude \"geometry/a.pbrt\"\nShape \"cylinder\"\n", dir);
    ASSERT_EQ(scene.shapes.size(), 3u);
    EXPECT_EQ(scene.shapes[0].type, "sphere");
    EXPECT_EQ(scene.shapes[0].location.toString(), "geometry/b.pbrt:1:1");
    EXPECT_EQ(scene.shapes[1].type, "disk");
    EXPECT_EQ(scene.shapes[1].location.toString(), "geometry/a.pbrt:2:1");
    EXPECT_EQ(scene.shapes[2].location.toString(), "s.pbrt:3:1");
    EXPECT_EQ(scene.includedFiles.size(), 2u);
}

TEST(PbrtParser, ABadIncludeNamesTheDirective) {
    const std::string dir = scratch();
    std::ofstream(dir + "/self.pbrt") << "Include \"self.pbrt\"\n";
    expectError("WorldBegin\nInclude \"missing.pbrt\"\n", "s.pbrt:2:1",
                "cannot open the scene file");
    expectError("WorldBegin\n\nInclude \"self.pbrt\"\n", "self.pbrt:1:1",
                "includes nest more than 32 files deep");
}

TEST(PbrtParser, InstancesCollectTheirShapesAndUsesTheirPlacement) {
    const SceneDescription scene = parse(R"(
WorldBegin
ObjectBegin "tree"
  Shape "sphere"
  Shape "disk"
ObjectEnd
Translate 10 0 0
ObjectInstance "tree"
Translate 10 0 0
ObjectInstance "tree"
)");
    EXPECT_TRUE(scene.shapes.empty());
    ASSERT_EQ(scene.instances.at("tree").shapes.size(), 2u);
    ASSERT_EQ(scene.instanceUses.size(), 2u);
    EXPECT_TRUE(scene.instanceUses[1].toWorld.isApprox(translation(20, 0, 0)));
}

TEST(PbrtParser, ErrorsNameTheFileLineAndColumn) {
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" [1 2\n", "s.pbrt:2:16",
                "needs a closing ]");
    expectError("WorldBegin\nShape \"sphere\" \"flaot radius\" 1\n", "s.pbrt:2:16",
                "unknown parameter type \"flaot\"");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" \"two\"\n", "s.pbrt:2:31",
                "\"two\" is a string, not a number");
    expectError("WorldBegin\nShape \"sphere\" \"float radius\" [nan]\n", "s.pbrt:2:32",
                "\"nan\" is not a finite number");
    expectError("WorldBegin\nShape \"sphere\" \"integer n\" 1.5\n", "s.pbrt:2:28",
                "is not an integer");
    expectError("WorldBegin\n  Shpae \"sphere\"\n", "s.pbrt:2:3",
                "unknown directive \"Shpae\"; did you mean Shape?");
    expectError("Shape \"sphere\"\n", "s.pbrt:1:1", "only allowed after WorldBegin");
    expectError("WorldBegin\nCamera \"perspective\"\n", "s.pbrt:2:1",
                "only allowed before WorldBegin");
    expectError("WorldBegin\nNamedMaterial \"nothing\"\nShape \"sphere\"\n", "s.pbrt:2:1",
                "NamedMaterial \"nothing\" is not defined");
    expectError("WorldBegin\nObjectInstance \"nothing\"\n", "s.pbrt:2:1",
                "ObjectInstance \"nothing\" is not defined");
    expectError("WorldBegin\nMediumInterface \"fog\" \"\"\n", "s.pbrt:2:1",
                "the medium \"fog\" is not defined");
    expectError("WorldBegin\nAttributeEnd\n", "s.pbrt:2:1", "without a matching AttributeBegin");
    expectError("WorldBegin\nAttributeBegin\nTransformEnd\n", "s.pbrt:3:1",
                "TransformEnd closes an AttributeBegin");
    expectError("WorldBegin\nScale 1 0 1\n", "s.pbrt:2:1", "the matrix is singular");
    expectError("LookAt 0 0 0 0 0 1 0 0 1\n", "s.pbrt:1:1", "parallel to the viewing direction");
    expectError("WorldBegin\nObjectBegin \"a\"\nShape \"sphere\"\n", "s.pbrt:2:1",
                "ObjectBegin without a matching ObjectEnd");
    expectError("ColorSpace \"aces2065-1\"\n", "s.pbrt:1:1", "linear sRGB only");
}

TEST(PbrtParser, SpectrumFilesAreReadAsTheirNumbers) {
    const std::string dir = scratch();
    std::filesystem::create_directories(dir + "/spds");
    std::ofstream(dir + "/spds/metal.spd") << "# wavelength value\n400 0.2\n500 0.3\n600 0.4\n";
    std::ofstream(dir + "/spds/odd.spd") << "400 0.2 500\n";
    const SceneDescription scene = parse(R"(WorldBegin
Material "conductor" "spectrum eta" "spds/metal.spd" "spectrum k" "metal-Au-k"
Shape "sphere"
)",
                                         dir);
    const Parameter* eta = scene.materials.at(0).parameters.find("eta");
    EXPECT_TRUE(eta->strings.empty());
    EXPECT_EQ(eta->numbers, (std::vector<double>{400, 0.2, 500, 0.3, 600, 0.4}));
    // A named spectrum stays a name.
    EXPECT_EQ(scene.materials.at(0).parameters.find("k")->strings.at(0), "metal-Au-k");
    EXPECT_EQ(scene.includedFiles.size(), 0u);
    expectError("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"spds/odd.spd\"\n",
                "s.pbrt:2:22", "holds 3 numbers");
    expectError("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Xx-eta\"\n",
                "s.pbrt:2:22", "neither a named spectrum nor a readable spectrum file");
}

// pbrt-v4 reads the first of repeated parameters; so does Alphorn, with a warning.
TEST(PbrtParser, ARepeatedParameterKeepsItsFirstValue) {
    const SceneDescription scene =
        parse("WorldBegin\nShape \"sphere\" \"float radius\" 1 \"float radius\" 2\n");
    EXPECT_EQ(scene.shapes.at(0).parameters.getFloat("radius", 0), 1.0f);
    EXPECT_EQ(scene.shapes.at(0).parameters.all().size(), 1u);
    // The repeat is still checked.
    expectError("WorldBegin\nShape \"sphere\" \"float r\" 1 \"float r\" [nan]\n", "s.pbrt:2:39",
                "is not a finite number");
}

TEST(PbrtParser, MotionBlurIsRefused) {
    expectError(R"(WorldBegin
ActiveTransform EndTime
Translate 1 0 0
ActiveTransform All
Shape "sphere"
)",
                "s.pbrt:5:1", "motion blur");
    // Equal transforms at both times are no motion.
    EXPECT_EQ(parse("WorldBegin\nActiveTransform StartTime\nTranslate 1 0 0\nActiveTransform "
                    "EndTime\nTranslate 1 0 0\nActiveTransform All\nShape \"sphere\"\n")
                  .shapes.size(),
              1u);
}

TEST(PbrtParser, AttributeDefaultsApplyToLaterEntitiesOfTheirKind) {
    const SceneDescription scene = parse(R"(
WorldBegin
AttributeBegin
  Attribute "shape" "float radius" 3
  Shape "sphere"
  Shape "sphere" "float radius" 4
AttributeEnd
Shape "sphere"
)");
    EXPECT_EQ(scene.shapes[0].parameters.getFloat("radius", 1), 3.0f);
    EXPECT_EQ(scene.shapes[1].parameters.getFloat("radius", 1), 4.0f);
    EXPECT_EQ(scene.shapes[2].parameters.getFloat("radius", 1), 1.0f);
}

}  // namespace
}  // namespace alphorn::pbrt
