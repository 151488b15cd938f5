// bdpt and vcm (vcm_path.h): every strategy family converges where it applies, checked by
// t-tests of independent passes against closed forms or against path_mis and the progressive
// photon mapper; a render is the same bytes for any thread count and tile size; scenes the
// integrators cannot render are refused with the file and line.
//
// Every statistic here goes through renderUnit(), because light tracing reaches the image only
// through the pass's light image (Integrator::addPassSplats), never through Li(). A pass is one
// independent estimate (its light paths are shared by all its pixels), so the tests compare
// means of passes. The cameras use a box filter: each pixel then holds exactly its one camera
// sample plus the light splats, an unbiased estimate of the pixel's mean radiance.
#include "common/core/rng.h"
#include "common/core/system_memory.h"
#include "common/render/local_render.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace alphorn {
namespace {

const std::string kSourceDir = sourceDirectory();
const std::string kMeshes = kSourceDir + "/scenes/meshes/";
constexpr double kSignificance = 0.01;

double luminance(const Color3f& c) {
    return 0.212671 * double(c.r()) + 0.715160 * double(c.g()) + 0.072169 * double(c.b());
}

std::string replaceAll(std::string text, const std::string& from, const std::string& to) {
    for (size_t at = text.find(from); at != std::string::npos; at = text.find(from, at + to.size()))
        text.replace(at, from.size(), to);
    return text;
}

// The Cornell box of scenes/cbox/cbox.xml at `size` pixels with a box filter and `integrator`
// (an XML element), optionally without its spheres and with `extra` elements added.
std::string cornellBox(const std::string& integrator, int size, bool spheres = true,
                       const std::string& extra = "") {
    std::ifstream file(kSourceDir + "/scenes/cbox/cbox.xml");
    std::stringstream text;
    text << file.rdbuf();
    std::string scene = replaceAll(text.str(), "../meshes/", kMeshes);
    scene = replaceAll(scene, "<integrator type=\"path_mis\"/>", integrator);
    scene = replaceAll(scene, "value=\"512\"", "value=\"" + std::to_string(size) + "\"");
    scene = replaceAll(scene, "<float name=\"fov\" value=\"38\"/>",
                       "<float name=\"fov\" value=\"38\"/><rfilter type=\"box\"/>");
    if (!spheres) scene = scene.substr(0, scene.find("<!-- mirror sphere")) + "</scene>\n";
    return replaceAll(scene, "</scene>", extra + "</scene>");
}

class VcmTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = std::filesystem::temp_directory_path() /
                ("alphorn_vcm_test_" + std::to_string(::getpid()));
        std::filesystem::create_directories(m_dir);
    }
    void TearDown() override { std::filesystem::remove_all(m_dir); }

    std::shared_ptr<Scene> loadText(const std::string& text) {
        const std::filesystem::path path = m_dir / "scene.xml";
        std::ofstream(path) << text;
        return loadScene(path.string());
    }

    void expectError(const std::string& text, const std::string& fragment) {
        try {
            loadText(text);
            ADD_FAILURE() << "no error; expected one naming " << fragment;
        } catch (const Error& e) {
            const std::string message = e.what();
            EXPECT_NE(message.find("scene.xml:"), std::string::npos) << message;
            EXPECT_NE(message.find(fragment), std::string::npos) << message;
        }
    }

    std::filesystem::path m_dir;
};

// The statistical tests: seconds in the release tree, minutes under the sanitizers, whose run
// (tools/run-tests.sh) leaves them out; the other tests of this file run the same code there.
class VcmConvergence : public VcmTest {};

// The mean luminance over the image of each of `passes` passes, each rendered alone as one unit
// over the whole image.
stats::RunningStats passMeans(const Scene& scene, uint64_t seed, uint32_t passes) {
    const Vector2i size = scene.camera()->outputSize();
    stats::RunningStats means;
    for (uint32_t pass = 0; pass < passes; ++pass) {
        const RenderUnit unit{pass, pass + 1, Tile{0, 0, size.x(), size.y()}};
        FilmBlock block = makeUnitBlock(scene, unit.tile);
        const auto data = preparePasses(scene, seed, pass, pass + 1);
        EXPECT_TRUE(renderUnit(scene, seed, unit, data, block));
        EXPECT_EQ(block.invalidSamples, 0u);
        const Image image = resolveImage(block, size.x(), size.y());
        double sum = 0.0;
        for (int y = 0; y < size.y(); ++y)
            for (int x = 0; x < size.x(); ++x) sum += luminance(image.get(x, y));
        means.add(sum / (double(size.x()) * size.y()));
    }
    return means;
}

::testing::AssertionResult agreesWith(const stats::RunningStats& means, double reference) {
    const stats::TTestResult result =
        stats::studentTTest(means.mean, means.variance(), reference, means.count, kSignificance);
    if (result.passed) return ::testing::AssertionSuccess() << result.message;
    return ::testing::AssertionFailure() << result.message;
}

// Welch's two-sample t-test of equal means.
::testing::AssertionResult agree(const stats::RunningStats& a, const stats::RunningStats& b) {
    const double va = a.variance() / double(a.count), vb = b.variance() / double(b.count);
    const double t = (a.mean - b.mean) / std::sqrt(va + vb);
    const double dof =
        (va + vb) * (va + vb) / (va * va / double(a.count - 1) + vb * vb / double(b.count - 1));
    const double p = stats::studentTTwoSidedPValue(t, dof);
    std::ostringstream message;
    message << "means " << a.mean << " +- " << std::sqrt(va) << " and " << b.mean << " +- "
            << std::sqrt(vb) << ": t = " << t << ", p = " << p;
    if (std::isfinite(p) && p > kSignificance)
        return ::testing::AssertionSuccess() << message.str();
    return ::testing::AssertionFailure() << message.str();
}

// A closed box of albedo 0.5 emitting radiance 1, seen from its centre: radiance 1/(1 - a) = 2
// everywhere, which any unbiased mix of strategies must reproduce.
std::string furnace(const std::string& integrator) {
    return "<scene>" + integrator +
           R"(<camera type="perspective"><transform name="toWorld"><lookat origin="0,0,0"
           target="1,0,0" up="0,1,0"/></transform><float name="fov" value="30"/>
           <integer name="width" value="8"/><integer name="height" value="8"/>
           <rfilter type="box"/></camera><mesh type="obj"><string name="filename" value=")" +
           kMeshes + R"(cube_inward.obj"/><bsdf type="diffuse"><color name="albedo"
           value="0.5"/></bsdf><emitter type="area"><color name="radiance" value="1"/></emitter>
           </mesh></scene>)";
}

TEST_F(VcmConvergence, DiffuseFurnace) {
    for (const char* integrator :
         {R"(<integrator type="bdpt"/>)", R"(<integrator type="vcm"/>)",
          R"(<integrator type="vcm"><boolean name="connections" value="false"/></integrator>)"}) {
        auto scene = loadText(furnace(integrator));
        const stats::RunningStats means = passMeans(*scene, 5, 200);
        EXPECT_TRUE(agreesWith(means, 2.0)) << integrator;
    }
}

// A point light of intensity 1 at height 1 over a diffuse floor of albedo 0.5, seen from above
// by light tracing alone: each pixel's mean radiance is (0.5 / pi) cos / r^2 averaged over the
// floor it sees, computed here by midpoint quadrature over the image through the camera's own
// rays (independent of any integrator).
TEST_F(VcmConvergence, LightTracingReproducesADirectlyLitPlane) {
    const std::string camera = R"(<camera type="perspective"><transform name="toWorld">
        <lookat origin="0.3,3,0.2" target="0,0,0" up="0,0,1"/></transform>
        <float name="fov" value="50"/><integer name="width" value="16"/>
        <integer name="height" value="12"/><rfilter type="box"/></camera>)";
    const std::string floor = R"(<mesh type="obj"><string name="filename" value=")" + kMeshes +
                              R"(quad.obj"/><transform name="toWorld"><scale value="20,1,20"/>
        </transform><bsdf type="diffuse"><color name="albedo" value="0.5"/></bsdf></mesh>
        <emitter type="point"><point name="position" value="0,1,0"/>
        <color name="power" value="12.566370614359172"/></emitter>)";
    auto scene = loadText(R"(<scene><integrator type="bdpt"><boolean name="lightTracingOnly"
        value="true"/><integer name="lightPathCount" value="20000"/></integrator>)" +
                          camera + floor + "</scene>");
    const Camera& cam = *scene->camera();
    const Vector2i size = cam.outputSize();
    double reference = 0.0;
    const int n = 600;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            Ray3f ray;
            cam.sampleRay(ray, Point2f((i + 0.5f) * size.x() / n, (j + 0.5f) * size.y() / n),
                          Point2f(0.5f, 0.5f));
            const double t = -double(ray.o.y()) / double(ray.d.y());
            const double x = ray.o.x() + t * ray.d.x(), z = ray.o.z() + t * ray.d.z();
            const double r2 = x * x + z * z + 1.0;
            reference += 0.5 / M_PI / (r2 * std::sqrt(r2)) / (double(n) * n);
        }
    const stats::RunningStats means = passMeans(*scene, 9, 100);
    EXPECT_TRUE(agreesWith(means, reference));
    EXPECT_LT(means.standardError(), 0.01 * reference) << "a test too weak to tell";

    // All strategies together (next-event estimation and light tracing by MIS) as well.
    auto all = loadText("<scene><integrator type=\"bdpt\"/>" + camera + floor + "</scene>");
    EXPECT_TRUE(agreesWith(passMeans(*all, 9, 100), reference));
}

// The Cornell box with its mirror and glass spheres, without them but with a spotlight, a
// projector and a point light added, and with diffuse spheres, against path_mis: two estimators of
// the same image. (With the mirror and glass spheres, path_mis cannot see the caustics of the
// point-like lights: no strategy of a path tracer joins a delta light through glass.)
TEST_F(VcmConvergence, BdptAgreesWithPathMisOnCornellBoxes) {
    const std::string deltaLights =
        R"(<emitter type="point"><point name="position" value="0.5,1.5,0.4"/>
           <color name="power" value="2,2,2"/></emitter>
           <emitter type="spotlight"><color name="power" value="3,3,3"/>
           <transform name="toWorld"><lookat origin="-0.6,1.8,0.5" target="-0.4,0,-0.3"
           up="0,1,0"/></transform></emitter>
           <emitter type="projector"><color name="power" value="2,1,1"/>
           <float name="fov" value="40"/>
           <transform name="toWorld"><lookat origin="0.7,1.7,0.8" target="-0.2,0.3,-0.8"
           up="0,1,0"/></transform>
           <texture type="checkerboard2d"/></emitter>)";
    // The spheres' meshes have interpolated normals, where light paths take the shading-normal
    // correction. On this finely tessellated sphere the correction is too small for this test to
    // see (it passes without it too); the case checks that light paths over smooth meshes agree.
    auto diffuseSpheres = [](std::string scene) {
        scene = replaceAll(scene, "<bsdf type=\"mirror\"/>",
                           "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.8\"/></bsdf>");
        return replaceAll(scene, "<bsdf type=\"dielectric\"/>",
                          "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.6\"/></bsdf>");
    };
    struct Case {
        const char* name;
        std::string bdpt, pathMis;
    };
    const Case cases[] = {
        {"area light, mirror and glass spheres", cornellBox("<integrator type=\"bdpt\"/>", 16),
         cornellBox("<integrator type=\"path_mis\"/>", 16)},
        {"delta lights", cornellBox("<integrator type=\"bdpt\"/>", 16, false, deltaLights),
         cornellBox("<integrator type=\"path_mis\"/>", 16, false, deltaLights)},
        {"diffuse smooth spheres", diffuseSpheres(cornellBox("<integrator type=\"bdpt\"/>", 16)),
         diffuseSpheres(cornellBox("<integrator type=\"path_mis\"/>", 16))},
        // maxDepth cuts every strategy at the same path length as path_mis.
        {"maxDepth 2",
         cornellBox(R"(<integrator type="bdpt"><integer name="maxDepth" value="2"/>
             </integrator>)",
                    16, false),
         cornellBox(R"(<integrator type="path_mis"><integer name="maxDepth" value="2"/>
             </integrator>)",
                    16, false)}};
    // More bdpt passes than path_mis ones: the image mean is what the t-test compares, and
    // the lamp seen directly varies more in it by camera hits than it did by light tracing
    // (which, per pixel, was much the noisier; see vcm_mis.cpp).
    for (const Case& c : cases) {
        auto bdpt = loadText(c.bdpt);
        const stats::RunningStats a = passMeans(*bdpt, 3, 1000);
        auto pathMis = loadText(c.pathMis);
        const stats::RunningStats b = passMeans(*pathMis, 4, 600);
        EXPECT_TRUE(agree(a, b)) << c.name;
        EXPECT_LT(a.standardError(), 0.01 * a.mean) << "a test too weak to tell";
    }
}

// Without caustics, where path_mis converges quickly, vcm converges to the same image, also with
// the paths cut at the same maxDepth.
TEST_F(VcmConvergence, VcmAgreesWithPathMisWithoutCaustics) {
    for (const std::string depth : {"", "<integer name=\"maxDepth\" value=\"1\"/>"}) {
        auto vcm =
            loadText(cornellBox("<integrator type=\"vcm\">" + depth + "</integrator>", 16, false));
        const stats::RunningStats a = passMeans(*vcm, 3, 300);
        auto pathMis = loadText(
            cornellBox("<integrator type=\"path_mis\">" + depth + "</integrator>", 16, false));
        const stats::RunningStats b = passMeans(*pathMis, 4, 600);
        EXPECT_TRUE(agree(a, b)) << depth;
    }
}

// Specular-diffuse-specular: the camera sees the floor under a point light only in a mirror
// overhead, and the floor there is lit directly and through the same mirror. The mirrored light
// (light, mirror, floor, mirror, camera) is reachable by merging alone: no connection can join a
// point light or the camera through a mirror. vcm must agree with the progressive photon mapper
// (the same radius schedule), which gathers that light from photons.
TEST_F(VcmConvergence, VcmAgreesWithThePhotonMapperWhereOnlyMergingReaches) {
    const std::string scene = R"(
        <camera type="perspective"><transform name="toWorld">
        <lookat origin="0,1.2,0.4" target="0,2,0.2857" up="0,1,0"/></transform>
        <float name="fov" value="3"/><integer name="width" value="4"/>
        <integer name="height" value="4"/><rfilter type="box"/></camera>
        <mesh type="obj"><string name="filename" value=")" +
                              kMeshes + R"(quad.obj"/>
        <transform name="toWorld"><scale value="20,1,20"/></transform>
        <bsdf type="diffuse"><color name="albedo" value="0.5"/></bsdf></mesh>
        <mesh type="obj"><string name="filename" value=")" +
                              kMeshes + R"(quad.obj"/>
        <transform name="toWorld"><scale value="0.5,1,0.5"/><rotate axis="1,0,0" angle="180"/>
        <translate value="0,2,0"/></transform><bsdf type="mirror"/></mesh>
        <emitter type="point"><point name="position" value="0,1,0"/>
        <color name="power" value="12.566370614359172"/></emitter></scene>)";
    auto vcm = loadText(R"(<scene><integrator type="vcm"><integer name="lightPathCount"
        value="20000"/><float name="radius" value="0.08"/><float name="alpha" value="0.75"/>
        </integrator>)" +
                        scene);
    const stats::RunningStats a = passMeans(*vcm, 3, 150);
    auto ppm = loadText(R"(<scene><integrator type="photonmapper"><integer name="photonCount"
        value="20000"/><float name="surfacePhotonRadius" value="0.08"/>
        <float name="alpha" value="0.75"/><boolean name="progressive" value="true"/>
        </integrator>)" +
                        scene);
    const stats::RunningStats b = passMeans(*ppm, 4, 150);
    EXPECT_TRUE(agree(a, b));
    // The mirrored light is a tenth of the total (1/9 against 1): bdpt, which cannot reach it,
    // must be told apart from both.
    auto bdpt = loadText(R"(<scene><integrator type="bdpt"/>)" + scene);
    const stats::RunningStats c = passMeans(*bdpt, 5, 150);
    EXPECT_FALSE(agree(a, c)) << "the test cannot see the merged light";
    EXPECT_LT(c.mean, 0.95 * a.mean);
}

// A point light between two large diffuse planes, seen from above: with connections off, every
// path is estimated by merging alone (a point light is never hit), at whichever of its vertices
// the weights choose, so the weights among merges at different vertices decide the sum. The
// irradiance varies slowly on the scale of the merge radius (a relative blur below 10^-3 at the
// first radius, less as it shrinks), and the image must agree with path_mis. With connections
// on, the same radius makes merging a large share of the indirect light.
TEST_F(VcmConvergence, MergesAtEveryVertexAgreeWithPathMisBetweenTwoPlanes) {
    const std::string scene = R"(
        <camera type="perspective"><transform name="toWorld">
        <lookat origin="0.3,1.8,0.2" target="0,0,0" up="0,1,0"/></transform>
        <float name="fov" value="20"/><integer name="width" value="8"/>
        <integer name="height" value="8"/><rfilter type="box"/></camera>
        <mesh type="obj"><string name="filename" value=")" +
                              kMeshes + R"(quad.obj"/>
        <transform name="toWorld"><scale value="20,1,20"/></transform>
        <bsdf type="diffuse"><color name="albedo" value="0.7"/></bsdf></mesh>
        <mesh type="obj"><string name="filename" value=")" +
                              kMeshes + R"(quad.obj"/>
        <transform name="toWorld"><scale value="20,1,20"/><rotate axis="1,0,0" angle="180"/>
        <translate value="0,2,0"/></transform>
        <bsdf type="diffuse"><color name="albedo" value="0.6"/></bsdf></mesh>
        <emitter type="point"><point name="position" value="0,1,0"/>
        <color name="power" value="12.566370614359172"/></emitter></scene>)";
    auto pathMis = loadText("<scene><integrator type=\"path_mis\"/>" + scene);
    const stats::RunningStats reference = passMeans(*pathMis, 4, 400);
    for (const char* connections : {"false", "true"}) {
        auto vcm = loadText(R"(<scene><integrator type="vcm"><integer name="lightPathCount"
            value="4000"/><float name="radius" value="0.05"/><boolean name="connections"
            value=")" + std::string(connections) +
                            "\"/></integrator>" + scene);
        const stats::RunningStats means = passMeans(*vcm, 3, 200);
        EXPECT_TRUE(agree(means, reference)) << "connections " << connections;
        EXPECT_LT(means.standardError(), 0.01 * means.mean) << "a test too weak to tell";
    }
}

// --threads 1 and 2 and two tile sizes give the same film bytes, with the default gaussian
// filter whose splats cross tile borders.
TEST_F(VcmTest, SameBytesForAnyThreadsAndTiles) {
    for (const char* integrator : {"<integrator type=\"bdpt\"/>", "<integrator type=\"vcm\"/>"}) {
        std::string text = cornellBox(integrator, 24);
        text = replaceAll(text, "<rfilter type=\"box\"/>", "");
        auto scene = loadText(text);
        auto render = [&](int threads, int tile) {
            tbb::global_control control(tbb::global_control::max_allowed_parallelism, threads);
            RenderSettings settings;
            settings.seed = 17;
            settings.passes = 3;
            settings.tileSize = tile;
            return renderLocal(*scene, settings).serialize();
        };
        const std::string reference = render(1, 64);
        EXPECT_EQ(render(2, 64), reference) << integrator;
        EXPECT_EQ(render(2, 5), reference) << integrator;
        EXPECT_EQ(render(1, 7), reference) << integrator;
    }
}

TEST_F(VcmTest, RefusesWhatItCannotRender) {
    const std::string body = R"(<camera type="perspective"><integer name="width" value="4"/>
        <integer name="height" value="4"/>
        <medium type="homogeneous"><color name="sigmaS" value="0.1"/></medium></camera>
        <emitter type="point"><color name="power" value="1"/></emitter></scene>)";
    expectError("<scene><integrator type=\"vcm\"/>" + body, "volume_path_mis");
    expectError("<scene><integrator type=\"bdpt\"/>" + body, "volumetric_photonmapper");
    const std::string lens = R"(<camera type="physical"><integer name="width" value="4"/>
        <integer name="height" value="4"/><float name="apertureRadius" value="0.1"/></camera>
        <emitter type="point"><color name="power" value="1"/></emitter></scene>)";
    expectError("<scene><integrator type=\"bdpt\"/>" + lens, "apertureRadius");
    const std::string plain = R"(<camera type="perspective"><integer name="width" value="4"/>
        <integer name="height" value="4"/></camera>
        <emitter type="point"><color name="power" value="1"/></emitter></scene>)";
    // Without light tracing (merging only), a lens is fine.
    EXPECT_NO_THROW(loadText(R"(<scene><integrator type="vcm"><boolean name="connections"
        value="false"/></integrator>)" +
                             lens));
    for (const char* params :
         {R"(<integer name="lightPathCount" value="0"/>)", R"(<float name="radius" value="-1"/>)",
          R"(<float name="alpha" value="1"/>)", R"(<integer name="maxDepth" value="-2"/>)",
          R"(<boolean name="connections" value="false"/><boolean name="merging" value="false"/>)",
          // At least one 152-byte vertex per path: 304 GiB, where it ended in std::bad_alloc.
          R"(<integer name="lightPathCount" value="2147483647"/>)"})
        expectError(
            std::string("<scene><integrator type=\"vcm\">") + params + "</integrator>" + plain,
            "scene.xml:1:");
}

// Light path counts beyond memory, given or by default the pixel count (16384 x 16384 here, at
// least 45 GiB), are beyond a limit, not malformed: the farm answers them RESOURCE_EXHAUSTED. The
// message names the integrator's element once.
TEST_F(VcmTest, LightPathCountsBeyondMemoryAreResourceLimits) {
    const std::string plain = R"(<camera type="perspective"><integer name="width" value="4"/>
        <integer name="height" value="4"/></camera>
        <emitter type="point"><color name="power" value="1"/></emitter></scene>)";
    EXPECT_THROW(loadText(R"(<scene><integrator type="vcm"><integer name="lightPathCount"
        value="2147483647"/></integrator>)" +
                          plain),
                 ResourceLimitError);
    if (physicalMemoryBytes() >= uint64_t(16384) * 16384 * 168) return;  // it would fit
    try {
        loadText(R"(<scene><integrator type="bdpt"/><camera type="perspective">
            <integer name="width" value="16384"/><integer name="height" value="16384"/></camera>
            <emitter type="point"><color name="power" value="1"/></emitter></scene>)");
        ADD_FAILURE() << "16384 x 16384 light paths were accepted";
    } catch (const ResourceLimitError& e) {
        const std::string message = e.what();
        EXPECT_NE(message.find("scene.xml:1:"), std::string::npos) << message;
        EXPECT_EQ(message.find("scene.xml:1:"), message.rfind("scene.xml:1:")) << message;
        EXPECT_NE(message.find("the default \"lightPathCount\""), std::string::npos) << message;
    }
}

// The t-test's scene mode samples Li() alone, which never sees light tracing: a file testing
// bdpt that way is refused, not answered with a biased mean.
TEST_F(VcmTest, TheRayTTestRefusesLightTracing) {
    const std::filesystem::path path = m_dir / "test.xml";
    std::ofstream(path) << R"(<test type="ttest"><string name="references" value="1"/>
        <scene><integrator type="bdpt"/><camera type="perspective"><integer name="width"
        value="4"/><integer name="height" value="4"/></camera>
        <emitter type="point"><color name="power" value="1"/></emitter></scene></test>)";
    try {
        parseSceneFile(path.string());
        ADD_FAILURE() << "no error";
    } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("splats light paths"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace alphorn
