#include "common/core/rng.h"
#include "common/emitter/emitter.h"
#include "common/stats/chi_square.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

// fov 60 degrees, 2:1 aspect: tan of the half-angles 0.57735 (x) and 0.28868 (y).
const double kTanX = std::tan(M_PI / 6), kTanY = kTanX / 2;
const double kSolidAngle = 4.0 * std::asin(std::sin(std::atan(kTanX)) * std::sin(std::atan(kTanY)));

std::shared_ptr<Emitter> projector(const std::string& texture, const std::string& transform = "") {
    return parseAs<Emitter>("projector.xml", absl::StrFormat(R"(<emitter type="projector">
  <color name="power" value="6, 3, 1.5"/>
  <float name="fov" value="60"/><integer name="width" value="200"/><integer name="height" value="100"/>
  %s %s
</emitter>)",
                                                             transform, texture));
}

const char* kChecker = R"(<texture type="checkerboard2d" name="image">
  <color name="color0" value="1"/><color name="color1" value="0"/>
  <float name="uscale" value="2"/><float name="vscale" value="2"/></texture>)";
// The checkerboard above, analytically: 4 x 4 checks, colour0 (1) at the uv origin.
double checker(double u, double v) {
    return (static_cast<int64_t>(std::floor(4 * u)) + static_cast<int64_t>(std::floor(4 * v))) %
               2 ==
           0;
}
double jacobian(double u, double v) {  // d omega / d(u, v)
    const double x = kTanX * (1 - 2 * u), y = kTanY * (2 * v - 1), r2 = 1 + x * x + y * y;
    return 4 * kTanX * kTanY / (r2 * std::sqrt(r2));
}
// Integral of f(u, v) J over [u0, u1] x [v0, v1] by the midpoint rule.
template <typename F>
double integrate(F f, double u0, double u1, double v0, double v1, int n) {
    double sum = 0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double u = u0 + (u1 - u0) * (i + 0.5) / n, v = v0 + (v1 - v0) * (j + 0.5) / n;
            sum += f(u, v) * jacobian(u, v);
        }
    return sum * (u1 - u0) * (v1 - v0) / (n * n);
}
// The direction (local = world) through image point (u, v).
Vector3f through(double u, double v) {
    return Vector3f(float(kTanX * (1 - 2 * u)), float(kTanY * (2 * v - 1)), 1.0f).normalized();
}

TEST(Projector, InsideOutsideAndBehindTheFrustum) {
    auto light = projector("");
    const double i0 = 6.0 / kSolidAngle;  // white image: intensity power / Omega
    auto intensityTowards = [&](const Vector3f& d) {
        EmitterQueryRecord rec(Point3f(3.0f * d));
        const Color3f v = light->sample(rec, Point2f(0.5f, 0.5f));
        EXPECT_EQ(rec.pdf, 1.0f);
        return double(v.r()) * 9.0;
    };
    EXPECT_NEAR(intensityTowards(through(0.5, 0.5)), i0, 1e-5 * i0);
    EXPECT_NEAR(intensityTowards(through(0.02, 0.97)), i0, 1e-5 * i0);
    EXPECT_EQ(intensityTowards(through(-0.02, 0.5)), 0.0);  // left of the frustum
    EXPECT_EQ(intensityTowards(through(0.5, 1.03)), 0.0);   // above it (x would be inside)
    EXPECT_EQ(intensityTowards(Vector3f(0, 0, -1)), 0.0);   // behind
    EXPECT_EQ(intensityTowards(-through(0.5, 0.5)), 0.0);
    EXPECT_NEAR(light->power().r(), 6.0, 1e-5);  // white: exactly `power`
    EXPECT_NEAR(light->power().b(), 1.5, 1e-5);
}

TEST(Projector, ImageOrientationAndPlacement) {
    // A uv texture shows which image point lands where: u runs from the image's left (local +x,
    // as for a camera) to its right, v from bottom to top (local +y is up).
    auto light = projector(
        R"(<texture type="uv" name="image"/>)",
        R"(<transform name="toWorld"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>)");
    // Looking down -z with up +y, the camera's left (local +x) is world -x.
    const double i0 = 6.0 / kSolidAngle;
    for (const auto& [u, v] : {std::pair{0.2, 0.7}, std::pair{0.8, 0.1}, std::pair{0.45, 0.9}}) {
        const Vector3f local = through(u, v);
        const Vector3f world(-local.x(), local.y(), -local.z());
        EmitterQueryRecord rec(Point3f(0, 0, 5) + 2.0f * world);
        const Color3f value(light->sample(rec, Point2f(0.5f, 0.5f)) * 4.0f);
        EXPECT_NEAR(value.r(), i0 * u, 1e-4 * i0) << u << " " << v;
        EXPECT_NEAR(value.g(), 0.5 * i0 * v, 1e-4 * i0) << u << " " << v;
        EXPECT_EQ(value.b(), 0.0f);
    }
}

TEST(Projector, PowerIsTheIntegralOverTheFrustum) {
    auto light = projector(kChecker);
    const double integral = integrate(checker, 0, 1, 0, 1, 2048);
    const double expected = 6.0 / kSolidAngle * integral;
    EXPECT_NEAR(light->power().r(), expected, 1e-4 * expected);
    EXPECT_NEAR(light->power().g(), expected / 2, 1e-4 * expected);
    // About half the checks are lit, the centre ones (seen at larger solid angle) included.
    EXPECT_GT(integral / kSolidAngle, 0.4);
    EXPECT_LT(integral / kSolidAngle, 0.6);
}

// Photon directions follow the sampling density (chi-square over 16 x 16 image cells), and the
// photon fluxes average to power().
void checkPhotons(const std::string& texture,
                  const std::function<double(double, double)>& density) {
    auto light = projector(texture);
    const int bins = 16, n = 300000;
    std::vector<double> observed(bins * bins, 0.0), expected(bins * bins, 0.0);
    double total = 0;
    for (int j = 0; j < bins; ++j)
        for (int i = 0; i < bins; ++i) {
            expected[j * bins + i] = integrate(density, double(i) / bins, double(i + 1) / bins,
                                               double(j) / bins, double(j + 1) / bins, 32);
            total += expected[j * bins + i];
        }
    for (double& e : expected) e *= n / total;
    Rng rng(5, 0, 0, StreamPurpose::Test);
    double sum = 0, sum2 = 0;
    for (int k = 0; k < n; ++k) {
        Ray3f ray;
        const Color3f flux = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                                 Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_TRUE(flux.allFinite());
        sum += flux.r();
        sum2 += double(flux.r()) * flux.r();
        const Vector3f d = ray.d;
        ASSERT_GT(d.z(), 0.0f);
        const double u = 0.5 * (1 - d.x() / d.z() / kTanX), v = 0.5 * (1 + d.y() / d.z() / kTanY);
        ASSERT_GE(u, -1e-6);
        ASSERT_LE(u, 1 + 1e-6);
        ASSERT_GE(v, -1e-6);
        ASSERT_LE(v, 1 + 1e-6);
        const int i = std::clamp(int(u * bins), 0, bins - 1),
                  j = std::clamp(int(v * bins), 0, bins - 1);
        observed[j * bins + i] += 1;
    }
    const auto result = stats::chi2Test(observed, expected, n, 5.0, 0.01);
    EXPECT_TRUE(result.passed) << result.message;
    const double mean = sum / n, sigma = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
    EXPECT_NEAR(mean, light->power().r(), 5 * sigma + 1e-5 * mean);
}

TEST(Projector, PhotonSamplingOfAWhiteImage) {
    // Directions uniform in solid angle over the frustum.
    checkPhotons("", [](double, double) { return 1.0; });
}

TEST(Projector, PhotonSamplingOfACheckerboard) {
    // The documented density: proportional to the image plus a floor of 1% of its maximum.
    checkPhotons(kChecker, [](double u, double v) { return checker(u, v) + 0.01; });
}

// As for the camera, a narrow fov renders: at 1e-6 degrees (a beam of solid angle 3e-16 sr) the
// intensity on the axis is power / Omega, a white image's power() is `power`, and photons carry
// it, all within the beam. Only a fov whose intensity float cannot hold is refused, saying why.
TEST(Projector, ANarrowFieldOfViewIsABeamOfTheGivenPower) {
    auto light = parseAs<Emitter>("projector_narrow.xml", R"(<emitter type="projector">
  <color name="power" value="2"/><float name="fov" value="1e-6"/>
</emitter>)");
    ASSERT_TRUE(light);
    const double a = 0.5e-6 * M_PI / 180.0, omega = 4.0 * std::asin(std::sin(a) * std::sin(a));
    EmitterQueryRecord rec(Point3f(0, 0, 3));
    const Color3f irradiance = light->sample(rec, Point2f(0.5f, 0.5f));
    EXPECT_NEAR(irradiance.r() * 9.0, 2.0 / omega, 1e-4 * 2.0 / omega);
    EXPECT_NEAR(light->power().r(), 2.0f, 1e-4f);
    Rng rng(9, 0, 0, StreamPurpose::Test);
    double sum = 0;
    const int n = 10000;
    for (int k = 0; k < n; ++k) {
        Ray3f ray;
        const Color3f flux = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                                 Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_TRUE(flux.allFinite());
        const Vector3f d = ray.d.normalized();
        ASSERT_LE(std::abs(d.x() / d.z()), std::tan(a) * 1.0001);
        ASSERT_LE(std::abs(d.y() / d.z()), std::tan(a) * 1.0001);
        sum += flux.r();
    }
    EXPECT_NEAR(sum / n, 2.0, 1e-3);
    expectParseError("projector_tiny.xml", R"(<emitter type="projector">
  <float name="fov" value="1e-18"/>
</emitter>)",
                     1,
                     "fov 1e-18 degrees (aspect 1:1) is too narrow to render in float precision");
    for (const char* fov : {"0", "-1", "nan", "inf", "180"})
        expectParseError("projector_fov.xml",
                         std::string(R"(<emitter type="projector"><float name="fov" value=")") +
                             fov + R"("/></emitter>)",
                         1, "fov must be in (0, 180) degrees, got ");
}

TEST(Projector, ClearErrors) {
    expectParseError("projector_fov.xml", R"(<emitter type="projector">
  <float name="fov" value="180"/>
</emitter>)",
                     1, "fov");
    expectParseError("projector_two.xml", R"(<emitter type="projector">
  <texture type="uv"/><texture type="uv"/>
</emitter>)",
                     1, "one texture");
}

}  // namespace
}  // namespace alphorn
