// The cameras' projection for light tracing (Camera::project, rasterPerSolidAngle): the inverse
// of sampleRay(), and a raster density whose integral over the image is the field of view's
// solid angle.
#include "common/camera/camera.h"
#include "common/core/rng.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::parseAs;

std::shared_ptr<Camera> makeCamera(const std::string& type, const std::string& extra = "") {
    return parseAs<Camera>("camera.xml", "<camera type=\"" + type + R"(">
  <integer name="width" value="64"/><integer name="height" value="48"/>
  <float name="fov" value="40"/>
  <transform name="toWorld"><lookat origin="1, 2, 3" target="0, 0.5, 0" up="0, 1, 0"/></transform>
)" + extra + "</camera>");
}

TEST(CameraProjection, InvertsSampleRay) {
    for (const char* type : {"perspective", "physical"}) {
        const auto camera = makeCamera(type);
        ASSERT_EQ(camera->lightTracingRefusal(), "") << type;
        Rng rng(3, 0, 0, StreamPurpose::Test);
        for (int i = 0; i < 1000; ++i) {
            const Point2f raster(64.0f * rng.nextFloat(), 48.0f * rng.nextFloat());
            Ray3f ray;
            camera->sampleRay(ray, raster, Point2f(0.5f, 0.5f));
            const float t = 0.5f + 10.0f * rng.nextFloat();
            const auto projection = camera->project(ray(t / ray.d.norm()));
            ASSERT_TRUE(projection) << type << " " << raster.transpose();
            EXPECT_NEAR(projection->raster.x(), raster.x(), 2e-3f) << type;
            EXPECT_NEAR(projection->raster.y(), raster.y(), 2e-3f) << type;
            EXPECT_NEAR((projection->position - Point3f(1, 2, 3)).norm(), 0.0f, 1e-5f);
            EXPECT_NEAR(projection->rasterPerSolidAngle, camera->rasterPerSolidAngle(ray.d),
                        1e-3f * projection->rasterPerSolidAngle);
        }
        // Behind the camera, and beside the image.
        EXPECT_FALSE(camera->project(Point3f(2, 3.5, 6)));
        EXPECT_FALSE(camera->project(Point3f(1, 2, -3)));
    }
}

// The image spans the solid angle 4 asin(sin a sin b) of a frustum with half-angles a (the
// horizontal fov / 2) and b; integrating 1 / (raster per solid angle) over the raster by the
// midpoint rule must give it.
TEST(CameraProjection, RasterDensityIntegratesToTheFieldOfView) {
    const auto camera = makeCamera("perspective");
    const double a = 20.0 * M_PI / 180.0;
    const double b = std::atan(std::tan(a) * 48.0 / 64.0);
    const double expected = 4.0 * std::asin(std::sin(a) * std::sin(b));
    double solidAngle = 0.0;
    const int n = 400;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const Point2f raster((i + 0.5f) * 64.0f / n, (j + 0.5f) * 48.0f / n);
            Ray3f ray;
            camera->sampleRay(ray, raster, Point2f(0.5f, 0.5f));
            solidAngle += (64.0 * 48.0 / (double(n) * n)) / camera->rasterPerSolidAngle(ray.d);
        }
    EXPECT_NEAR(solidAngle, expected, 1e-4 * expected);
}

TEST(CameraProjection, ALensIsRefused) {
    const auto lens = makeCamera("physical", R"(<float name="apertureRadius" value="0.1"/>)");
    EXPECT_NE(lens->lightTracingRefusal().find("apertureRadius"), std::string::npos);
    const auto scaled = parseAs<Camera>("camera.xml", R"(<camera type="perspective">
  <transform name="toWorld"><scale value="2, 1, 1"/></transform></camera>)");
    EXPECT_NE(scaled->lightTracingRefusal().find("toWorld"), std::string::npos);
}

// nearClip 1e-30 rendered black: the near-plane point a ray's direction is normalised from had a
// squared length of 0 in float. nearClip * farClip beyond the float range did the same through
// the projection matrix. At the bounds the rays are still unit length.
TEST(CameraProjection, ClipDistancesThatBreakTheRaysAreRefused) {
    for (const std::string type : {"perspective", "physical"}) {
        plugin_testing::expectParseError("near.xml", "<camera type=\"" + type + R"(">
  <float name="nearClip" value="1e-30"/></camera>)",
                                         1, "nearClip 1e-30 is too small (at least 1e-18)");
        plugin_testing::expectParseError("near_times_far.xml", "<camera type=\"" + type + R"(">
  <float name="nearClip" value="10"/><float name="farClip" value="1e38"/></camera>)",
                                         1,
                                         "nearClip * farClip (10 * 1e+38) exceeds the float range");
        for (const char* clips :
             {R"(<float name="nearClip" value="1e-18"/>)",
              R"(<float name="nearClip" value="1e-18"/><float name="farClip" value="3e38"/>)"}) {
            const auto camera = makeCamera(type, clips);
            for (const Point2f& raster : {Point2f(0, 0), Point2f(32, 24), Point2f(64, 48)}) {
                Ray3f ray;
                camera->sampleRay(ray, raster, Point2f(0.5f, 0.5f));
                EXPECT_NEAR(ray.d.norm(), 1.0f, 1e-5f) << type << " " << clips;
                EXPECT_TRUE(std::isfinite(ray.mint) && std::isfinite(ray.maxt) &&
                            ray.mint < ray.maxt);
            }
        }
    }
}

}  // namespace
}  // namespace alphorn
