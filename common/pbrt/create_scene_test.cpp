// The pbrt-v4 front end's scenes against what they must equal: the same scene written in Nori XML
// (the same bytes), pbrt-v4's conventions checked on the image (its camera's handedness, the side
// a one-sided light faces), closed forms, and clear errors for what Alphorn does not render.
#include "common/core/error.h"
#include "common/render/film.h"
#include "common/render/local_render.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

namespace fs = std::filesystem;

std::string scratch() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const fs::path dir =
        fs::temp_directory_path() / (std::string("alphorn_pbrt_scene_") + info->name());
    fs::create_directories(dir);
    return dir.string();
}

std::string write(const std::string& dir, const std::string& name, const std::string& text) {
    const std::string path = dir + "/" + name;
    std::ofstream(path) << text;
    return path;
}

FilmBlock render(const Scene& scene, uint32_t passes, uint64_t seed = 7) {
    RenderSettings settings;
    settings.passes = passes;
    settings.seed = seed;
    settings.tileSize = 16;
    return renderLocal(scene, settings);
}

// Expects loading the scene to fail with a message that starts with `where` and contains `what`.
void expectError(const std::string& path, const std::string& where, const std::string& what) {
    try {
        loadScene(path);
        ADD_FAILURE() << "no error for " << path;
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find(where), std::string::npos) << message;
        EXPECT_NE(message.find(what), std::string::npos) << message;
    }
}

// A camera on the +z axis looking at the origin, a floor quad, and a quad light above it whose
// winding faces up (away from the floor): ReverseOrientation turns it down. Axis-aligned, so
// both formats compute the same matrices to the bit.
constexpr const char* kPbrtBox = R"(
LookAt 0 0.5 5  0 0.5 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 24 "integer yresolution" 16
Sampler "independent" "integer pixelsamples" 4
Integrator "path" "integer maxdepth" 3
PixelFilter "box"
WorldBegin
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.7 0.6 0.5]
  Shape "trianglemesh" "point3 P" [-2 0 -2  2 0 -2  2 0 2  -2 0 2] "integer indices" [0 2 1 0 3 2]
AttributeEnd
AttributeBegin
  ReverseOrientation
  AreaLightSource "diffuse" "rgb L" [4 4 4]
  Material "diffuse" "rgb reflectance" [0 0 0]
  Shape "trianglemesh" "point3 P" [-0.5 2 -0.5  0.5 2 -0.5  0.5 2 0.5  -0.5 2 0.5]
    "integer indices" [0 2 1 0 3 2]
AttributeEnd
)";

// The same scene in Nori XML: pbrt's camera is Alphorn's mirrored in x, its fov (40 degrees
// across the shorter, vertical side) is 2 atan(tan 20 * 24/16) across the width, and the
// light's winding is the reverse of the pbrt file's (ReverseOrientation, no normals).
std::string xmlBox(const std::string& dir) {
    write(dir, "floor.obj", "v -2 0 -2\nv 2 0 -2\nv 2 0 2\nv -2 0 2\nf 1 3 2\nf 1 4 3\n");
    write(dir, "light.obj",
          "v -0.5 2 -0.5\nv 0.5 2 -0.5\nv 0.5 2 0.5\nv -0.5 2 0.5\nf 1 2 3\nf 1 3 4\n");
    const float fov =
        float(2.0 * std::atan(std::tan(40.0f * M_PI / 360.0) * 24.0 / 16.0) * 180.0 / M_PI);
    return write(dir, "box.xml",
                 absl::StrFormat(R"(<scene>
  <integrator type="path_mis"><integer name="maxDepth" value="3"/></integrator>
  <sampler type="independent"><integer name="sampleCount" value="4"/></sampler>
  <camera type="perspective">
    <float name="fov" value="%.9g"/>
    <integer name="width" value="24"/><integer name="height" value="16"/>
    <float name="farClip" value="1e12"/>
    <transform name="toWorld">
      <scale value="-1, 1, 1"/>
      <lookat origin="0, 0.5, 5" target="0, 0.5, 0" up="0, 1, 0"/>
    </transform>
    <rfilter type="box"/>
  </camera>
  <mesh type="obj"><string name="filename" value="floor.obj"/>
    <bsdf type="diffuse"><color name="albedo" value="0.7, 0.6, 0.5"/></bsdf></mesh>
  <mesh type="obj"><string name="filename" value="light.obj"/>
    <bsdf type="diffuse"><color name="albedo" value="0"/></bsdf>
    <emitter type="area"><color name="radiance" value="4"/></emitter></mesh>
</scene>)",
                                 fov));
}

TEST(PbrtScene, RendersTheSameBytesAsTheSameSceneInNoriXml) {
    const std::string dir = scratch();
    auto fromPbrt = loadScene(write(dir, "box.pbrt", kPbrtBox));
    auto fromXml = loadScene(xmlBox(dir));
    const FilmBlock pbrtFilm = render(*fromPbrt, 4), xmlFilm = render(*fromXml, 4);
    EXPECT_EQ(pbrtFilm.serialize(), xmlFilm.serialize());
    // Not an empty image: the light, turned down by ReverseOrientation, lights the floor.
    const Image image = resolveImage(pbrtFilm, 24, 16);
    double sum = 0;
    for (float v : image.rgb) sum += v;
    EXPECT_GT(sum, 1.0);
}

TEST(PbrtScene, WithoutReverseOrientationTheLightFacesAwayFromTheFloor) {
    const std::string dir = scratch();
    std::string text = kPbrtBox;
    text.replace(text.find("ReverseOrientation"), std::string("ReverseOrientation").size(), "");
    auto scene = loadScene(write(dir, "up.pbrt", text));
    const Image image = resolveImage(render(*scene, 4), 24, 16);
    for (float v : image.rgb) ASSERT_EQ(v, 0.0f);
}

// pbrt's camera shows its +x (up x view direction) on the image's right, so from +z looking at
// the origin with +y up, world +x is on the left of pbrt's image (its world is left-handed).
// A bright square at world +x must be in the left half.
TEST(PbrtScene, CameraHandednessIsPbrts) {
    const std::string dir = scratch();
    auto scene = loadScene(write(dir, "side.pbrt", R"(
LookAt 0 0 5  0 0 0  0 1 0
Camera "perspective" "float fov" 60
Film "rgb" "integer xresolution" 20 "integer yresolution" 20
Sampler "independent" "integer pixelsamples" 1
WorldBegin
AreaLightSource "diffuse" "rgb L" [1 1 1]
Shape "trianglemesh" "point3 P" [1 -0.5 0  2 -0.5 0  2 0.5 0  1 0.5 0]
  "integer indices" [0 1 2 0 2 3]
)"));
    const Image image = resolveImage(render(*scene, 1), 20, 20);
    double left = 0, right = 0;
    for (int y = 0; y < 20; ++y)
        for (int x = 0; x < 20; ++x) (x < 10 ? left : right) += image.rgb[3 * (y * 20 + x)];
    EXPECT_GT(left, 10.0);
    EXPECT_EQ(right, 0.0);
}

// The white furnace in pbrt's format: a convex diffuse solid (an octahedron, flat facets: no
// facet sees another) of reflectance 0.8 under a constant "infinite" light of L = 1 reflects
// exactly 0.8 everywhere; the sky around it is 1. A t-test over the pixels inside the solid.
TEST(PbrtScene, FurnaceUnderAConstantInfiniteLight) {
    const std::string dir = scratch();
    auto scene = loadScene(write(dir, "furnace.pbrt", R"(
LookAt 0 0 4  0 0 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 32 "integer yresolution" 32
Sampler "independent" "integer pixelsamples" 64
Integrator "volpath" "integer maxdepth" 10
PixelFilter "box"
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "diffuse" "rgb reflectance" [0.8 0.8 0.8]
Shape "trianglemesh" "point3 P" [1 0 0  -1 0 0  0 1 0  0 -1 0  0 0 1  0 0 -1]
  "integer indices" [0 2 4  2 1 4  1 3 4  3 0 4  2 0 5  1 2 5  3 1 5  0 3 5]
)"));
    const Image image = resolveImage(render(*scene, 64), 32, 32);
    // The octahedron's front facets fill the pixels around the centre; the corners are sky.
    std::vector<double> inside;
    for (int y = 12; y < 20; ++y)
        for (int x = 12; x < 20; ++x) inside.push_back(image.rgb[3 * (y * 32 + x) + 1]);
    const stats::MeanVariance mv = stats::meanAndVariance(inside.data(), inside.size());
    const stats::TTestResult t =
        stats::studentTTest(mv.mean, mv.variance, 0.8, inside.size(), 0.01);
    EXPECT_TRUE(t.passed) << t.message;
    EXPECT_GT(mv.variance, 0.0);
    EXPECT_NEAR(image.rgb[1], 1.0f, 1e-6f);  // the sky, seen directly
}

// Instancing through ObjectBegin/ObjectInstance (Embree instances of one mesh group) renders the
// same bytes as the same triangles written out flat, for the identity and a dyadic translation
// (exact in float, so both place every corner at the same bits).
TEST(PbrtScene, InstancesRenderTheBytesOfTheSameTrianglesWrittenFlat) {
    const std::string head = R"(
LookAt 1 1.5 3  1 0 -2  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" 24 "integer yresolution" 16
Sampler "independent" "integer pixelsamples" 2
Integrator "path" "integer maxdepth" 3
PixelFilter "box"
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [3 3 3]
  Shape "trianglemesh" "point3 P" [-4 4 -4  4 4 -4  4 4 4  -4 4 4] "integer indices" [0 1 2 0 2 3]
AttributeEnd
Material "diffuse" "rgb reflectance" [0.6 0.5 0.4]
)";
    const std::string block =
        "Shape \"trianglemesh\" \"point3 P\" [-1 0 -1  1 0 -1  1 0.5 1  -1 0.25 1  0 1 0]\n"
        "  \"integer indices\" [0 2 1  0 3 2  0 4 3  1 2 4]\n";
    const std::string dir = scratch();
    auto instanced = loadScene(write(dir, "instanced.pbrt",
                                     head + "ObjectBegin \"rock\"\n" + block +
                                         "ObjectEnd\n"
                                         "ObjectInstance \"rock\"\n"
                                         "Translate 2 0 -4\n"
                                         "ObjectInstance \"rock\"\n"));
    auto flat = loadScene(write(dir, "flat.pbrt", head + block + "Translate 2 0 -4\n" + block));
    EXPECT_EQ(instanced->instances().size(), 2u);
    EXPECT_TRUE(flat->instances().empty());
    const FilmBlock film = render(*instanced, 2);
    EXPECT_EQ(film.serialize(), render(*flat, 2).serialize());
    // The rocks are in view and lit: the bytes compared are an image, not darkness.
    const Image image = resolveImage(film, 24, 16);
    int lit = 0;
    for (float v : image.rgb) lit += v > 0.0f;
    EXPECT_GT(lit, 20);
}

// pbrt-v4's area light "power": L is scaled so that the shape emits that flux, pi L area (twice
// for a two-sided light); the light's colour is kept.
TEST(PbrtScene, AreaLightPowerSetsTheFlux) {
    const std::string dir = scratch();
    auto scene = loadScene(write(dir, "power.pbrt", R"(Camera "perspective"
WorldBegin
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 0.5 0.25] "float power" 10
  Shape "trianglemesh" "point3 P" [0 0 0  2 0 0  2 2 0  0 2 0] "integer indices" [0 1 2 0 2 3]
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [1 1 1] "float power" 10 "bool twosided" true
  Translate 0 0 5
  Shape "disk" "float radius" 1
AttributeEnd
)"));
    ASSERT_EQ(scene->emitters().size(), 2u);
    const Color3f quad = scene->emitters()[0]->power(), disk = scene->emitters()[1]->power();
    EXPECT_NEAR(quad.r(), 10.0f, 1e-4f);
    EXPECT_NEAR(quad.g(), 5.0f, 1e-4f);
    EXPECT_NEAR(quad.b(), 2.5f, 1e-4f);
    EXPECT_NEAR(disk.g(), 10.0f, 1e-4f);
}

TEST(PbrtScene, WhatAlphornDoesNotRenderIsRefusedWhereItIsWritten) {
    const std::string dir = scratch();
    const std::string head = "Camera \"perspective\"\nWorldBegin\n";
    expectError(write(dir, "curve.pbrt", head + "Shape \"curve\" \"point3 P\" [0 0 0 1 1 1]\n"),
                "curve.pbrt:3:1", "Shape \"curve\": Alphorn reads the shapes");
    expectError(write(dir, "unused.pbrt", head + "Shape \"sphere\" \"float radisu\" 2\n"),
                "unused.pbrt:3:16", "does not support the parameter \"float radisu\"");
    expectError(write(dir, "hair.pbrt", head + "Material \"hair\"\nShape \"sphere\"\n"),
                "hair.pbrt:3:1", "Material \"hair\": this material is not supported");
    expectError(
        write(dir, "crop.pbrt",
              "Film \"rgb\" \"float cropwindow\" [0 .5 0 .5]\n" + head + "Shape \"sphere\"\n"),
        "crop.pbrt:1:12", "\"cropwindow\" (a part of the image) is not supported");
    expectError(write(dir, "ortho.pbrt", "Camera \"orthographic\"\nWorldBegin\n"), "ortho.pbrt:1:1",
                "Alphorn's cameras are perspective");
    expectError(write(dir, "alpha.pbrt", head + "Shape \"sphere\" \"float alpha\" 0.5\n"),
                "alpha.pbrt:3:16", "alpha (cut-outs) is not supported");
    expectError(write(dir, "sppm.pbrt", "Integrator \"sppm\"\n" + head), "sppm.pbrt:1:1",
                "Alphorn renders volpath and path");
    expectError(write(dir, "index.pbrt",
                      head + "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] "
                             "\"integer indices\" [0 1 3]\n"),
                "index.pbrt:3:", "the index 3 is outside the 3 vertices");
    expectError(write(dir, "tex.pbrt",
                      head + "Material \"diffuse\" \"texture reflectance\" "
                             "\"nothing\"\nShape \"sphere\"\n"),
                "tex.pbrt:3:20", "the spectrum texture \"nothing\" is not defined");
}

TEST(PbrtScene, ListsEveryFileItNamesWithoutBuildingIt) {
    const std::string dir = scratch();
    fs::create_directories(dir + "/geometry");
    write(dir, "geometry/part.pbrt", "Shape \"plymesh\" \"string filename\" \"geometry/m.ply\"\n");
    write(dir, "geometry/m.ply", "not read when listing");
    write(dir, "wood.png", "not read when listing");
    const std::string scene = write(dir, "list.pbrt", R"(WorldBegin
Texture "wood" "spectrum" "imagemap" "string filename" "wood.png"
Include "geometry/part.pbrt"
)");
    std::vector<std::string> files = listSceneFiles(scene);
    std::sort(files.begin(), files.end());
    EXPECT_EQ(files, (std::vector<std::string>{dir + "/geometry/m.ply", dir + "/geometry/part.pbrt",
                                               dir + "/wood.png"}));
    // Confined to the bundle, a file outside it is refused naming the directive.
    write(dir, "escape.pbrt", "WorldBegin\nShape \"plymesh\" \"string filename\" \"../x.ply\"\n");
    FileReferencePolicy policy;
    policy.confinementRoot = dir;
    try {
        listSceneFiles(dir + "/escape.pbrt", policy);
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("escape.pbrt:2:17 (Shape \"plymesh\")"),
                  std::string::npos)
            << e.what();
        EXPECT_NE(std::string(e.what()).find("leaves the scene bundle"), std::string::npos);
        EXPECT_EQ(std::string(e.what()).find(dir), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace alphorn
