// The cameras' projection for light tracing (Camera::project, rasterPerSolidAngle): the inverse
// of sampleRay(), and a raster density whose integral over the image is the field of view's
// solid angle.
#include "common/camera/camera.h"
#include "common/core/rng.h"
#include "common/texture/plugin_testing.h"

#include <absl/strings/str_format.h>
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

// Nori's statistical test files aim every camera sample along the view axis with fov 1e-6 on a
// 1x1 image. The rays must then be the pinhole rays of that field of view, not merely accepted:
// through the raster point (x, y) of a w x h image, the camera-space direction is
// ((1 - 2x/w) t, (1 - 2y/h) t h/w, 1) normalised, t = tan(fov / 2), within a few float steps of
// the axis. The thin lens with apertureRadius 0 is the same camera.
TEST(CameraProjection, ANarrowFieldOfViewSendsEverySampleAlongTheViewAxis) {
    const Vector3f axis(0, -1, 0);  // lookat from (0, 0.01, 0) to the origin
    for (const std::string type : {"perspective", "physical"})
        for (const Vector2i& size : {Vector2i(1, 1), Vector2i(64, 48)}) {
            const auto camera =
                parseAs<Camera>("narrow.xml", absl::StrFormat(R"(<camera type="%s">
  <integer name="width" value="%d"/><integer name="height" value="%d"/>
  <float name="fov" value="1e-6"/>
  <transform name="toWorld"><lookat origin="0, 0.01, 0" target="0, 0, 0" up="0, 0, 1"/></transform>
</camera>)",
                                                              type, size.x(), size.y()));
            ASSERT_TRUE(camera) << type;
            const double t = std::tan(0.5e-6 * M_PI / 180.0);
            const double aspect = double(size.x()) / size.y();
            for (const Point2f& fraction : {Point2f(0, 0), Point2f(1, 0), Point2f(0.5f, 0.5f),
                                            Point2f(0.25f, 0.75f), Point2f(1, 1)}) {
                const Point2f raster(fraction.x() * size.x(), fraction.y() * size.y());
                Ray3f ray;
                camera->sampleRay(ray, raster, Point2f(0.3f, 0.8f));
                ASSERT_TRUE(ray.d.allFinite() && ray.o.allFinite()) << type;
                EXPECT_NEAR(ray.d.norm(), 1.0f, 1e-6f);
                // The camera's x axis is up x axis = (0, 0, 1) x (0, -1, 0) = (1, 0, 0), its y
                // axis the up vector (0, 0, 1).
                const double x = (1.0 - 2.0 * fraction.x()) * t,
                             y = (1.0 - 2.0 * fraction.y()) * t / aspect;
                EXPECT_NEAR(ray.d.x(), x, 1e-3 * t) << type << " " << raster.transpose();
                EXPECT_NEAR(ray.d.z(), y, 1e-3 * t) << type << " " << raster.transpose();
                EXPECT_GT(ray.d.dot(axis), 1.0f - 1e-7f);
                // Every ray reaches the floor y = 0 within t * 0.01 of the origin.
                const Point3f hit = ray(0.01f / -ray.d.y());
                EXPECT_LE(Vector2f(hit.x(), hit.z()).norm(), 2.0 * 0.01 * t);
                EXPECT_TRUE(ray.mint > 0.0f && ray.mint < ray.maxt);
            }
            // Light tracing projects onto this image too: a point on the axis lands at the
            // image's centre.
            EXPECT_EQ(camera->lightTracingRefusal(), "");
            const auto centre = camera->project(Point3f(0, -1, 0));
            ASSERT_TRUE(centre);
            EXPECT_NEAR(centre->raster.x(), 0.5f * size.x(), 1e-3f * size.x());
            EXPECT_NEAR(centre->raster.y(), 0.5f * size.y(), 1e-3f * size.y());
            EXPECT_TRUE(std::isfinite(centre->rasterPerSolidAngle));
        }
}

// Any fov in (0, 180) loads as long as float precision can hold the projection. Narrower than
// that the rays would be NaN, so the fov is refused with its reason. A narrow fov whose raster
// density (for light tracing) overflows still renders; only light tracing refuses it.
TEST(CameraProjection, OnlyFieldsOfViewFloatCannotHoldAreRefused) {
    for (const std::string type : {"perspective", "physical"}) {
        for (const char* fov : {"1e-17", "1e-30", "3.5e-37", "179.99998"}) {
            const auto camera = parseAs<Camera>("fov.xml", "<camera type=\"" + type + R"(">
  <integer name="width" value="8"/><integer name="height" value="6"/>
  <float name="fov" value=")" + fov + R"("/></camera>)");
            ASSERT_TRUE(camera) << fov;
            for (const Point2f& raster : {Point2f(0, 0), Point2f(4, 3), Point2f(8, 6)}) {
                Ray3f ray;
                camera->sampleRay(ray, raster, Point2f(0.5f, 0.5f));
                EXPECT_TRUE(ray.d.allFinite()) << fov;
                EXPECT_NEAR(ray.d.norm(), 1.0f, 1e-5f) << fov;
                EXPECT_GT(ray.d.z(), 0.0f) << fov;
            }
        }
        plugin_testing::expectParseError("fov_tiny.xml", "<camera type=\"" + type + R"(">
  <float name="fov" value="1e-38"/></camera>)",
                                         1,
                                         "fov 1e-38 degrees is too narrow to render in float "
                                         "precision");
        const auto large = parseAs<Camera>("fov_large.xml", "<camera type=\"" + type + R"(">
  <integer name="width" value="16384"/><integer name="height" value="16384"/>
  <float name="fov" value="1e-15"/></camera>)");
        EXPECT_NE(large->lightTracingRefusal().find("too narrow for light tracing"),
                  std::string::npos)
            << large->lightTracingRefusal();
    }
}

}  // namespace
}  // namespace alphorn
