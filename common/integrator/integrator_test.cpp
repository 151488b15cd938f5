// Integrator tests on tiny scenes written to a temporary directory. Expected values come from
// closed forms (the diffuse furnace: 1/(1 - a) with global illumination, 1 + a direct only;
// inverse-square point lighting; the form factor of a square) or from agreement between
// independent strategies within 5 standard errors of their difference. Fixed seeds throughout.
#include "common/integrator/integrator.h"
#include "common/camera/camera.h"
#include "common/sampler/sampler.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

struct Estimate {
    double mean = 0.0, stderror = 0.0;
    bool finite = true;
};

class IntegratorTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_integrator_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::string write(const std::string& name, const std::string& text) {
        const std::filesystem::path path = m_dir / name;
        std::ofstream(path) << text;
        return path.string();
    }

    // A scene with the given body; its integrator is replaced per test with use().
    std::shared_ptr<Scene> load(const std::string& body, const std::string& camera) {
        const std::string text =
            "<scene>\n<integrator type=\"normals\"/>\n" + camera + "\n" + body + "\n</scene>\n";
        return loadScene(write("scene.xml", text));
    }

    static void use(Scene& scene, const std::string& type,
                    const PropertyList& props = PropertyList()) {
        auto integrator = std::static_pointer_cast<Integrator>(
            ObjectFactory::create(ObjectKind::Integrator, type, props));
        integrator->activate();
        scene.setIntegrator(integrator);
    }

    // Mean luminance over pixel positions drawn uniformly on the image (as the t-test does).
    static Estimate imageMean(const Scene& scene, int samples, uint64_t seed) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        const Camera& camera = *scene.camera();
        const Vector2i size = camera.outputSize();
        double sum = 0.0, sum2 = 0.0;
        Estimate e;
        for (int i = 0; i < samples; ++i) {
            sampler->startStream(seed, 0, static_cast<uint64_t>(i), StreamPurpose::Test);
            const Point2f pixel = sampler->next2D();
            Ray3f ray;
            const Color3f w = camera.sampleRay(
                ray, Point2f(pixel.x() * size.x(), pixel.y() * size.y()), sampler->next2D());
            const Color3f L = w * scene.integrator()->Li(scene, *sampler, ray, nullptr);
            if (!L.allFinite() || (L < 0.0f).any()) e.finite = false;
            const double y = L.luminance();
            sum += y;
            sum2 += y * y;
        }
        e.mean = sum / samples;
        e.stderror = std::sqrt(std::max(0.0, sum2 / samples - e.mean * e.mean) / (samples - 1));
        return e;
    }

    // Radiance along one ray, averaged over samples.
    static Estimate rayMean(const Scene& scene, const Ray3f& ray, int samples, uint64_t seed) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        double sum = 0.0, sum2 = 0.0;
        Estimate e;
        for (int i = 0; i < samples; ++i) {
            sampler->startStream(seed, 0, static_cast<uint64_t>(i), StreamPurpose::Test);
            const Color3f L = scene.integrator()->Li(scene, *sampler, ray, nullptr);
            if (!L.allFinite() || (L < 0.0f).any()) e.finite = false;
            sum += L.luminance();
            sum2 += double(L.luminance()) * L.luminance();
        }
        e.mean = sum / samples;
        e.stderror = std::sqrt(std::max(0.0, sum2 / samples - e.mean * e.mean) / (samples - 1));
        return e;
    }

    std::filesystem::path m_dir;
};

std::string camera(const std::string& origin, const std::string& target, float fov, int size = 16) {
    return "<camera type=\"perspective\"><float name=\"fov\" value=\"" + std::to_string(fov) +
           "\"/><integer name=\"width\" value=\"" + std::to_string(size) +
           "\"/><integer name=\"height\" value=\"" + std::to_string(size) +
           "\"/><transform name=\"toWorld\"><lookat origin=\"" + origin + "\" target=\"" + target +
           "\" up=\"0,1,0\"/></transform></camera>";
}

std::string furnace(float albedo) {
    const std::string a = std::to_string(albedo);
    return "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
           "cube_inward.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" value=\"" + a + "," +
           a + "," + a +
           "\"/></bsdf><emitter type=\"area\"><color name=\"radiance\" "
           "value=\"1,1,1\"/></emitter></mesh>";
}

std::string sphere(const std::string& bsdf, float radius, const std::string& at) {
    const std::string r = std::to_string(radius);
    return "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
           "sphere.obj\"/><transform name=\"toWorld\"><scale value=\"" + r + "," + r + "," + r +
           "\"/><translate value=\"" + at + "\"/></transform>" + bsdf + "</mesh>";
}

const char* kAll[] = {"direct_mats", "direct_ems", "direct_mis", "whitted",
                      "path_mats",   "path_ems",   "path_mis"};

bool isPath(const std::string& type) {
    return type.rfind("path_", 0) == 0;
}

// Camera inside a closed diffuse box of albedo a emitting radiance 1 everywhere: global
// illumination gives 1/(1 - a), direct illumination 1 + a. Whitted does one emitter sample at
// diffuse surfaces, so it is a direct-illumination method here. The camera sees only the middle
// of one wall: uniform area sampling of the adjacent wall from a point at distance c from an
// edge has a second moment ~ 1/c^2, so with edges in view the variance of direct_ems would be
// infinite and a 5-sigma test meaningless. (MIS bounds the weight by the albedo.)
TEST_F(IntegratorTest, DiffuseFurnace) {
    for (float albedo : {0.5f, 0.8f}) {
        auto scene = load(furnace(albedo), camera("0,0,0", "0,0,1", 30.0f));
        for (const std::string type : kAll) {
            use(*scene, type);
            const Estimate e = imageMean(*scene, 20000, 1);
            const double expected = isPath(type) ? 1.0 / (1.0 - albedo) : 1.0 + albedo;
            EXPECT_TRUE(e.finite) << type;
            EXPECT_NEAR(e.mean, expected, 5.0 * e.stderror + 1e-4) << type << " a=" << albedo;
            // Loose absolute bound so that a huge variance cannot hide a wrong mean.
            EXPECT_LT(e.stderror, 0.02 * expected) << type;
        }
    }
}

// Lossless specular objects in the furnace change nothing for global illumination: the mirror
// reflects radiance 2 and glass carries eta^2 * 2 inside, which refraction back out scales to 2
// again. (Whitted is not tested here: its shadow rays treat the spheres as occluders.)
TEST_F(IntegratorTest, FurnaceWithGlassAndMirrorSpheres) {
    const std::string body = furnace(0.5f) +
                             sphere("<bsdf type=\"dielectric\"/>", 0.3f, "0.3,0,0.6") +
                             sphere("<bsdf type=\"mirror\"/>", 0.3f, "-0.35,0.1,0.6");
    auto scene = load(body, camera("0,0,-0.5", "0,0,1", 60.0f));
    for (const std::string type : {"path_mats", "path_ems", "path_mis"}) {
        use(*scene, type);
        const Estimate e = imageMean(*scene, 20000, 2);
        const double expected = 2.0;
        EXPECT_TRUE(e.finite) << type;
        EXPECT_NEAR(e.mean, expected, 5.0 * e.stderror + 1e-4) << type;
    }
}

// A point light of power P at height h over a diffuse floor of albedo rho: the radiance is
// rho/pi * P/(4 pi) * cos / d^2. Only strategies that sample emitters can see a delta light.
TEST_F(IntegratorTest, PointLightOverDiffusePlane) {
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"10,1,10\"/></transform>"
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.6,0.6,0.6\"/></bsdf></mesh>"
        "<emitter type=\"point\"><point name=\"position\" value=\"0,2,0\"/>"
        "<color name=\"power\" value=\"50,50,50\"/></emitter>";
    auto scene = load(body, camera("0,3,3", "0,0,0", 30.0f));
    const Point3f x(0.3f, 0.0f, 0.2f);
    const Point3f eye(1.0f, 1.0f, 1.0f);
    const Ray3f ray(eye, (x - eye).normalized());
    const double d2 = 0.3 * 0.3 + 2.0 * 2.0 + 0.2 * 0.2;
    const double expected = 0.6 / M_PI * 50.0 / (4.0 * M_PI) * (2.0 / std::sqrt(d2)) / d2;
    for (const std::string type : kAll) {
        use(*scene, type);
        const Estimate e = rayMean(*scene, ray, 200, 3);
        EXPECT_TRUE(e.finite) << type;
        const bool seesDelta = type != "direct_mats" && type != "path_mats";
        EXPECT_NEAR(e.mean, seesDelta ? expected : 0.0, 1e-4 * expected) << type;
    }
    // Nori's "simple" integrator puts the same light on the integrator with a white BRDF:
    // energy / (4 pi^2) * cos / d^2.
    PropertyList simple;
    simple.setPoint("position", Point3f(0.0f, 2.0f, 0.0f));
    simple.setColor("energy", Color3f(50.0f));
    use(*scene, "simple", simple);
    EXPECT_NEAR(rayMean(*scene, ray, 1, 3).mean, expected / 0.6, 1e-4 * expected);
}

// Path tracing with NEE only and with MIS estimate the same global illumination: if MIS weights
// did not sum to one, or a light were counted twice, they would disagree. The scene has a small
// area light, a point light, a rough microfacet sphere, a glass sphere (caustics) and a mirror.
TEST_F(IntegratorTest, StrategiesAgree) {
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"3,1,3\"/></transform>"
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.7,0.5,0.3\"/></bsdf></mesh>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"0.4,1,0.4\"/>"
        "<rotate axis=\"1,0,0\" angle=\"180\"/><translate value=\"0,1.6,0\"/></transform>"
        "<emitter type=\"area\"><color name=\"radiance\" value=\"8,8,8\"/></emitter></mesh>" +
        sphere(
            "<bsdf type=\"microfacet\"><float name=\"alpha\" value=\"0.2\"/>"
            "<color name=\"kd\" value=\"0.2,0.3,0.1\"/></bsdf>",
            0.35f, "-0.5,0.35,0") +
        sphere("<bsdf type=\"dielectric\"/>", 0.3f, "0.5,0.5,0.2") +
        sphere("<bsdf type=\"mirror\"/>", 0.25f, "0,0.25,-0.8") +
        "<emitter type=\"point\"><point name=\"position\" value=\"1,1.2,1\"/>"
        "<color name=\"power\" value=\"2,2,2\"/></emitter>";
    auto scene = load(body, camera("0,2.5,3", "0,0.2,0", 45.0f));
    auto agree = [](const Estimate& a, const Estimate& b, const std::string& what) {
        EXPECT_TRUE(a.finite && b.finite) << what;
        EXPECT_NEAR(a.mean, b.mean, 5.0 * std::hypot(a.stderror, b.stderror)) << what;
        EXPECT_GT(a.mean, 0.0) << what;
    };
    // Only strategies that see delta lights and count light after delta bounces the same way
    // are comparable here (direct_ems cannot see the light in the mirror, direct_mis can).
    use(*scene, "direct_mis");
    const Estimate mis = imageMean(*scene, 100000, 5);
    use(*scene, "path_ems");
    const Estimate pems = imageMean(*scene, 100000, 6);
    use(*scene, "path_mis");
    const Estimate pmis = imageMean(*scene, 100000, 7);
    agree(pems, pmis, "path_ems vs path_mis");
    EXPECT_GT(pmis.mean, mis.mean);  // indirect light adds to direct light
}

// The same comparison including BSDF-only sampling (and Whitted, which equals direct_ems when
// nothing is specular), on a scene with area lights only and a glossy sphere where MIS matters.
// No delta BSDFs: emitter sampling cannot see a light in a mirror, BSDF sampling can.
TEST_F(IntegratorTest, MaterialSamplingAgreesOnAreaLights) {
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"3,1,3\"/></transform>"
        "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.7,0.5,0.3\"/></bsdf></mesh>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"0.8,1,0.8\"/>"
        "<rotate axis=\"1,0,0\" angle=\"180\"/><translate value=\"0,1.5,0\"/></transform>"
        "<emitter type=\"area\"><color name=\"radiance\" value=\"3,3,3\"/></emitter></mesh>" +
        sphere("<bsdf type=\"microfacet\"><float name=\"alpha\" value=\"0.3\"/></bsdf>", 0.35f,
               "-0.5,0.35,0") +
        sphere(
            "<bsdf type=\"microfacet\"><float name=\"alpha\" value=\"0.05\"/>"
            "<color name=\"kd\" value=\"0.1,0.1,0.1\"/></bsdf>",
            0.3f, "0.5,0.3,0.2");
    auto scene = load(body, camera("0,2.5,3", "0,0.2,0", 45.0f));
    std::vector<std::pair<std::string, Estimate>> direct, path;
    uint64_t seed = 10;
    for (const std::string type : kAll) {
        use(*scene, type);
        (isPath(type) ? path : direct).emplace_back(type, imageMean(*scene, 100000, seed++));
    }
    for (const auto& group : {direct, path}) {
        for (size_t i = 1; i < group.size(); ++i) {
            const Estimate &a = group[0].second, &b = group[i].second;
            EXPECT_TRUE(a.finite && b.finite);
            EXPECT_NEAR(a.mean, b.mean, 5.0 * std::hypot(a.stderror, b.stderror))
                << group[0].first << " vs " << group[i].first;
        }
    }
}

// The light faces away from everything the camera sees: under it is darkness for every
// integrator, and its back is black. A two-sided slip in eval(), pdf() or sample() shows here.
TEST_F(IntegratorTest, AreaLightsAreOneSided) {
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"3,1,3\"/></transform></mesh>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><scale value=\"0.5,1,0.5\"/>"
        "<translate value=\"0,1,0\"/></transform>"
        "<emitter type=\"area\"><color name=\"radiance\" value=\"5,5,5\"/></emitter></mesh>";
    auto scene = load(body, camera("0,0.6,3", "0,0.5,0", 60.0f));
    for (const std::string type : kAll) {
        use(*scene, type);
        const Estimate e = imageMean(*scene, 5000, 20);
        EXPECT_TRUE(e.finite) << type;
        EXPECT_EQ(e.mean, 0.0) << type;
    }
}

// Degenerate geometry: a zero-area triangle with a zero normal in both an emitter and a diffuse
// mesh, and a camera looking along the floor plane at grazing angles. Everything stays finite.
TEST_F(IntegratorTest, FiniteOnZeroAreaTrianglesAndGrazingAngles) {
    write("degenerate.obj",
          "v -1 0 -1\nv 1 0 -1\nv 1 0 1\nv 0.2 0 0.2\nv 0.2 0 0.2\nv 0.5 0 0.5\n"
          "vn 0 1 0\nvn 0 0 0\n"
          "f 1//1 3//1 2//1\nf 4//2 5//2 6//2\nf 1//1 4//2 4//2\n");
    const std::string degenerate = (m_dir / "degenerate.obj").string();
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + degenerate +
        "\"/><transform name=\"toWorld\"><scale value=\"3,1,3\"/></transform></mesh>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        degenerate +
        "\"/><transform name=\"toWorld\"><rotate axis=\"1,0,0\" angle=\"180\"/>"
        "<translate value=\"0,1,0\"/></transform>"
        "<emitter type=\"area\"><color name=\"radiance\" value=\"5,5,5\"/></emitter></mesh>" +
        sphere("<bsdf type=\"dielectric\"/>", 0.2f, "0,0.2,0");
    for (const std::string& cam :
         {camera("-3,0,0.1", "3,0,0.1", 60.0f), camera("0,0.5,3", "0,0.5,0", 80.0f)}) {
        auto scene = load(body, cam);
        for (const std::string type : kAll) {
            use(*scene, type);
            EXPECT_TRUE(imageMean(*scene, 3000, 30).finite) << type;
        }
        use(*scene, "ao");
        EXPECT_TRUE(imageMean(*scene, 3000, 31).finite);
    }
}

// Ambient occlusion at the centre of a 2x2 floor under a parallel 2x2 ceiling at height 1: the
// cosine-weighted fraction of directions that escape is 1 minus the form factor
// (4/pi)(1/sqrt 2) atan(1/sqrt 2) = 0.554124, so AO = 0.445876. With `length` 0.5 the ceiling is
// out of reach and AO = 1.
TEST_F(IntegratorTest, AmbientOcclusionMatchesFormFactor) {
    const std::string body =
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
        "quad.obj\"/></mesh>"
        "<mesh type=\"obj\"><string name=\"filename\" value=\"" +
        kMeshes +
        "quad.obj\"/><transform name=\"toWorld\"><rotate axis=\"1,0,0\" angle=\"180\"/>"
        "<translate value=\"0,1,0\"/></transform></mesh>";
    auto scene = load(body, camera("0,0.5,0.5", "0,0,0", 30.0f));
    const Ray3f down(Point3f(0.0f, 0.5f, 0.0f), Vector3f(0.0f, -1.0f, 0.0f));
    use(*scene, "ao");
    const Estimate e = rayMean(*scene, down, 40000, 40);
    const double expected = 1.0 - 4.0 / M_PI / std::sqrt(2.0) * std::atan(1.0 / std::sqrt(2.0));
    EXPECT_NEAR(e.mean, expected, 5.0 * e.stderror);
    PropertyList shortRange;
    shortRange.setFloat("length", 0.5f);
    use(*scene, "ao", shortRange);
    EXPECT_EQ(rayMean(*scene, down, 1000, 41).mean, 1.0);
}

TEST_F(IntegratorTest, RejectsBadParameters) {
    PropertyList negative;
    negative.setInteger("maxDepth", -2);
    EXPECT_THROW(ObjectFactory::create(ObjectKind::Integrator, "path_mis", negative), Error);
    PropertyList length;
    length.setFloat("length", 0.0f);
    EXPECT_THROW(ObjectFactory::create(ObjectKind::Integrator, "ao", length), Error);
}

}  // namespace
}  // namespace alphorn
