// Object instancing: an instance hits and renders as its triangles placed flat, every placement
// is found by the rays through it, a group's BVH is built once however many instances place it,
// and what instancing cannot take is refused.
#include "common/scene/instance.h"

#include "common/core/error.h"
#include "common/core/rng.h"
#include "common/render/local_render.h"
#include "common/scene/media_traversal.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

std::string writeFile(const std::string& name, const std::string& text) {
    const std::string path = (std::filesystem::path(::testing::TempDir()) / name).string();
    std::ofstream(path) << text;
    return path;
}

template <typename T>
std::shared_ptr<T> make(
    ObjectKind kind, const std::string& type, const PropertyList& props,
    const std::vector<std::pair<std::shared_ptr<Object>, std::string>>& children = {}) {
    auto object = ObjectFactory::create(kind, type, props);
    for (const auto& [child, name] : children) object->addChild(child, name);
    object->activate();
    return std::static_pointer_cast<T>(object);
}

// An OBJ file as the scene's own meshes load it: in world space by `toWorld`, or in object
// space (no transform) for a group.
std::shared_ptr<Mesh> loadMesh(
    const std::string& path, const Transform& toWorld = Transform(),
    const std::vector<std::pair<std::shared_ptr<Object>, std::string>>& children = {}) {
    PropertyList props("test.xml:1 (mesh type=\"obj\")");
    props.setString("filename", path);
    if (!toWorld.isIdentity()) props.setTransform("toWorld", toWorld);
    return make<Mesh>(ObjectKind::Mesh, "obj", props, children);
}

Transform translation(const Vector3f& t) {
    return Transform(Eigen::Affine3f(Eigen::Translation3f(t)).matrix());
}

using Placement = std::pair<std::shared_ptr<MeshGroup>, Transform>;

// A scene of `meshes` (world space) and `placements`, seen by a camera at `eye` looking along -z
// (its transform exact in float), lit by a point light, path traced.
std::shared_ptr<Scene> makeScene(const std::vector<std::shared_ptr<Mesh>>& meshes,
                                 const std::vector<Placement>& placements,
                                 const Point3f& eye = Point3f(2.5f, 1.0f, -2.0f),
                                 const std::string& integrator = "path_mis") {
    auto scene = std::static_pointer_cast<Scene>(
        ObjectFactory::create(ObjectKind::Scene, "scene", PropertyList("test.xml:1 (scene)")));
    PropertyList camera("test.xml:2 (camera)");
    Matrix4f toWorld = Matrix4f::Identity();
    toWorld(0, 0) = -1.0f;
    toWorld(2, 2) = -1.0f;
    toWorld.topRightCorner<3, 1>() = eye;
    camera.setTransform("toWorld", Transform(toWorld));
    camera.setFloat("fov", 60.0f);
    camera.setInteger("width", 24);
    camera.setInteger("height", 18);
    scene->addChild(make<Object>(ObjectKind::Camera, "perspective", camera), "");
    PropertyList sampler("test.xml:3 (sampler)");
    sampler.setInteger("sampleCount", 4);
    scene->addChild(make<Object>(ObjectKind::Sampler, "independent", sampler), "");
    scene->addChild(
        make<Object>(ObjectKind::Integrator, integrator, PropertyList("test.xml:4 (integrator)")),
        "");
    PropertyList light("test.xml:5 (emitter)");
    light.setPoint("position", Point3f(2.5f, 2.0f, -4.0f));
    light.setColor("power", Color3f(30.0f));
    scene->addChild(make<Object>(ObjectKind::Emitter, "point", light), "");
    for (const auto& mesh : meshes) scene->addChild(mesh, "");
    for (const auto& [group, transform] : placements) scene->addInstance(group, transform);
    scene->activate();
    return scene;
}

std::shared_ptr<MeshGroup> groupOf(const std::string& name,
                                   const std::vector<std::shared_ptr<Mesh>>& meshes) {
    auto group = std::make_shared<MeshGroup>(name);
    for (const auto& mesh : meshes) group->addMesh(mesh);
    return group;
}

// A floor (y = 0, facing up) over x in [1.25, 3.75], z in [-7.75, -2.25].
const char* kFloor = R"(v 1.25 0 -2.25
v 3.75 0 -2.25
v 3.75 0 -7.75
v 1.25 0 -7.75
vn 0 1 0
f 1//1 2//1 3//1
f 1//1 3//1 4//1
)";

// An octahedron of radius 0.375 about (1.5, 0.375, -3), with smooth (unnormalised) normals: every
// coordinate dyadic, so that placing it by a translation of small dyadic amounts is exact.
const char* kOctahedron = R"(v 1.875 0.375 -3
v 1.125 0.375 -3
v 1.5 0.75 -3
v 1.5 0 -3
v 1.5 0.375 -2.625
v 1.5 0.375 -3.375
vn 3 0.5 0.25
vn -3 0.5 0.25
vn 0.25 2 -0.5
vn 0.25 -2 0.5
vn 0.5 0.25 1
vn -0.5 0.25 -1
f 1//1 3//3 5//5
f 3//3 2//2 5//5
f 2//2 4//4 5//5
f 4//4 1//1 5//5
f 3//3 1//1 6//6
f 2//2 3//3 6//6
f 4//4 2//2 6//6
f 1//1 4//4 6//6
)";

bool sameFilm(const FilmBlock& a, const FilmBlock& b) {
    if (a.width() != b.width() || a.height() != b.height()) return false;
    for (int y = 0; y < a.height(); ++y)
        for (int x = 0; x < a.width(); ++x) {
            const PixelSum &p = a.at(x, y), &q = b.at(x, y);
            if (p.weight != q.weight || p.rgb[0] != q.rgb[0] || p.rgb[1] != q.rgb[1] ||
                p.rgb[2] != q.rgb[2])
                return false;
        }
    return true;
}

// The same triangles placed by an identity instance and by a translation of (2, 0, -4), against
// the same meshes loaded flat with those transforms: every ray origin of the scene (the camera,
// the floor, the octahedra, x in [1, 4] and z in [-8, -2]) moves into object space exactly, so
// Embree computes the same distances and barycentrics and the images are the same bytes.
TEST(Instancing, IdentityAndDyadicTranslationRenderTheBytesOfTheFlatCopy) {
    const std::string floor = writeFile("instancing_floor.obj", kFloor);
    const std::string octahedron = writeFile("instancing_octahedron.obj", kOctahedron);
    const Transform moved = translation(Vector3f(2.0f, 0.0f, -4.0f));

    const auto flat =
        makeScene({loadMesh(floor), loadMesh(octahedron), loadMesh(octahedron, moved)}, {});
    const auto group = groupOf("octahedron", {loadMesh(octahedron)});
    const auto instanced = makeScene({loadMesh(floor)}, {{group, Transform()}, {group, moved}});
    ASSERT_EQ(instanced->meshes().size(), 1u);
    ASSERT_EQ(instanced->instances().size(), 2u);

    RenderSettings settings;
    settings.seed = 7;
    settings.passes = 4;
    const FilmBlock a = renderLocal(*flat, settings), b = renderLocal(*instanced, settings);
    EXPECT_TRUE(sameFilm(a, b));

    // Built and rendered on one thread: the same bytes (the group's BVH is a pure function of
    // its triangles, like the scene's).
    {
        tbb::global_control oneThread(tbb::global_control::max_allowed_parallelism, 1);
        const auto again = makeScene({loadMesh(floor)}, {{group, Transform()}, {group, moved}});
        EXPECT_TRUE(sameFilm(b, renderLocal(*again, settings)));
    }

    // Not a film of nothing: the octahedra cover pixels the floor alone would light otherwise.
    const auto floorOnly = makeScene({loadMesh(floor)}, {});
    EXPECT_FALSE(sameFilm(a, renderLocal(*floorOnly, settings)));
}

Transform rotatedAndScaled() {
    Eigen::Affine3f m = Eigen::Affine3f::Identity();
    m.translate(Vector3f(0.3f, -0.2f, 1.1f));
    m.rotate(Eigen::AngleAxisf(0.7f, Vector3f(1.0f, 2.0f, 3.0f).normalized()));
    m.scale(Vector3f(1.5f, 0.75f, 2.0f));
    return Transform(m.matrix());
}

// A rotated and (non-uniformly) scaled instance of the 18k-triangle sphere against the sphere
// loaded flat with the same transform: for many random rays, the same hits (triangle, distance,
// point, shading and true normals, within float rounding) and misses.
TEST(Instancing, RotatedScaledInstanceHitsAsTheFlatCopy) {
    const std::string sphere = sourcePath("scenes/meshes/sphere.obj");
    const Transform toWorld = rotatedAndScaled();
    const auto flat = makeScene({loadMesh(sphere, toWorld)}, {});
    const auto group = groupOf("sphere", {loadMesh(sphere)});
    const auto instanced = makeScene({}, {{group, toWorld}});
    const Mesh* groupMesh = group->meshes()[0].get();
    const Point3f centre = toWorld.applyPoint(Point3f::Zero());

    Rng rng(11, 0, 0, StreamPurpose::Test);
    int hits = 0, misses = 0, otherTriangle = 0, disagree = 0;
    for (int i = 0; i < 4000; ++i) {
        const Vector3f from =
            Vector3f(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * 2.0f - Vector3f::Ones();
        const Vector3f to =
            Vector3f(rng.nextFloat(), rng.nextFloat(), rng.nextFloat()) * 2.0f - Vector3f::Ones();
        const Point3f origin = centre + 8.0f * from.normalized();
        const Ray3f ray(origin, (centre + 2.2f * to - origin).normalized());
        Intersection a, b;
        const bool hitA = flat->rayIntersect(ray, a), hitB = instanced->rayIntersect(ray, b);
        if (hitA != hitB) {
            ++disagree;  // a ray grazing the silhouette, within rounding of an edge
            continue;
        }
        EXPECT_EQ(instanced->rayOccluded(ray), hitB);
        if (!hitA) {
            ++misses;
            continue;
        }
        ++hits;
        EXPECT_EQ(b.mesh, groupMesh);
        EXPECT_EQ(b.instance, &instanced->instances()[0]);
        EXPECT_EQ(a.instance, nullptr);
        otherTriangle += a.triangle != b.triangle;
        EXPECT_NEAR(a.t, b.t, 2e-5f * a.t);
        EXPECT_LT((a.p - b.p).norm(), 2e-5f * 8.0f);
        EXPECT_GT(a.shFrame.n.dot(b.shFrame.n), 1.0f - 1e-5f);
        EXPECT_GT(a.geometricNormal().dot(b.geometricNormal()), 1.0f - 1e-5f);
        EXPECT_NEAR(b.geometricNormal().norm(), 1.0f, 1e-6f);
        EXPECT_NEAR(b.shFrame.s.dot(b.shFrame.n), 0.0f, 1e-5f);
        EXPECT_LT((a.uv - b.uv).norm(), 1e-4f);
    }
    EXPECT_GT(hits, 1000);
    EXPECT_GT(misses, 1000);
    EXPECT_LE(disagree, 4);
    EXPECT_LE(otherTriangle, 4);
}

// 100 placements of one cube, each rotated and scaled its own way on a grid: a ray down through
// each cube's centre hits that instance on its top; rays between them hit nothing, and occluded()
// agrees with intersect() on random segments. The group's BVH is built once.
TEST(Instancing, ManyInstancesEachRayHitsItsOwn) {
    const auto group = groupOf("cube", {loadMesh(sourcePath("scenes/meshes/cube.obj"))});
    std::vector<Placement> placements;
    std::vector<float> halfHeights;
    for (int i = 0; i < 100; ++i) {
        Eigen::Affine3f m = Eigen::Affine3f::Identity();
        m.translate(Vector3f(4.0f * float(i % 10), 0.0f, -4.0f * float(i / 10)));
        m.rotate(Eigen::AngleAxisf(0.1f * float(i), Vector3f::UnitY()));
        const float height = 0.5f + 0.01f * float(i);
        m.scale(Vector3f(0.8f, height, 1.2f - 0.005f * float(i)));
        placements.emplace_back(group, Transform(m.matrix()));
        halfHeights.push_back(height);
    }
    const uint64_t built = embreeScenesBuilt();
    const auto scene = makeScene({}, placements);
    EXPECT_EQ(embreeScenesBuilt() - built, 2u) << "the scene's BVH and the group's, once";
    ASSERT_EQ(scene->instances().size(), 100u);

    for (int i = 0; i < 100; ++i) {
        const Point3f centre(4.0f * float(i % 10), 0.0f, -4.0f * float(i / 10));
        const Ray3f down(centre + Vector3f(0.1f, 10.0f, 0.1f), Vector3f(0.0f, -1.0f, 0.0f));
        Intersection its;
        ASSERT_TRUE(scene->rayIntersect(down, its)) << i;
        EXPECT_EQ(its.instance, &scene->instances()[i]) << i;
        EXPECT_NEAR(its.p.y(), halfHeights[i], 1e-5f) << i;
        EXPECT_NEAR(its.t, 10.0f - halfHeights[i], 1e-5f) << i;
        EXPECT_GT(its.geometricNormal().y(), 0.9999f) << i;
        EXPECT_TRUE(scene->rayOccluded(down)) << i;
        const Ray3f between(centre + Vector3f(2.0f, 10.0f, -2.0f), Vector3f(0.0f, -1.0f, 0.0f));
        EXPECT_FALSE(scene->rayIntersect(between, its)) << i;
        EXPECT_FALSE(scene->rayOccluded(between)) << i;
    }

    Rng rng(3, 0, 0, StreamPurpose::Test);
    int blocked = 0;
    for (int i = 0; i < 2000; ++i) {
        const Point3f a(40.0f * rng.nextFloat() - 2.0f, 3.0f * rng.nextFloat() - 1.5f,
                        -40.0f * rng.nextFloat() + 2.0f);
        const Point3f b(40.0f * rng.nextFloat() - 2.0f, 3.0f * rng.nextFloat() - 1.5f,
                        -40.0f * rng.nextFloat() + 2.0f);
        const float length = (b - a).norm();
        const Ray3f segment(a, (b - a) / length, 0.0f, length);
        Intersection its;
        const bool hit = scene->rayIntersect(segment, its);
        EXPECT_EQ(scene->rayOccluded(segment), hit) << i;
        blocked += hit;
    }
    EXPECT_GT(blocked, 200);
    EXPECT_LT(blocked, 1800);
}

// The bounds of a scene loaded to be checked (no Embree) are those of the rendered one, and take
// in every instance's world box.
TEST(Instancing, BoundsWithoutEmbreeAreThoseOfTheBuild) {
    const std::string floor = writeFile("instancing_bounds_floor.obj", kFloor);
    const auto group = groupOf("cube", {loadMesh(sourcePath("scenes/meshes/cube.obj"))});
    std::vector<Instance> instances;
    instances.emplace_back(group, translation(Vector3f(100.0f, 0.0f, 0.0f)));
    instances.emplace_back(group, rotatedAndScaled());
    const std::vector<std::shared_ptr<Mesh>> meshes = {loadMesh(floor)};
    Accel built, bounded;
    built.build(meshes, instances);
    bounded.boundMeshes(meshes, instances);
    EXPECT_EQ(built.bounds().min(), bounded.bounds().min());
    EXPECT_EQ(built.bounds().max(), bounded.bounds().max());
    EXPECT_EQ(built.bounds().max().x(), 101.0f);  // the translated cube's far side
    EXPECT_TRUE(built.bounds().contains(instances[1].worldBounds()));
    EXPECT_EQ(built.bounds().min().z(), -7.75f);  // the floor
}

std::string errorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const Error& e) {
        return e.what();
    }
    return "";
}

// pbrt-v4 does not instance area lights either: a mesh with one is refused, naming the mesh's
// source and the group.
TEST(Instancing, AGroupRefusesAnAreaLight) {
    PropertyList area("test.xml:9 (emitter)");
    area.setColor("radiance", Color3f(1.0f));
    const auto light = make<Object>(ObjectKind::Emitter, "area", area);
    const auto mesh = loadMesh(sourcePath("scenes/meshes/quad.obj"), Transform(), {{light, ""}});
    MeshGroup group("lamp");
    const std::string message = errorOf([&] { group.addMesh(mesh); });
    EXPECT_NE(message.find("test.xml:1 (mesh type=\"obj\")"), std::string::npos) << message;
    EXPECT_NE(message.find("object \"lamp\""), std::string::npos) << message;
    EXPECT_NE(message.find("area light"), std::string::npos) << message;
    EXPECT_TRUE(group.meshes().empty());
}

// Transforms Embree cannot place, placements beyond the traceable range, meshes added to a placed
// group and instances added to a built scene are refused with the group's name.
TEST(Instancing, RefusesWhatCannotBePlaced) {
    const auto group = groupOf("cube", {loadMesh(sourcePath("scenes/meshes/cube.obj"))});
    Matrix4f projective = Matrix4f::Identity();
    projective(3, 2) = 0.5f;
    Matrix4f singular = Matrix4f::Identity();
    singular(1, 1) = 0.0f;
    Matrix4f notFinite = Matrix4f::Identity();
    notFinite(0, 3) = std::numeric_limits<float>::quiet_NaN();
    for (const auto& [matrix, problem] : std::vector<std::pair<Matrix4f, std::string>>{
             {projective, "projective"}, {singular, "singular"}, {notFinite, "not finite"}}) {
        const std::string message = errorOf([&] { Instance(group, Transform(matrix)); });
        EXPECT_NE(message.find(problem), std::string::npos) << message;
        EXPECT_NE(message.find("object \"cube\""), std::string::npos) << message;
    }
    const std::string far =
        errorOf([&] { Instance(group, translation(Vector3f(0.0f, 2e15f, 0.0f))); });
    EXPECT_NE(far.find("where rays cannot be traced"), std::string::npos) << far;
    EXPECT_EQ(errorOf([&] { Instance(group, translation(Vector3f(0.0f, 9e14f, 0.0f))); }), "");

    const auto scene = makeScene({}, {{group, Transform()}});
    const std::string late =
        errorOf([&] { group->addMesh(loadMesh(sourcePath("scenes/meshes/quad.obj"))); });
    EXPECT_NE(late.find("already placed"), std::string::npos) << late;
    const std::string afterBuild = errorOf([&] { scene->addInstance(group, Transform()); });
    EXPECT_NE(afterBuild.find("after the scene was built"), std::string::npos) << afterBuild;
}

// Media boundaries and null surfaces are supported in instances: the checks that look for them
// in the scene find them in placed groups too (Scene::findMesh), and a hit on the instanced
// boundary leads into its inside medium from world-space normals.
TEST(Instancing, MediaAndNullSurfacesInGroupsAreSeen) {
    const std::string cube = sourcePath("scenes/meshes/cube.obj");
    PropertyList fog("test.xml:7 (medium)");
    fog.setColor("sigmaA", Color3f(0.5f));
    fog.setColor("sigmaS", Color3f(0.5f));
    const auto medium = make<Object>(ObjectKind::Medium, "homogeneous", fog);
    const auto null = make<Object>(ObjectKind::BSDF, "null", PropertyList("test.xml:8 (bsdf)"));
    const auto group =
        groupOf("fog box", {loadMesh(cube, Transform(), {{null, ""}, {medium, "inside"}})});
    // Scaled by -1 along x (a mirror) and moved: the inside is still the inside.
    Matrix4f mirror = Matrix4f::Identity();
    mirror(0, 0) = -2.0f;
    mirror(1, 1) = 2.0f;
    mirror(2, 2) = 2.0f;
    mirror(2, 3) = -10.0f;
    const auto scene =
        makeScene({}, {{group, Transform(mirror)}}, Point3f(0.0f, 0.0f, 0.0f), "volume_path_mis");
    EXPECT_TRUE(needsVolumetricPaths(*scene));
    const Mesh* boundary = scene->findMesh([](const Mesh& m) { return m.hasMediumInterface(); });
    EXPECT_EQ(boundary, group->meshes()[0].get());
    EXPECT_NE(mediumAt(*scene, Point3f(0.5f, 0.5f, -10.5f)), nullptr);
    EXPECT_EQ(mediumAt(*scene, Point3f(0.5f, 0.5f, -5.0f)), nullptr);

    const std::string refusal = errorOf([&] {
        makeScene({}, {{group, Transform()}}, Point3f(0, 0, 5), "vcm");
    });
    EXPECT_NE(refusal.find("bounds a medium"), std::string::npos) << refusal;
}

}  // namespace
}  // namespace alphorn
