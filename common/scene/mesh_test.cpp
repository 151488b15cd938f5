#include "common/scene/mesh.h"

#include "common/core/dpdf.h"
#include "common/core/rng.h"
#include "common/core/system_memory.h"
#include "common/core/warp.h"
#include "common/sampler/sampler.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/scene/scene_load.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace alphorn {
namespace {

// A scene from XML text, written to a temporary file and loaded.
std::shared_ptr<Scene> sceneFrom(const std::string& xml) {
    const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                       ("alphorn_mesh_test_" + std::to_string(::getpid()) + ".xml");
    std::ofstream(path) << xml;
    auto scene = loadScene(path.string());
    std::filesystem::remove(path);
    return scene;
}

std::string meshFile(const std::string& mesh) {
    return sourcePath("scenes/meshes/") + mesh;
}

// A scene holding one of the repository's meshes, with the default BSDF unless `children` name
// one.
std::shared_ptr<Scene> sceneWithMesh(const std::string& mesh, const std::string& children = "") {
    return sceneFrom(R"(<scene><integrator type="normals"/>
<camera type="perspective"><integer name="width" value="4"/><integer name="height" value="4"/></camera>
<mesh type="obj"><string name="filename" value=")" +
                     meshFile(mesh) + R"("/>)" + children + "</mesh></scene>");
}

// A BSDF that needs the tangent: a normal map (whose unperturbed normals change nothing).
const std::string kNormalMap = R"(<bsdf type="normalmap"><bsdf type="diffuse"/>
  <texture type="constant" name="normalmap"><color name="value" value="0.5, 0.5, 1"/></texture>
</bsdf>)";

Intersection hit(const Scene& scene, const Point3f& origin, const Vector3f& direction) {
    Intersection its;
    EXPECT_TRUE(scene.rayIntersect(Ray3f(origin, direction), its));
    return its;
}

// The shading tangent follows dp/du and the bitangent the side of dp/dv, so tangent-space data
// (normal maps) keeps its orientation relative to the texture. quad.obj maps u to +x and v to +z
// under a +y normal: a mirrored mapping, so the bitangent is +z rather than n x s = -z.
TEST(MeshTangents, FollowTheUvDirectionsOnAPlane) {
    auto scene = sceneWithMesh("quad.obj", kNormalMap);
    const Intersection its = hit(*scene, Point3f(0.3f, 1.0f, 0.2f), Vector3f(0, -1, 0));
    EXPECT_NEAR(its.shFrame.n.y(), 1.0f, 1e-6f);
    EXPECT_NEAR(its.shFrame.s.x(), 1.0f, 1e-6f);
    EXPECT_NEAR(its.shFrame.t.z(), 1.0f, 1e-6f);
    // Rotated about the normal by 90 degrees, the tangent turns with the mesh.
    auto rotated = sceneWithMesh(
        "quad.obj", R"(<transform name="toWorld"><rotate axis="0, 1, 0" angle="90"/></transform>)" +
                        kNormalMap);
    const Intersection r = hit(*rotated, Point3f(0.3f, 1.0f, 0.2f), Vector3f(0, -1, 0));
    EXPECT_NEAR(std::abs(r.shFrame.s.z()), 1.0f, 1e-6f);
    EXPECT_NEAR(r.shFrame.s.dot(its.shFrame.s), 0.0f, 1e-6f);
    // Local coordinates still invert: the frame is orthonormal.
    const Vector3f d = Vector3f(0.3f, -0.5f, 0.8f).normalized();
    EXPECT_LT((its.toWorld(its.toLocal(d)) - d).norm(), 1e-6f);
}

// On the sphere u is the longitude (phi from +x towards +z): at (1, 0, 0) dp/du points along +z,
// and v (up the sphere) along +y.
TEST(MeshTangents, FollowTheUvDirectionsOnACurvedMesh) {
    auto scene = sceneWithMesh("sphere.obj", kNormalMap);
    const Intersection its = hit(*scene, Point3f(3.0f, 0.01f, 0.01f), Vector3f(-1, 0, 0));
    EXPECT_GT(its.shFrame.n.x(), 0.99f);
    EXPECT_GT(its.shFrame.s.z(), 0.99f);
    EXPECT_GT(its.shFrame.t.y(), 0.99f);
    EXPECT_NEAR(its.shFrame.s.dot(its.shFrame.n), 0.0f, 1e-5f);
    EXPECT_NEAR(its.shFrame.t.dot(its.shFrame.n), 0.0f, 1e-5f);
}

// Under a BSDF that is symmetric about the normal (every BSDF but the normal map) the tangent's
// direction changes no distribution, so a hit gets the frame built from its normal alone, even
// on a mesh with uvs; the same mesh under a normal map gets the u-aligned one.
TEST(MeshTangents, OnlyBSDFsThatNeedThemGetFramesAlignedWithU) {
    for (const char* file : {"quad.obj", "sphere.obj"}) {
        SCOPED_TRACE(file);
        const Point3f origin =
            std::string(file) == "quad.obj" ? Point3f(0.3f, 1.0f, 0.2f) : Point3f(0.1f, 0.2f, 3.0f);
        const Vector3f direction =
            std::string(file) == "quad.obj" ? Vector3f(0, -1, 0) : Vector3f(0, 0, -1);
        for (const std::string& bsdf : {std::string(), std::string(R"(<bsdf type="dielectric"/>)"),
                                        std::string(R"(<bsdf type="microfacet"/>)")}) {
            SCOPED_TRACE(bsdf);
            const Intersection its = hit(*sceneWithMesh(file, bsdf), origin, direction);
            const Frame fromNormal(its.shFrame.n);
            EXPECT_EQ(its.shFrame.s, fromNormal.s);
            EXPECT_EQ(its.shFrame.t, fromNormal.t);
        }
        const Intersection mapped = hit(*sceneWithMesh(file, kNormalMap), origin, direction);
        const Frame fromNormal(mapped.shFrame.n);
        EXPECT_GT(
            (mapped.shFrame.s - fromNormal.s).norm() + (mapped.shFrame.t - fromNormal.t).norm(),
            1e-3f);
    }
}

// End to end: a normal map whose normals lean towards +v (green above 0.5) lights a plate more
// from a light on the +v side (+z for quad.obj) than from the mirrored light on the -v side.
TEST(MeshTangents, NormalMapGreenLeansTowardsPlusV) {
    auto radianceWithLightAt = [](float z) {
        auto scene = sceneFrom(absl::StrFormat(R"(<scene><integrator type="direct_ems"/>
<camera type="perspective"><float name="fov" value="1e-3"/>
  <integer name="width" value="1"/><integer name="height" value="1"/>
  <transform name="toWorld"><lookat origin="0, 2, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
</camera>
<emitter type="point"><point name="position" value="0, 1, %g"/><color name="power" value="10"/></emitter>
<mesh type="obj"><string name="filename" value="%s"/>
  <bsdf type="normalmap"><bsdf type="diffuse"/>
    <texture type="constant" name="normalmap"><color name="value" value="0.5, 0.8, 0.9"/></texture>
  </bsdf>
</mesh></scene>)",
                                               z, meshFile("quad.obj")));
        auto sampler = scene->sampler()->clone();
        sampler->startStream(1, 0, 0, StreamPurpose::Test);
        return scene->integrator()
            ->Li(*scene, *sampler, Ray3f(Point3f(0, 2, 0), Vector3f(0, -1, 0)), nullptr)
            .r();
    };
    const float towardsV = radianceWithLightAt(1.0f), awayFromV = radianceWithLightAt(-1.0f);
    EXPECT_GT(awayFromV, 0.0f);
    EXPECT_GT(towardsV, 1.5f * awayFromV);
}

// A light sample is the point fillIntersection gives at the same triangle and barycentrics,
// bit for bit (sampleSurface computes it without frames): the triangle and the reused random
// number are found with a table built as the mesh builds its own. Meshes with normals and uvs
// (sphere.obj), a normal and uvs (quad.obj) and neither (triangle.obj).
TEST(MeshSurfaceSample, IsTheHitPointOfFillIntersection) {
    for (const char* file : {"sphere.obj", "quad.obj", "triangle.obj"}) {
        SCOPED_TRACE(file);
        auto scene = sceneWithMesh(file);
        const Mesh& mesh = *scene->meshes().at(0);
        DiscretePDF areas;
        areas.reserve(mesh.triangleCount());
        for (uint32_t i = 0; i < mesh.triangleCount(); ++i) areas.append(mesh.triangleArea(i));
        areas.normalize();
        Rng rng(5, 0, 0, StreamPurpose::Test);
        for (int i = 0; i < 200; ++i) {
            const Point2f sample(rng.nextFloat(), rng.nextFloat());
            const SurfaceSample s = mesh.sampleSurface(sample);
            float u = sample.x();
            const uint32_t triangle = static_cast<uint32_t>(areas.sampleReuse(u));
            const Point2f bary = warp::squareToUniformTriangle(Point2f(u, sample.y()));
            Intersection its;
            mesh.fillIntersection(triangle, bary.x(), bary.y(), its);
            EXPECT_EQ(s.p, its.p);
            EXPECT_EQ(s.n, its.shFrame.n);
            EXPECT_EQ(s.uv, its.uv);
            EXPECT_EQ(s.pdf, 1.0f / mesh.surfaceArea());
        }
    }
}

// The true normal (computed on demand) is the unit normal of the hit triangle's winding, and a
// mesh without vertex normals shades with it.
TEST(MeshGeometricNormal, IsTheTriangleNormalAndTheShadingNormalWithoutVertexNormals) {
    auto sphere = sceneWithMesh("sphere.obj");
    const Intersection its = hit(*sphere, Point3f(3.0f, 0.2f, 0.1f), Vector3f(-1, 0, 0));
    const Mesh& mesh = *its.mesh;
    const auto corner = [&](int k) {
        return Vector3f(mesh.positions().col(mesh.faces()(k, its.triangle)));
    };
    const Vector3f expected = (corner(1) - corner(0)).cross(corner(2) - corner(0)).normalized();
    EXPECT_LT((its.geometricNormal() - expected).norm(), 1e-6f);
    EXPECT_GT(its.geometricNormal().dot(its.shFrame.n), 0.99f);  // outward, as the vertex normals

    auto flat = sceneWithMesh("triangle.obj");
    const Mesh& triangle = *flat->meshes().at(0);
    Intersection t;
    triangle.fillIntersection(0, 0.2f, 0.3f, t);
    EXPECT_NEAR(t.geometricNormal().norm(), 1.0f, 1e-6f);
    EXPECT_EQ(t.shFrame.n, t.geometricNormal());
}

// tinyobjloader's "vw" lines are emptied (line breaks kept, for its line numbers); other lines,
// including ones that merely start with "vw", are untouched.
TEST(WavefrontOBJ, SkinWeightLinesAreEmptied) {
    EXPECT_EQ(
        preparedForTinyObj("v 0 0 0\n  vw 0 1e20 1\r\nvw\t1 2\rvwx 1\n   \nvw 3", "m.obj").text,
        "v 0 0 0\n\r\n\rvwx 1\n   \n");
    EXPECT_EQ(preparedForTinyObj("vw", "m.obj").text, "vw");
    EXPECT_EQ(preparedForTinyObj("", "m.obj").text, "");
}

// fuzz/obj_loader found a "vw" line whose joint id (1e20) tinyobjloader converted to int
// (undefined behaviour); the file now loads to a clear error or a mesh.
TEST(WavefrontOBJ, FuzzCrashSkinWeightJointIdLoadsOrFailsClearly) {
    const std::string path = sourcePath("fuzz/corpus/obj_loader/crash_vw_huge_joint_id");
    PropertyList props("test (mesh type=\"obj\")");
    props.setString("filename", path);
    try {
        ObjectFactory::create(ObjectKind::Mesh, "obj", props);
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
}

// fuzz/obj_loader found a mesh with a vertex at 3.3e31, where a ray leaving its surface made
// Embree abort (its ray validity assertion); such meshes are refused when loaded. (That file
// also has a position of one number, "v 6.000000", which is refused first now; the bound itself
// is tested with a well-formed file in ObjLinesTinyObjLoaderWouldMisreadAreRefused.)
TEST(WavefrontOBJ, FuzzCrashVertexBeyondEmbreeRangeIsRefused) {
    const std::string path = sourcePath("fuzz/corpus/obj_loader/crash_vertex_beyond_embree_range");
    PropertyList props("test (mesh type=\"obj\")");
    props.setString("filename", path);
    try {
        ObjectFactory::create(ObjectKind::Mesh, "obj", props);
        FAIL() << "a vertex at 3.3e31 was accepted";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
}

// A mesh takes an area emitter only: a point, spot or projector light nested in it was
// accepted and marked the mesh as emitting.
TEST(Mesh, PointLikeLightsCannotBeNestedInAMesh) {
    for (const std::string emitter :
         {R"(<emitter type="point"><color name="power" value="1"/></emitter>)",
          R"(<emitter type="spotlight"><color name="power" value="1"/></emitter>)"}) {
        try {
            sceneWithMesh("quad.obj", "\n" + emitter);
            ADD_FAILURE() << "accepted " << emitter;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find(":4:2 (emitter type="), std::string::npos) << message;
            EXPECT_NE(message.find("a point-like light (point, spotlight, projector) cannot be "
                                   "nested in a <mesh>"),
                      std::string::npos)
                << message;
        }
    }
    EXPECT_NO_THROW(sceneWithMesh(
        "quad.obj", R"(<emitter type="area"><color name="radiance" value="1"/></emitter>)"));
}

// Loads `obj` as a mesh; returns the error message, or "" when it loads.
std::string objLoadError(const std::string& obj) {
    const std::filesystem::path path = std::filesystem::temp_directory_path() /
                                       ("alphorn_mesh_test_" + std::to_string(::getpid()) + ".obj");
    std::ofstream(path, std::ios::binary) << obj;
    PropertyList props("scene.xml:9:3 (mesh type=\"obj\")");
    props.setString("filename", path.string());
    std::string message;
    try {
        ObjectFactory::create(ObjectKind::Mesh, "obj", props);
    } catch (const Error& e) {
        message = e.what();
    }
    std::filesystem::remove(path);
    return message;
}

// tinyobjloader read what it could not parse as 0 ("v nan 0 0", "v a b c", a missing
// coordinate), an index through atoi (99999999999999999999 wrapped, 1.5 read as 1), and a line
// only up to a NUL byte; none of that was reported. Each is refused naming the OBJ file's line.
TEST(WavefrontOBJ, ObjLinesTinyObjLoaderWouldMisreadAreRefused) {
    const std::string triangle = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    const std::vector<std::pair<std::string, std::string>> cases = {
        {"v nan 0 0\n", ":1: \"v nan 0 0\": \"nan\" is not a finite decimal number"},
        {"v 0 0 0\nv inf 0 0\n", ":2: \"v inf 0 0\": \"inf\" is not a finite decimal number"},
        {"v 1e39 0 0\n", ":1: \"v 1e39 0 0\": \"1e39\" is not a finite decimal number"},
        {"v 0 1.5e39 0\n", "\"1.5e39\" is not a finite decimal number"},
        {"v 0 0 " + std::string(39, '9') + ".5\n", "is not a finite decimal number"},
        {"v 0x1 0 0\n", "\"0x1\" is not a finite decimal number"},
        {"v a b c\n", ":1: \"v a b c\": \"a\" is not a finite decimal number"},
        {"v 1.5x 0 0\n", "\"1.5x\" is not a finite decimal number"},
        {"v 0 0\n", ":1: \"v 0 0\" has 2 numbers; \"v\" takes 3 (x y z), 4 (x y z w) or 6"},
        {"v 0 0 0 1 1\n", "\"v 0 0 0 1 1\" has 5 numbers"},
        {"vt nan 0\n", ":1: \"vt nan 0\": \"nan\" is not a finite decimal number"},
        {"vt 0 0 0 0\n", "\"vt\" takes 1 to 3 (u [v [w]])"},
        {"vn 0 nan 1\n", "\"nan\" is not a finite decimal number"},
        {"vn 0 1\n", "\"vn 0 1\" has 2 numbers; \"vn\" takes 3 (x y z)"},
        {triangle + "f 1 2 99999999999999999999\n",
         ":4: \"f 1 2 99999999999999999999\": \"99999999999999999999\" is not a face vertex"},
        {triangle + "f 1 2 2147483648\n", "\"2147483648\" is not a face vertex"},
        {triangle + "f 1 2 1.5\n", ":4: \"f 1 2 1.5\": \"1.5\" is not a face vertex"},
        {triangle + "f 1 2 0\n", "\"0\" is not a face vertex"},
        {triangle + "f 1/ 2 3\n", "\"1/\" is not a face vertex"},
        {triangle + "f 1/1/1/1 2 3\n", "\"1/1/1/1\" is not a face vertex"},
        {triangle + "f 1 2\n", ":4: \"f 1 2\": a face needs at least 3 vertices"},
        {triangle + "f 1 2 3 # a comment\n",
         ":4: \"f 1 2 3 # a comment\": \"#\" is not a face vertex"},
        {std::string("v 0 0 0\0 junk\n", 14), ":1: the line contains a NUL byte"},
        // Lines end at \n, \r or \r\n, as tinyobjloader reads them.
        {"v 0 0 0\r\nv 0 0 0\rv 0 0 0\nv x 0 0\n", ":4: \"v x 0 0\""},
    };
    for (const auto& [obj, expected] : cases) {
        const std::string message = objLoadError(obj);
        EXPECT_NE(message.find("scene.xml:9:3 (mesh type=\"obj\"): OBJ file "), std::string::npos)
            << message;
        // Every message names the file and the line; most cases say which line.
        EXPECT_NE(message.find(".obj:"), std::string::npos) << message;
        EXPECT_NE(message.find(expected[0] == ':' ? ".obj" + expected : expected),
                  std::string::npos)
            << "\"" << message << "\" lacks \"" << expected << "\"";
    }
    // Faces whose triangulation gives no triangle are not "no faces": a face of 90000 vertices
    // going round one triangle was reported so (such a face is now beyond the limit: this one
    // goes round as often as the limit allows).
    std::string polygon = triangle + "f";
    for (size_t i = 0; i < kMaxObjFaceVertices / 3 * 3; ++i)
        polygon += " " + std::to_string(1 + i % 3);
    EXPECT_NE(objLoadError(polygon + "\n")
                  .find("has 1 face, but triangulating it gave no triangle (its vertices are "
                        "collinear or coincide)"),
              std::string::npos);
    EXPECT_NE(objLoadError(triangle + "f 1 2 3 1 2 3\nf 3 2 1 3 2 1\n")
                  .find("has 2 faces, but triangulating them gave no triangle"),
              std::string::npos);
    // The forms tinyobjloader reads as written load.
    EXPECT_EQ(objLoadError(" v\t0 0 0 # a comment\nv 1 0 0 1\nv 0 1 0 1 0.5 0.25\nv +.5 -2. 1e-2\n"
                           "vt 0.5\nvt 0 1\nvt 0 1 0\nvn 0 0 1\n# f 1 2\n"
                           "f 1/1/1 2/2/1 3/3/1\nf 1//1 2//1 4//1\nf -4 -3 -1\nf 1/1 2/2 3/3\n"),
              "");
    // Vertices far out, written well, meet the bound on positions after toWorld.
    EXPECT_NE(
        objLoadError("v 3.3e31 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n").find("farther out than 1e+15"),
        std::string::npos);
}

// The counts made without building anything are those of the mesh the loader builds: one
// vertex per distinct (position, uv, normal) triple, n - 2 triangles per polygon of n.
TEST(WavefrontOBJ, CountsBeforeBuildingAreTheLoadedMeshes) {
    const ObjCounts polygons = countObjText(
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0.5 2 0\nvn 0 0 1\n"
        "f 1//1 2//1 3//1 4//1\nf 4//1 3//1 5//1\nf -5//-1 -4//1 -3//1\n",
        "m.obj");
    EXPECT_EQ(polygons.faces, 3u);
    EXPECT_EQ(polygons.triangles, 4u);
    EXPECT_EQ(polygons.vertices, 5u) << "1//1 and -5//-1 are the same vertex";
    EXPECT_TRUE(polygons.normals);
    EXPECT_FALSE(polygons.uvs);
    for (const std::string mesh : {"sphere.obj", "quad.obj", "triangle.obj"}) {
        const ObjCounts counts = countObjFile(meshFile(mesh));
        const auto scene = sceneWithMesh(mesh);  // owns the mesh below
        const Mesh& loaded = *scene->meshes().at(0);
        EXPECT_EQ(counts.triangles, loaded.triangleCount()) << mesh;
        EXPECT_EQ(counts.vertices, loaded.vertexCount()) << mesh;
        EXPECT_EQ(counts.normals, loaded.normals().cols() > 0) << mesh;
        EXPECT_EQ(counts.uvs, loaded.uvs().cols() > 0) << mesh;
    }
}

// tinyobjloader triangulates a polygon in time quadratic in its vertices (90000 took 14 s): a
// face beyond kMaxObjFaceVertices is refused by the pass before it, naming the line and count.
TEST(WavefrontOBJ, FacesBeyondTheVertexLimitAreRefused) {
    auto polygon = [](size_t n) {
        std::string text;
        for (size_t i = 0; i < n; ++i) {
            const double angle = 2.0 * M_PI * double(i) / double(n);
            text += absl::StrFormat("v %.6f %.6f 0\n", std::cos(angle), std::sin(angle));
        }
        text += "f";
        for (size_t i = 1; i <= n; ++i) text += " " + std::to_string(i);
        return text + "\n";
    };
    EXPECT_EQ(preparedForTinyObj(polygon(kMaxObjFaceVertices), "m.obj").faceCount, 1u);
    const size_t n = kMaxObjFaceVertices + 1;
    for (auto pass : {+[](const std::string& text) { preparedForTinyObj(text, "m.obj"); },
                      +[](const std::string& text) { countObjText(text, "m.obj"); }}) {
        try {
            pass(polygon(n));
            FAIL() << "a face of " << n << " vertices was accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(
                          absl::StrFormat("m.obj:%d: a face with %d vertices; at most %d", n + 1, n,
                                          kMaxObjFaceVertices)),
                      std::string::npos)
                << e.what();
        }
    }
}

// Each face within the vertex limit triangulates quickly, but a file of thousands of them took
// 0.04 s a face: the faces of more than 4 vertices may add up to kMaxObjTriangulationWork
// squared vertices, and the face beyond is refused by the pass before tinyobjloader.
TEST(WavefrontOBJ, FilesBeyondTheTriangulationWorkLimitAreRefused) {
    const size_t n = kMaxObjFaceVertices;
    std::string vertices, face = "f";
    for (size_t i = 0; i < n; ++i) {
        const double angle = 2.0 * M_PI * double(i) / double(n);
        vertices += absl::StrFormat("v %.6f %.6f 0\n", std::cos(angle), std::sin(angle));
        face += " " + std::to_string(i + 1);
    }
    face += "\n";
    const size_t allowed = kMaxObjTriangulationWork / (n * n);
    ASSERT_EQ(allowed * n * n, kMaxObjTriangulationWork);
    std::string text = vertices;
    for (size_t i = 0; i < allowed; ++i) text += face;
    // Triangles and quads cost no more for being many.
    for (int i = 0; i < 1000; ++i) text += "f 1 2 3 4\nf 1 2 3\n";
    EXPECT_EQ(preparedForTinyObj(text, "m.obj").faceCount, allowed + 2000);
    EXPECT_EQ(countObjText(text, "m.obj").faces, allowed + 2000);
    text += "f 1 2 3 4 5\n";
    const std::string expected = absl::StrFormat(
        "m.obj:%d: a face with 5 vertices takes the file beyond the triangulation work allowed: "
        "the squares of the vertex counts of its faces of more than 4 vertices add up to %u, more "
        "than %u (%d faces of %d vertices;",
        n + allowed + 2000 + 1, kMaxObjTriangulationWork + 25, kMaxObjTriangulationWork, allowed,
        n);
    for (auto pass : {+[](const std::string& text) { preparedForTinyObj(text, "m.obj"); },
                      +[](const std::string& text) { countObjText(text, "m.obj"); }}) {
        try {
            pass(text);
            FAIL() << "faces beyond the triangulation work limit were accepted";
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
    }
}

// A scene placing one OBJ file many times reads it once; each <mesh> gets the mesh it would have
// got alone, moved by its own toWorld.
TEST(WavefrontOBJ, AFileNamedByManyMeshesGivesEachTheMeshItWouldGetAlone) {
    const std::string sphere = meshFile("sphere.obj");
    auto element = [&](const std::string& translate) {
        return R"(<mesh type="obj"><string name="filename" value=")" + sphere +
               R"("/><transform name="toWorld"><scale value="0.3, 0.7, 1.1"/><translate value=")" +
               translate + R"("/></transform></mesh>)";
    };
    const std::string head = R"(<scene><integrator type="normals"/>
<camera type="perspective"><integer name="width" value="4"/><integer name="height" value="4"/></camera>)";
    const auto together = sceneFrom(head + element("1, 2, 3") + element("-4, 5, 6") +
                                    element("1, 2, 3") + "</scene>");
    const auto alone = sceneFrom(head + element("-4, 5, 6") + "</scene>");
    ASSERT_EQ(together->meshes().size(), 3u);
    const Mesh& second = *together->meshes()[1];
    const Mesh& single = *alone->meshes()[0];
    EXPECT_EQ(second.positions(), single.positions());
    EXPECT_EQ(second.normals(), single.normals());
    EXPECT_EQ(second.uvs(), single.uvs());
    EXPECT_EQ(second.faces(), single.faces());
    EXPECT_EQ(together->meshes()[0]->positions(), together->meshes()[2]->positions());
    EXPECT_NE(together->meshes()[0]->positions(), second.positions());
}

// The mesh of the OBJ file at `path`, built as the parser builds it with `context` (null: alone).
std::shared_ptr<Mesh> objMesh(const std::string& path,
                              std::shared_ptr<SceneLoadContext> context = nullptr) {
    PropertyList props("test (mesh type=\"obj\")");
    props.setString("filename", path);
    props.setLoadContext(std::move(context));
    return std::static_pointer_cast<Mesh>(ObjectFactory::create(ObjectKind::Mesh, "obj", props));
}

// A temporary OBJ file, removed at the end of the test.
struct TemporaryObjFile {
    explicit TemporaryObjFile(const std::string& name)
        : path((std::filesystem::temp_directory_path() /
                ("alphorn_mesh_test_" + std::to_string(::getpid()) + "_" + name + ".obj"))
                   .string()) {}
    ~TemporaryObjFile() { std::filesystem::remove(path); }
    void write(const std::string& text) const { std::ofstream(path, std::ios::binary) << text; }
    const std::string path;
};

const std::string kTriangleObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
// Another mesh, with the skin weight and \r\n lines that preparing the text changes.
const std::string kQuadObj =
    "v 0 0 0\r\nv 2 0 0\r\nvw 0 1e20 1\r\nv 2 2 0\r\nv 0 2 0\r\nf 1 2 3 4\r\n";

// The count reads and checks a file once; the first <mesh> naming it builds from that text, which
// the file, changed or removed since, does not alter: the mesh built is the mesh counted.
TEST(WavefrontOBJ, TheFirstMeshBuildsFromTheTextTheCountKept) {
    const TemporaryObjFile file("kept");
    file.write(kQuadObj);
    const auto alone = objMesh(file.path);
    auto context = std::make_shared<SceneLoadContext>();
    context->announceObjFile(file.path);
    context->announceObjFile(file.path);
    CountedObj counted = countedAndPreparedObjFile(file.path);
    const uint64_t bytes = counted.prepared.text.size();
    EXPECT_TRUE(context->keepObjText(file.path, std::move(counted.prepared)));
    EXPECT_EQ(context->keptObjTextBytes(), bytes);

    file.write(kTriangleObj);
    const auto first = objMesh(file.path, context);
    EXPECT_EQ(context->keptObjTextBytes(), 0u) << "the text goes with the first mesh";
    std::filesystem::remove(file.path);
    const auto second = objMesh(file.path, context);
    for (const auto& mesh : {first, second}) {
        EXPECT_EQ(mesh->positions(), alone->positions());
        EXPECT_EQ(mesh->faces(), alone->faces());
        EXPECT_EQ(mesh->triangleCount(), counted.counts.triangles);
        EXPECT_EQ(mesh->vertexCount(), counted.counts.vertices);
    }
}

// The texts kept take at most the context's maximum together (one larger than it is kept when
// it is the only one); a file whose text was not kept is read, checked and prepared when its
// mesh is built, as it was read alone.
TEST(WavefrontOBJ, TextsBeyondTheMaximumAreReadAgainWhenTheirMeshIsBuilt) {
    const TemporaryObjFile large("large"), small("small");
    large.write(kQuadObj);
    small.write(kTriangleObj);
    const uint64_t maximum = kTriangleObj.size() - 1;
    auto context = std::make_shared<SceneLoadContext>(maximum);
    context->announceObjFile(large.path);
    context->announceObjFile(small.path);
    EXPECT_TRUE(context->keepObjText(large.path, countedAndPreparedObjFile(large.path).prepared));
    EXPECT_FALSE(context->keepObjText(small.path, countedAndPreparedObjFile(small.path).prepared));
    EXPECT_FALSE(context->keepObjText("never/announced.obj", {"v 0 0 0\n", 0}));
    EXPECT_GT(context->keptObjTextBytes(), maximum);

    large.write(kTriangleObj);
    small.write(kQuadObj);
    EXPECT_EQ(objMesh(large.path, context)->triangleCount(), 2u) << "built from the kept quad";
    EXPECT_EQ(context->keptObjTextBytes(), 0u);
    EXPECT_EQ(objMesh(small.path, context)->triangleCount(), 2u) << "read again: now a quad";
    // Read again, the file is checked again.
    small.write("v 0 0 0\nv nan 0 0\n");
    context->announceObjFile(small.path);
    try {
        objMesh(small.path, context);
        FAIL() << "an unchecked file was built";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(":2: \"v nan 0 0\""), std::string::npos) << e.what();
    }
}

// The bytes this process has read from files so far (Linux's count of read() calls' bytes).
uint64_t bytesReadSoFar() {
    std::ifstream io("/proc/self/io");
    std::string key;
    uint64_t value = 0;
    while (io >> key >> value)
        if (key == "rchar:") return value;
    ADD_FAILURE() << "no rchar in /proc/self/io";
    return 0;
}

// A scene naming an OBJ file several times reads it once, for the count (the meshes are built
// from that text), and builds each <mesh> as it would be built alone.
TEST(WavefrontOBJ, AScenesFileIsReadOnceAndBuiltAsAlone) {
    const TemporaryObjFile quad("scene_quad");
    quad.write(kQuadObj);
    const std::string sphere = meshFile("sphere.obj");
    const std::string head = R"(<scene><integrator type="normals"/>
<camera type="perspective"><integer name="width" value="4"/><integer name="height" value="4"/></camera>)";
    auto element = [](const std::string& path) {
        return R"(<mesh type="obj"><string name="filename" value=")" + path + R"("/></mesh>)";
    };
    const uint64_t before = bytesReadSoFar();
    const auto scene = sceneFrom(head + element(sphere) + element(quad.path) + element(sphere) +
                                 element(quad.path) + "</scene>");
    const uint64_t read = bytesReadSoFar() - before;
    const uint64_t sphereBytes = std::filesystem::file_size(sphere);
    EXPECT_GE(read, sphereBytes);
    EXPECT_LT(read, sphereBytes * 3 / 2) << "sphere.obj was read more than once";
    ASSERT_EQ(scene->meshes().size(), 4u);
    const auto sphereAlone = objMesh(sphere), quadAlone = objMesh(quad.path);
    for (size_t i = 0; i < 4; ++i) {
        const Mesh& alone = i % 2 == 0 ? *sphereAlone : *quadAlone;
        EXPECT_EQ(scene->meshes()[i]->positions(), alone.positions()) << i;
        EXPECT_EQ(scene->meshes()[i]->normals(), alone.normals()) << i;
        EXPECT_EQ(scene->meshes()[i]->uvs(), alone.uvs()) << i;
        EXPECT_EQ(scene->meshes()[i]->faces(), alone.faces()) << i;
    }
}

// A scene whose meshes would take more memory than allowed is refused before any is built, at
// the mesh from which on they would, naming the whole scene's counts and the limit.
TEST(WavefrontOBJ, ScenesWhoseMeshesExceedTheMemoryLimitAreRefusedBeforeBuilding) {
    const std::filesystem::path path =
        std::filesystem::temp_directory_path() /
        ("alphorn_mesh_limit_" + std::to_string(::getpid()) + ".xml");
    std::string xml = R"(<scene><integrator type="normals"/>
<camera type="perspective"><integer name="width" value="4"/><integer name="height" value="4"/></camera>
)";
    for (int i = 0; i < 1000; ++i)
        xml += R"(<mesh type="obj"><string name="filename" value=")" + meshFile("sphere.obj") +
               "\"/></mesh>\n";
    xml += "</scene>\n";
    std::ofstream(path) << xml;
    const ObjCounts sphere = countObjFile(meshFile("sphere.obj"));
    SceneLimits limits;
    limits.maxGeometryBytes = sphere.memoryBytes() * 5 / 2;  // room for two spheres, not three
    limits.setting = "--max-memory";
    const auto start = std::chrono::steady_clock::now();
    try {
        loadScene(path.string(), {}, {}, limits);
        FAIL() << "1000 spheres were loaded within the memory of 2.5";
    } catch (const ResourceLimitError& e) {
        const std::string message = e.what();
        for (const std::string& expected :
             {path.string() + ":5:2 (mesh type=\"obj\")",
              absl::StrFormat("its 1000 meshes have %u triangles and %u vertices",
                              1000 * sphere.triangles, 1000 * sphere.vertices),
              absl::StrFormat("more than the limit of %s (--max-memory)",
                              formatBytes(limits.maxGeometryBytes)),
              absl::StrFormat("has %u triangles", sphere.triangles)})
            EXPECT_NE(message.find(expected), std::string::npos) << expected << " in " << message;
    }
    // Counted, not built: a 1000-sphere scene takes several seconds to build.
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 5.0);
    std::filesystem::remove(path);
}

}  // namespace
}  // namespace alphorn
