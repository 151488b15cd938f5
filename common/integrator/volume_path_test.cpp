// The volumetric path tracers at the level of whole paths: a medium that does not interact
// renders exactly like vacuum (same bits, because it draws no random numbers), and a chromatic
// medium equals, channel by channel, the grey media of each channel's coefficients (an
// independent second method for the hero-channel / spectral-MIS weighting). Closed-form checks of
// whole images are in tests/statistical/volume_*_ttest.xml.
#include "common/integrator/integrator.h"
#include "common/integrator/volume.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

#include <absl/strings/str_format.h>
#include <gtest/gtest.h>

namespace alphorn {
namespace {

const std::string kMeshes = sourcePath("scenes/meshes/");

// A small scene: an area light over a floor, a sphere of medium (null boundary) in between,
// the camera in `cameraMedium`.
std::string sceneXml(const std::string& integrator, const std::string& cameraMedium,
                     const std::string& sphereMedia) {
    return absl::StrFormat(R"(<scene>
  <integrator type="%s"/>
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="0, 1, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="40"/><integer name="width" value="16"/><integer name="height" value="16"/>
    %s
  </camera>
  <mesh type="obj">
    <string name="filename" value="%squad.obj"/>
    <transform name="toWorld"><scale value="3, 1, 3"/></transform>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="%squad.obj"/>
    <transform name="toWorld"><scale value="1.5, 1, 1.5"/><rotate axis="1, 0, 0" angle="180"/><translate value="0, 2.5, 0"/></transform>
    <emitter type="area"><color name="radiance" value="1, 1, 1"/></emitter>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="%ssphere.obj"/>
    <transform name="toWorld"><scale value="0.7, 0.7, 0.7"/><translate value="0, 0.8, 0"/></transform>
    <bsdf type="null"/>
    %s
  </mesh>
</scene>)",
                           integrator, cameraMedium, kMeshes, kMeshes, kMeshes, sphereMedia);
}

std::shared_ptr<Scene> load(const std::string& name, const std::string& xml) {
    return loadScene(plugin_testing::writeTempFile(name, xml));
}

// Li for `count` fixed streams at uniformly random image positions.
std::vector<Color3f> sampleScene(const Scene& scene, int count) {
    std::unique_ptr<Sampler> sampler = scene.sampler()->clone();
    const Vector2f size = scene.camera()->outputSize().cast<float>();
    std::vector<Color3f> values;
    for (int k = 0; k < count; ++k) {
        sampler->startStream(99, 0, static_cast<uint64_t>(k), StreamPurpose::Test);
        const Point2f position = sampler->next2D().cwiseProduct(size);
        const Point2f aperture = sampler->next2D();
        Ray3f ray;
        Color3f value = scene.camera()->sampleRay(ray, position, aperture);
        value *= scene.integrator()->Li(scene, *sampler, ray, nullptr);
        values.push_back(value);
    }
    return values;
}

TEST(VolumePath, ZeroDensityRendersExactlyLikeVacuum) {
    for (const char* integrator : {"volume_path_mats", "volume_path_mis"}) {
        auto vacuum = load("vacuum.xml", sceneXml(integrator, "", ""));
        auto zero = load(
            "zero.xml",
            sceneXml(integrator,
                     R"(<medium type="homogeneous"><color name="sigmaS" value="0"/></medium>)",
                     R"(<medium type="heterogeneous" name="inside"><float name="density" value="0"/>
                        <color name="sigmaS" value="3"/></medium>
                        <medium type="vacuum" name="outside"/>)"));
        const std::vector<Color3f> a = sampleScene(*vacuum, 4000), b = sampleScene(*zero, 4000);
        int nonBlack = 0;
        for (size_t i = 0; i < a.size(); ++i) {
            ASSERT_TRUE((a[i] == b[i]).all()) << integrator << " sample " << i << ": "
                                              << a[i].toString() << " vs " << b[i].toString();
            nonBlack += !a[i].isBlack();
        }
        EXPECT_GT(nonBlack, 400) << "the scene must show something for the test to mean anything";
    }
}

// The chromatic sphere of scenes/seed/medium_sphere_chromatic.xml (sigmaS (1.8, 1.8, 0.2), sigmaA
// (0.2, 0.2, 1.8)) against grey spheres with the coefficients of its red/green and of its blue
// channel. Two-sample z-tests per channel at |z| < 3.5 (fixed streams, so the outcome is
// deterministic).
TEST(VolumePath, ChromaticMediumMatchesPerChannelGreyMedia) {
    auto sphere = [](const std::string& s, const std::string& a) {
        return absl::StrFormat(
            R"(<medium type="homogeneous" name="inside"><color name="sigmaS" value="%s"/><color name="sigmaA" value="%s"/></medium>)",
            s, a);
    };
    auto chromatic = load(
        "chromatic.xml", sceneXml("volume_path_mis", "", sphere("1.8, 1.8, 0.2", "0.2, 0.2, 1.8")));
    auto greyRG = load("grey_rg.xml", sceneXml("volume_path_mis", "", sphere("1.8", "0.2")));
    auto greyB = load("grey_b.xml", sceneXml("volume_path_mis", "", sphere("0.2", "1.8")));
    const int n = 60000;
    const std::vector<Color3f> c = sampleScene(*chromatic, n), rg = sampleScene(*greyRG, n),
                               b = sampleScene(*greyB, n);
    auto stats = [](const std::vector<Color3f>& v, int channel) {
        stats::RunningStats s;
        for (const Color3f& x : v) s.add(double(x[channel]));
        return s;
    };
    for (int channel = 0; channel < 3; ++channel) {
        const stats::RunningStats x = stats(c, channel);
        const stats::RunningStats y = stats(channel < 2 ? rg : b, channel);
        const double z = (x.mean - y.mean) / std::sqrt(x.variance() / n + y.variance() / n);
        EXPECT_LT(std::abs(z), 3.5) << "channel " << channel << ": " << x.mean << " vs " << y.mean;
        EXPECT_GT(x.mean, 0.01);
    }
}

// mediumAt finds the medium of a point from the boundaries around it (for lights in media).
TEST(VolumePath, MediumAtAPoint) {
    auto scene = load(
        "medium_at.xml",
        sceneXml(
            "volume_path_mis", "",
            R"(<medium type="homogeneous" name="inside"><color name="sigmaS" value="1"/></medium>)"));
    const Mesh* sphere = scene->meshes().back().get();
    ASSERT_NE(sphere->insideMedium(), nullptr);
    EXPECT_EQ(mediumAt(*scene, Point3f(0.1f, 0.9f, 0.2f)), sphere->insideMedium());
    EXPECT_EQ(mediumAt(*scene, Point3f(0.0f, 2.0f, 0.0f)), nullptr);  // above the sphere
    EXPECT_EQ(mediumAt(*scene, Point3f(2.0f, 0.5f, 1.0f)), nullptr);
}

TEST(VolumePath, MediumPlacementErrorsNameTheLine) {
    const std::string mesh = kMeshes + "sphere.obj";
    plugin_testing::expectParseError(
        "unnamed_medium.xml",
        absl::StrFormat("<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"%s\"/>\n"
                        "<medium type=\"vacuum\"/>\n</mesh></scene>",
                        mesh),
        3, "needs name=\"inside\" or name=\"outside\"");
    plugin_testing::expectParseError(
        "two_inside.xml",
        absl::StrFormat("<scene>\n<mesh type=\"obj\"><string name=\"filename\" value=\"%s\"/>\n"
                        "<medium type=\"vacuum\" name=\"inside\"/>\n"
                        "<medium type=\"vacuum\" name=\"inside\"/>\n</mesh></scene>",
                        mesh),
        4, "more than one inside medium");
}

// Tracking costs majorant x distance steps per crossing: a medium whose majorant times the
// diagonal of the box it fills exceeds 2^21 is refused when the scene loads, whether the
// majorant is declared or follows from the density or a texture's range. These hung before
// (1 spp at 32x24 unfinished after a minute).
TEST(VolumePath, TrackingBeyondTheLimitIsRefusedAtLoad) {
    auto perlin = [](const char* max) {
        return absl::StrFormat(
            "<texture type=\"perlin3d\" name=\"sigmaS\"><float name=\"min\" value=\"0\"/>"
            "<float name=\"max\" value=\"%s\"/></texture>",
            max);
    };
    const std::string medium = "<medium type=\"heterogeneous\" name=\"inside\">";
    // The sphere of sceneXml: radius 0.7, a bounding box of diagonal 1.4 sqrt(3) = 2.42487.
    const struct {
        std::string sphereMedium;
        const char* majorant;
    } refused[] = {
        {medium + "<float name=\"majorant\" value=\"1e9\"/>" + perlin("1") + "</medium>", "1e+09"},
        {medium + "<float name=\"majorant\" value=\"1e30\"/>" + perlin("1") + "</medium>", "1e+30"},
        {medium + "<float name=\"density\" value=\"1e30\"/>" + perlin("1") + "</medium>", "1e+30"},
        {medium + perlin("1e30") + "</medium>", "1e+30"},
        {medium + "<texture type=\"exponential3d\" name=\"sigmaA\"><color name=\"color0\" "
                  "value=\"1e30\"/></texture></medium>",
         "1e+30"},
        // 10^6 x 2.42 = 2.4e6, just above the limit.
        {medium + "<float name=\"density\" value=\"1e6\"/>" + perlin("1") + "</medium>", "1e+06"},
    };
    for (const auto& c : refused)
        plugin_testing::expectParseError(
            "dense.xml", sceneXml("volume_path_mis", "", c.sphereMedium), 21,
            absl::StrFormat("majorant %s times 2.42487 (the diagonal of the bounding box of ",
                            c.majorant));
    plugin_testing::expectParseError(
        "dense_camera.xml",
        sceneXml("volume_path_mats",
                 "<medium type=\"heterogeneous\"><float name=\"majorant\" value=\"1e9\"/>" +
                     perlin("1") + "</medium>",
                 ""),
        6, "(the camera's medium)) is");
    // Below the limit (8e5 x 2.42 = 1.9e6) it loads; so does any homogeneous medium, whose
    // closed forms take no steps.
    EXPECT_NO_THROW(load(
        "dense_ok.xml",
        sceneXml("volume_path_mis", "",
                 medium + "<float name=\"density\" value=\"8e5\"/>" + perlin("1") + "</medium>")));
    EXPECT_NO_THROW(load("dense_homogeneous.xml",
                         sceneXml("volume_path_mis", "",
                                  "<medium type=\"homogeneous\" name=\"inside\"><color "
                                  "name=\"sigmaS\" value=\"1e30\"/></medium>")));
}

}  // namespace
}  // namespace alphorn
