// Integrators under lights at infinity, against closed forms. A convex diffuse object of albedo a
// under a constant environment L reflects exactly a L (every direction it reflects into escapes),
// whatever the strategy; a diffuse plane under a directional light of irradiance E at angle theta
// has radiance a / pi E cos theta; a camera ray that escapes sees the map's pixel; in an
// absorbing medium it sees the environment times the transmittance up to the box media end at
// (media_traversal.h). Strategies that must agree (BSDF sampling, light sampling, MIS; phase
// sampling against next-event estimation in fog) are compared within 5 standard errors of their
// difference. Fixed seeds throughout.
#include "common/core/image.h"
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

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

struct Estimate {
    double mean = 0.0, stderror = 0.0;
};

class InfiniteLightsTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_infinite_lights_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::shared_ptr<Scene> load(const std::string& integrator, const std::string& body) {
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << "<scene>\n" + integrator + "\n" + body + "\n</scene>\n";
        return loadScene(path.string());
    }

    static void use(Scene& scene, const std::string& type,
                    const PropertyList& props = PropertyList()) {
        auto integrator = std::static_pointer_cast<Integrator>(
            ObjectFactory::create(ObjectKind::Integrator, type, props));
        integrator->activate();
        scene.setIntegrator(integrator);
    }

    // Mean luminance over the image; samples of one pass share `pass` (a photon map).
    static Estimate imageMean(const Scene& scene, int samples, uint64_t seed,
                              const PassData* pass = nullptr) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        const Camera& camera = *scene.camera();
        const Vector2i size = camera.outputSize();
        double sum = 0.0, sum2 = 0.0;
        for (int i = 0; i < samples; ++i) {
            sampler->startStream(seed, 0, static_cast<uint64_t>(i), StreamPurpose::Test);
            const Point2f pixel = sampler->next2D();
            Ray3f ray;
            const Color3f w = camera.sampleRay(
                ray, Point2f(pixel.x() * size.x(), pixel.y() * size.y()), sampler->next2D());
            const Color3f L = w * scene.integrator()->Li(scene, *sampler, ray, pass);
            EXPECT_TRUE(L.allFinite() && !(L < 0.0f).any()) << L.toString();
            const double y = L.luminance();
            sum += y;
            sum2 += y * y;
        }
        Estimate e;
        e.mean = sum / samples;
        e.stderror = std::sqrt(std::max(0.0, sum2 / samples - e.mean * e.mean) / (samples - 1));
        return e;
    }

    // A progressive photon mapper's image mean: one estimate per pass (each traces its own
    // photons), then the mean and standard error over passes, which are independent.
    static Estimate photonImageMean(const Scene& scene, int passes, int samples) {
        double sum = 0.0, sum2 = 0.0;
        for (int p = 0; p < passes; ++p) {
            const auto data = scene.integrator()->preparePass(scene, 5, uint64_t(p));
            const double m = imageMean(scene, samples, 100 + p, data.get()).mean;
            sum += m;
            sum2 += m * m;
        }
        Estimate e;
        e.mean = sum / passes;
        e.stderror = std::sqrt(std::max(0.0, sum2 / passes - e.mean * e.mean) / (passes - 1));
        return e;
    }

    // The green channel's mean and standard error along one ray.
    static Estimate rayEstimate(const Scene& scene, const Ray3f& ray, int samples) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        double sum = 0.0, sum2 = 0.0;
        for (int i = 0; i < samples; ++i) {
            sampler->startStream(9, 0, static_cast<uint64_t>(i), StreamPurpose::Test);
            const double g = scene.integrator()->Li(scene, *sampler, ray, nullptr).g();
            sum += g;
            sum2 += g * g;
        }
        Estimate e;
        e.mean = sum / samples;
        e.stderror = std::sqrt(std::max(0.0, sum2 / samples - e.mean * e.mean) / (samples - 1));
        return e;
    }

    static Color3f rayMean(const Scene& scene, const Ray3f& ray, int samples) {
        std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
        Color3f sum(0.0f);
        for (int i = 0; i < samples; ++i) {
            sampler->startStream(3, 0, static_cast<uint64_t>(i), StreamPurpose::Test);
            sum += scene.integrator()->Li(scene, *sampler, ray, nullptr);
        }
        return sum / float(samples);
    }

    std::filesystem::path m_dir;
};

std::string camera(const std::string& origin, const std::string& target, float fov,
                   const std::string& medium = "", const std::string& up = "0,1,0") {
    return "<camera type=\"perspective\"><float name=\"fov\" value=\"" + std::to_string(fov) +
           "\"/><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/>"
           "<transform name=\"toWorld\"><lookat origin=\"" +
           origin + "\" target=\"" + target + "\" up=\"" + up + "\"/></transform>" + medium +
           "</camera>";
}

// The cube [-1, 1]^3, diffuse of albedo `albedo`, seen from +z: the camera sees only the middle
// of the face z = 1.
std::string cubeScene(float albedo, const std::string& light, const std::string& medium = "") {
    const std::string a = std::to_string(albedo);
    return camera("0,0,4", "0,0,0", 20.0f, medium) +
           "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
           "cube.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" value=\"" + a +
           "\"/></bsdf></mesh>" + light;
}

const char* kNormals = "<integrator type=\"normals\"/>";

const char* kSurfaceIntegrators[] = {"path_mats",   "path_ems",         "path_mis",
                                     "direct_mats", "direct_ems",       "direct_mis",
                                     "whitted",     "volume_path_mats", "volume_path_mis"};

TEST_F(InfiniteLightsTest, ConstantEnvironmentFurnace) {
    auto scene = load(kNormals, cubeScene(0.8f,
                                          "<emitter type=\"environment\"><color "
                                          "name=\"radiance\" value=\"2\"/></emitter>"));
    for (const char* type : kSurfaceIntegrators) {
        use(*scene, type);
        const Estimate e = imageMean(*scene, 20000, 1);
        EXPECT_NEAR(e.mean, 0.8 * 2.0, 5.0 * e.stderror + 1e-5) << type;
    }
    // Photon mappers: photons from the disk the bounding sphere casts; the camera sees the face
    // at least 0.4 from its edges, far more than the radius, where the estimate is unbiased.
    for (const char* type : {"photonmapper", "volumetric_photonmapper"}) {
        PropertyList props;
        props.setString("directLight", "photons");
        props.setInteger(std::string(type) == "photonmapper" ? "photonCount" : "surfacePhotonCount",
                         20000);
        props.setFloat("surfacePhotonRadius", 0.1f);
        props.setBoolean("progressive", true);
        use(*scene, type, props);
        const Estimate e = photonImageMean(*scene, 12, 1000);
        EXPECT_NEAR(e.mean, 1.6, 5.0 * e.stderror) << type;
        EXPECT_LT(e.stderror, 0.03) << type;
    }
    // Next-event estimation at the photon mapper's first diffuse hit, no direct photons.
    PropertyList props;
    props.setInteger("photonCount", 20000);
    props.setFloat("surfacePhotonRadius", 0.1f);
    props.setBoolean("progressive", true);
    use(*scene, "photonmapper", props);
    const Estimate e = photonImageMean(*scene, 6, 2000);
    EXPECT_NEAR(e.mean, 1.6, 5.0 * e.stderror) << "photonmapper, nee";
}

// A plane of albedo a under a directional light at 60 degrees from its normal: a / pi E cos 60.
TEST_F(InfiniteLightsTest, DirectionalLightOnAPlane) {
    const std::string light =
        "<emitter type=\"directional\"><color name=\"irradiance\" value=\"3\"/><vector "
        "name=\"direction\" value=\"0.8660254, -0.5, 0\"/></emitter>";
    auto scene =
        load(kNormals, camera("0,3,0", "0,0,0", 20.0f, "", "0,0,1") +
                           "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
                           "quad.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" "
                           "value=\"0.6\"/></bsdf></mesh>" +
                           light);
    const double expected = 0.6 / M_PI * 3.0 * 0.5;
    for (const char* type : kSurfaceIntegrators) {
        use(*scene, type);
        const Estimate e = imageMean(*scene, 4000, 2);
        // A delta light: next-event estimation finds it exactly; BSDF sampling never does.
        const bool blind = std::string(type) == "path_mats" || std::string(type) == "direct_mats" ||
                           std::string(type) == "volume_path_mats";
        EXPECT_NEAR(e.mean, blind ? 0.0 : expected, 1e-5) << type;
    }
    PropertyList props;
    props.setString("directLight", "photons");
    props.setInteger("photonCount", 20000);
    props.setFloat("surfacePhotonRadius", 0.1f);
    props.setBoolean("progressive", true);
    use(*scene, "photonmapper", props);
    const Estimate e = photonImageMean(*scene, 12, 1000);
    EXPECT_NEAR(e.mean, expected, 5.0 * e.stderror) << "photonmapper";
    EXPECT_LT(e.stderror, 0.02 * expected);
}

// On an image map with a sun, BSDF sampling, light sampling and their MIS agree on the cube, and
// a camera ray that misses the cube sees its direction's pixel.
TEST_F(InfiniteLightsTest, ImageEnvironmentStrategiesAgreeAndRaysSeeThePixels) {
    Image map(8, 8);
    for (int y = 0; y < 8; ++y)
        for (int x = 0; x < 8; ++x) map.set(x, y, Color3f(0.1f * x, 0.05f * y + 0.1f, 0.3f));
    map.set(4, 1, Color3f(40.0f, 30.0f, 20.0f));
    writeEXR((m_dir / "sky.exr").string(), map);
    const std::string light =
        "<emitter type=\"environment\"><string name=\"filename\" value=\"sky.exr\"/><string "
        "name=\"mapping\" value=\"octahedral\"/></emitter>";
    // Seen from the side, the cube shows two faces lit by different parts of the sky.
    auto scene =
        load(kNormals, camera("3,0.5,3", "0,0,0", 25.0f) +
                           "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
                           "cube.obj\"/><bsdf type=\"diffuse\"><color name=\"albedo\" "
                           "value=\"0.7\"/></bsdf></mesh>" +
                           light);
    use(*scene, "path_mis");
    const Estimate reference = imageMean(*scene, 40000, 3);
    for (const char* type : {"path_mats", "path_ems", "volume_path_mis", "volume_path_mats"}) {
        use(*scene, type);
        const Estimate e = imageMean(*scene, 40000, 4);
        EXPECT_NEAR(e.mean, reference.mean, 5.0 * std::hypot(e.stderror, reference.stderror))
            << type;
    }
    for (const char* type : {"direct_mats", "direct_ems"}) {
        use(*scene, "direct_mis");
        const Estimate mis = imageMean(*scene, 40000, 5);
        use(*scene, type);
        const Estimate e = imageMean(*scene, 40000, 6);
        EXPECT_NEAR(e.mean, mis.mean, 5.0 * std::hypot(e.stderror, mis.stderror)) << type;
    }
    // +z (away from the cube, seen from its front) is the map's centre pixel (4, 4); +x its
    // right edge's middle (7, 4).
    for (const char* type : {"path_mis", "path_ems", "direct_ems", "whitted", "volume_path_mis"}) {
        use(*scene, type);
        const Color3f up = rayMean(*scene, Ray3f(Point3f(0, 0, 2), Vector3f(0, 0, 1)), 4);
        EXPECT_TRUE(up.isApprox(map.get(4, 4))) << type << ": " << up.toString();
        const Color3f side = rayMean(*scene, Ray3f(Point3f(2, 0, 0), Vector3f(1, 0, 0)), 4);
        EXPECT_TRUE(side.isApprox(map.get(7, 4))) << type << ": " << side.toString();
    }
}

// In a purely absorbing medium around the camera, an escaping ray sees the environment times
// exp(-sigma_a d), d its length up to the box media end at: the meshes' box and the camera, 1%
// larger (plus 1e-4). Phase sampling, next-event estimation and volume photons agree in
// scattering fog.
TEST_F(InfiniteLightsTest, EnvironmentThroughMedia) {
    const std::string light =
        "<emitter type=\"environment\"><color name=\"radiance\" value=\"1.5\"/></emitter>";
    auto absorbing = load(
        kNormals, cubeScene(0.5f, light,
                            "<medium type=\"homogeneous\"><color name=\"sigmaA\" value=\"0.7\"/>"
                            "<color name=\"sigmaS\" value=\"0\"/></medium>"));
    // The box: x in [-1, 1] grown by 0.02 + 1e-4; from (0, 0, 4) along -x it ends at 1.0201.
    const double expected = 1.5 * std::exp(-0.7 * 1.0201);
    for (const char* type : {"volume_path_mats", "volume_path_mis"}) {
        use(*absorbing, type);
        // Free-flight sampling in an absorbing medium ends the path with the probability of
        // absorption: an unbiased, not a deterministic, estimate.
        const Estimate seen =
            rayEstimate(*absorbing, Ray3f(Point3f(0, 0, 4), Vector3f(-1, 0, 0)), 20000);
        EXPECT_NEAR(seen.mean, expected, 5.0 * seen.stderror) << type;
        EXPECT_LT(seen.stderror, 0.01);
    }
    auto fog = load(kNormals,
                    cubeScene(0.5f, light,
                              "<medium type=\"homogeneous\"><color name=\"sigmaA\" value=\"0.1\"/>"
                              "<color name=\"sigmaS\" value=\"0.4\"/></medium>"));
    use(*fog, "volume_path_mis");
    const Estimate mis = imageMean(*fog, 40000, 7);
    use(*fog, "volume_path_mats");
    const Estimate mats = imageMean(*fog, 40000, 8);
    EXPECT_NEAR(mis.mean, mats.mean, 5.0 * std::hypot(mis.stderror, mats.stderror));
    EXPECT_GT(mis.mean, 0.1);
    // Photons from the environment must reach all of the fog, the camera's end of it too (the
    // disk they start on spans the box media end at, not only the meshes).
    PropertyList props;
    props.setInteger("photonCount", 50000);
    props.setFloat("volumePhotonRadius", 0.15f);
    props.setBoolean("progressive", true);
    use(*fog, "volumetric_photonmapper", props);
    const Estimate photons = photonImageMean(*fog, 24, 1000);
    EXPECT_NEAR(photons.mean, mis.mean, 5.0 * std::hypot(photons.stderror, mis.stderror));
    EXPECT_LT(photons.stderror, 0.05 * mis.mean);
}

// The map is among the files a scene names (what the farm client uploads with it), and a
// missing one is refused there, naming the element.
TEST_F(InfiniteLightsTest, TheMapIsListedWithTheScenesFiles) {
    writePFM((m_dir / "sky.pfm").string(), Image(2, 2));
    const std::string body = camera("0,0,4", "0,0,0", 20.0f) +
                             "\n<emitter type=\"environment\"><string name=\"filename\" "
                             "value=\"sky.pfm\"/></emitter>";
    const std::filesystem::path path = m_dir / "scene.xml";
    std::ofstream(path) << "<scene>\n" + std::string(kNormals) + "\n" + body + "\n</scene>\n";
    const std::vector<std::string> files = listSceneFiles(path.string());
    EXPECT_NE(std::find(files.begin(), files.end(), (m_dir / "sky.pfm").string()), files.end());
    std::filesystem::remove(m_dir / "sky.pfm");
    try {
        listSceneFiles(path.string());
        ADD_FAILURE() << "a missing map was listed";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("scene.xml:4"), std::string::npos) << message;
        EXPECT_NE(message.find("the environment map"), std::string::npos) << message;
    }
}

// An environment nested in a mesh is refused where it is written.
TEST_F(InfiniteLightsTest, EnvironmentInAMeshIsRefused) {
    try {
        load(kNormals, camera("0,0,4", "0,0,0", 20.0f) +
                           "<mesh type=\"obj\"><string name=\"filename\" value=\"" + kMeshes +
                           "cube.obj\"/>\n<emitter type=\"environment\"/></mesh>");
        ADD_FAILURE() << "accepted";
    } catch (const Error& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("scene.xml:4:2 (emitter type=\"environment\")"), std::string::npos)
            << message;
        EXPECT_NE(message.find("cannot be nested in a <mesh>"), std::string::npos) << message;
    }
}

// Bidirectional integrators refuse lights at infinity, naming themselves and the light.
TEST_F(InfiniteLightsTest, UnsupportedIntegratorsRefuseClearly) {
    for (const char* light :
         {"<emitter type=\"environment\"/>", "<emitter type=\"directional\"/>"}) {
        for (const char* type : {"bdpt", "vcm"}) {
            try {
                load(std::string("<integrator type=\"") + type + "\"/>", cubeScene(0.5f, light));
                ADD_FAILURE() << type << " accepted " << light;
            } catch (const Error& e) {
                const std::string message = e.what();
                EXPECT_NE(message.find(std::string(type) + " does not support lights at infinity"),
                          std::string::npos)
                    << message;
            }
        }
    }
}

}  // namespace
}  // namespace alphorn
