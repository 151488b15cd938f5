#include "common/camera/camera.h"
#include "common/render/local_render.h"
#include "common/scene/scene.h"
#include "common/texture/plugin_testing.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

std::shared_ptr<Camera> makePhysical(float aperture, float focal) {
    return parseAs<Camera>("physical.xml", absl::StrFormat(R"(<camera type="physical">
  <integer name="width" value="64"/><integer name="height" value="48"/>
  <float name="fov" value="40"/>
  <float name="apertureRadius" value="%g"/><float name="focalDistance" value="%g"/>
</camera>)",
                                                           aperture, focal));
}

// Traces the rays of one image position through a grid of aperture samples (edges included,
// where the concentric map reaches the rim) to the plane at depth Z, and returns the largest
// distance from the pinhole ray's hit, in tangent-space units (divided by Z).
float measuredBlurRadius(const Camera& camera, const Point2f& pixel, float Z) {
    Ray3f pinhole;
    camera.sampleRay(pinhole, pixel, Point2f(0.5f, 0.5f));  // the disk centre
    EXPECT_FLOAT_EQ(pinhole.o.norm(), 0.0f);
    const Point3f centre = pinhole(Z / pinhole.d.z());
    float radius = 0.0f;
    const int n = 33;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            Ray3f ray;
            camera.sampleRay(ray, pixel, Point2f(i / float(n - 1), j / float(n - 1)));
            EXPECT_NEAR(ray.o.z(), 0.0f, 1e-7f);
            const Point3f hit = ray((Z - ray.o.z()) / ray.d.z());
            radius = std::max(radius, (hit - centre).head<2>().norm() / Z);
        }
    return radius;
}

TEST(PhysicalCamera, BlurRadiusIsApertureTimesDefocus) {
    const float A = 0.3f, F = 5.0f;
    auto camera = makePhysical(A, F);
    for (const Point2f& pixel : {Point2f(32.0f, 24.0f), Point2f(5.5f, 40.25f)})
        for (float Z : {1.5f, 2.5f, 4.0f, 8.0f, 20.0f}) {
            const float expected = A * std::abs(1.0f / Z - 1.0f / F);
            EXPECT_NEAR(measuredBlurRadius(*camera, pixel, Z), expected, 2e-3f * expected)
                << "Z " << Z;
        }
}

TEST(PhysicalCamera, FocalPlaneIsSharp) {
    auto camera = makePhysical(0.8f, 6.0f);
    EXPECT_LT(measuredBlurRadius(*camera, Point2f(32.0f, 24.0f), 6.0f), 1e-6f);
    EXPECT_LT(measuredBlurRadius(*camera, Point2f(60.0f, 3.0f), 6.0f), 1e-6f);
    // Rays leave from the whole lens disk, not a point.
    Ray3f ray;
    camera->sampleRay(ray, Point2f(32.0f, 24.0f), Point2f(1.0f, 0.5f));
    EXPECT_NEAR(ray.o.head<2>().norm(), 0.8f, 1e-5f);
}

TEST(PhysicalCamera, ZeroApertureRendersThePinholeImageByteForByte) {
    const std::string sphere = sourcePath("scenes/meshes/sphere.obj");
    auto sceneXml = [&](const std::string& camera, const std::string& extra) {
        return absl::StrFormat(R"(<scene>
  <integrator type="normals"/>
  <camera type="%s">
    <transform name="toWorld"><lookat origin="0.3, 0.5, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
    <float name="fov" value="35"/><integer name="width" value="40"/><integer name="height" value="30"/>
    <float name="nearClip" value="0.01"/><float name="farClip" value="100"/>%s
  </camera>
  <mesh type="obj"><string name="filename" value="%s"/></mesh>
</scene>)",
                               camera, extra, sphere);
    };
    auto render = [](const std::string& name, const std::string& xml) {
        auto scene = loadScene(plugin_testing::writeTempFile(name, xml));
        RenderSettings settings;
        settings.seed = 7;
        settings.passes = 3;
        return renderLocal(*scene, settings).serialize();
    };
    const std::string pinhole = render("pinhole.xml", sceneXml("perspective", ""));
    const std::string physical =
        render("physical0.xml", sceneXml("physical", R"(<float name="apertureRadius" value="0"/>
    <float name="focalDistance" value="3"/>)"));
    EXPECT_TRUE(pinhole == physical);
    // And the aperture does change the image (the comparison above can fail).
    const std::string blurred =
        render("physical1.xml", sceneXml("physical", R"(<float name="apertureRadius" value="0.2"/>
    <float name="focalDistance" value="1"/>)"));
    EXPECT_FALSE(pinhole == blurred);
}

// The same blur seen in a render: a small emissive sphere at depth Z on a black background is a
// disk of radius s in the pinhole image (constant radiance); the lens convolves it with the
// blur disk of radius R. The image's second moment about its centroid is
// <r^2> = R^2 / 2 + s^2 / 2 + 1/6 (pixel centres instead of sample positions), so
// R = sqrt(2 <r^2> - s^2 - 1/3).
double renderedBlurRadiusPixels(float aperture, float focal, float depth, float radius) {
    const std::string sphere = sourcePath("scenes/meshes/sphere.obj");
    const std::string xml = absl::StrFormat(R"(<scene>
  <integrator type="direct_mats"/>
  <camera type="physical">
    <float name="fov" value="40"/><integer name="width" value="64"/><integer name="height" value="64"/>
    <float name="apertureRadius" value="%g"/><float name="focalDistance" value="%g"/>
    <rfilter type="box"/>
  </camera>
  <mesh type="obj">
    <string name="filename" value="%s"/>
    <transform name="toWorld"><scale value="%g, %g, %g"/><translate value="0, 0, %g"/></transform>
    <emitter type="area"><color name="radiance" value="1"/></emitter>
  </mesh>
</scene>)",
                                            aperture, focal, sphere, radius, radius, radius, depth);
    auto scene = loadScene(plugin_testing::writeTempFile("small_emitter.xml", xml));
    RenderSettings settings;
    settings.passes = 256;
    const Image image = resolveImage(renderLocal(*scene, settings), 64, 64);
    double w = 0, cx = 0, cy = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            const double v = image.get(x, y).r();
            w += v;
            cx += v * (x + 0.5);
            cy += v * (y + 0.5);
        }
    cx /= w;
    cy /= w;
    EXPECT_NEAR(cx, 32.0, 0.1);
    EXPECT_NEAR(cy, 32.0, 0.1);
    double r2 = 0;
    for (int y = 0; y < 64; ++y)
        for (int x = 0; x < 64; ++x) {
            const double dx = x + 0.5 - cx, dy = y + 0.5 - cy;
            r2 += image.get(x, y).r() * (dx * dx + dy * dy);
        }
    const double pixelsPerTangent = 32.0 / std::tan(20.0 * M_PI / 180.0);
    const double s = radius / std::sqrt(double(depth) * depth - radius * radius) * pixelsPerTangent;
    return std::sqrt(std::max(0.0, 2.0 * r2 / w - s * s - 1.0 / 3.0));
}

TEST(PhysicalCamera, RenderedBlurOfASmallEmitterMatchesTheThinLens) {
    if (!ObjectFactory::has(ObjectKind::Integrator, "direct_mats") ||
        !ObjectFactory::has(ObjectKind::Emitter, "area"))
        GTEST_SKIP() << "needs direct_mats and the area emitter";
    const double pixelsPerTangent = 32.0 / std::tan(20.0 * M_PI / 180.0);
    for (const auto& [A, F, Z, r] :
         {std::tuple{0.2f, 2.0f, 6.0f, 0.15f}, std::tuple{0.3f, 6.0f, 2.5f, 0.06f}}) {
        const double expected = A * std::abs(1.0 / Z - 1.0 / F) * pixelsPerTangent;
        EXPECT_NEAR(renderedBlurRadiusPixels(A, F, Z, r), expected, 0.03 * expected)
            << A << " " << F;
    }
    // In focus nothing is left beyond the sphere and the pixels.
    EXPECT_LT(renderedBlurRadiusPixels(0.2f, 6.0f, 6.0f, 0.15f), 0.8);
}

TEST(PhysicalCamera, RejectsBadParameters) {
    expectParseError("negative_aperture.xml", R"(<scene>
  <camera type="physical">
    <float name="apertureRadius" value="-0.1"/>
  </camera>
</scene>)",
                     2, "apertureRadius");
    expectParseError("zero_focus.xml", R"(<camera type="physical">
  <float name="focalDistance" value="0"/>
</camera>)",
                     1, "focalDistance");
}

}  // namespace
}  // namespace alphorn
