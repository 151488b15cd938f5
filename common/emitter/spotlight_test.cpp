#include "common/core/rng.h"
#include "common/emitter/emitter.h"
#include "common/stats/chi_square.h"
#include "common/stats/student_t.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

// PBRT v2 falloff and intensity, in double, written independently of the plugin.
double falloff(double cosTheta, double cosTotal, double cosStart) {
    if (cosTheta >= cosStart) return 1.0;
    if (cosTheta < cosTotal) return 0.0;
    const double delta = (cosTheta - cosTotal) / (cosStart - cosTotal);
    return delta * delta * delta * delta;
}
double centralIntensity(double power, double cosTotal, double cosStart) {
    return power / (2.0 * M_PI * ((1.0 - cosStart) + (cosStart - cosTotal) / 5.0));
}

std::shared_ptr<Emitter> spot(const std::string& transform, float total = 30, float start = 25,
                              const std::string& power = "10, 20, 5") {
    return parseAs<Emitter>("spot.xml", absl::StrFormat(R"(<emitter type="spotlight">
  <color name="power" value="%s"/>
  <float name="totalAngle" value="%g"/><float name="falloffStart" value="%g"/>
  %s
</emitter>)",
                                                        power, total, start, transform));
}

const std::string kAimed =
    R"(<transform name="toWorld"><lookat origin="1, 2, 3" target="1, -1, 3" up="0, 0, 1"/></transform>)";

TEST(SpotLight, FalloffBetweenTheConesIsQuarticInCosine) {
    auto light = spot(kAimed);
    const Vector3f axis(0, -1, 0), perp(1, 0, 0);
    const Point3f pos(1, 2, 3);
    auto received = [&](float degrees) {
        const float t = degToRad(degrees);
        EmitterQueryRecord rec(pos + 1.5f * (std::cos(t) * axis + std::sin(t) * perp));
        const Color3f value = light->sample(rec, Point2f(0.5f, 0.5f));
        EXPECT_EQ(rec.pdf, 1.0f);
        EXPECT_TRUE(rec.p.isApprox(pos));
        return Color3f(value * (1.5f * 1.5f));  // intensity
    };
    const double i0 = centralIntensity(10.0, std::cos(M_PI / 6), std::cos(25.0 * M_PI / 180));
    EXPECT_NEAR(received(0).r(), i0, 1e-5 * i0);
    EXPECT_NEAR(received(24.9f).r(), i0, 1e-5 * i0);
    // falloff(27.5 degrees) = delta^4 = ((cos 27.5 - cos 30) / (cos 25 - cos 30))^4 = 0.073656.
    EXPECT_NEAR(received(27.5f).r() / i0, 0.073656, 2e-5);
    EXPECT_NEAR(received(27.5f).g() / (2.0 * i0), 0.073656, 2e-5);
    EXPECT_EQ(received(30.5f).r(), 0.0f);
    EXPECT_EQ(received(120.0f).r(), 0.0f);
}

// pbrt-v4's falloff: smoothstep(delta) = delta^2 (3 - 2 delta) between the cones, and the flux
// 2 pi I ((1 - cos start) + (cos start - cos total) / 2); photons follow it and carry the power.
TEST(SpotLight, SmoothstepFalloffAsPbrtV4) {
    auto light = parseAs<Emitter>("spot.xml", R"(<emitter type="spotlight">
  <color name="power" value="10"/>
  <float name="totalAngle" value="30"/><float name="falloffStart" value="25"/>
  <string name="falloff" value="smoothstep"/>
</emitter>)");
    const double cosTotal = std::cos(M_PI / 6), cosStart = std::cos(25.0 * M_PI / 180);
    const double i0 = 10.0 / (2.0 * M_PI * ((1.0 - cosStart) + (cosStart - cosTotal) / 2.0));
    auto intensity = [&](double degrees) {
        const double t = degrees * M_PI / 180;
        EmitterQueryRecord rec(Point3f(float(std::sin(t)), 0.0f, float(std::cos(t))));
        return double(light->sample(rec, Point2f(0.5f, 0.5f)).r());
    };
    EXPECT_NEAR(intensity(0), i0, 1e-5 * i0);
    const double delta = (std::cos(27.5 * M_PI / 180) - cosTotal) / (cosStart - cosTotal);
    EXPECT_NEAR(intensity(27.5) / i0, delta * delta * (3 - 2 * delta), 2e-5);
    EXPECT_EQ(intensity(30.5), 0.0);
    // Photons: the fraction leaving between the cones is the outer part of the flux.
    Rng rng(31, 0, 0, StreamPurpose::Test);
    stats::RunningStats outer, flux;
    for (int k = 0; k < 100000; ++k) {
        Ray3f ray;
        flux.add(
            light->samplePhoton(ray, Point2f(0.5f, 0.5f), Point2f(rng.nextFloat(), rng.nextFloat()))
                .r());
        ASSERT_GE(ray.d.normalized().z(), cosTotal - 1e-6);
        outer.add(ray.d.normalized().z() < cosStart ? 1.0 : 0.0);
    }
    const double outerShare =
        ((cosStart - cosTotal) / 2.0) / ((1.0 - cosStart) + (cosStart - cosTotal) / 2.0);
    EXPECT_NEAR(outer.mean, outerShare, 5.0 * outer.standardError());
    EXPECT_NEAR(flux.mean, 10.0, 1e-9);
    expectParseError("spot.xml", R"(<emitter type="spotlight"><color name="power" value="1"/>
  <string name="falloff" value="linear"/></emitter>)",
                     1, "falloff must be");
}

TEST(SpotLight, IrradianceOnAPlaneAtTheCentreAndBetweenTheCones) {
    auto light = spot(kAimed, 20.0f, 15.0f);
    const double cosT = std::cos(20.0 * M_PI / 180), cosS = std::cos(15.0 * M_PI / 180);
    const double i0 = centralIntensity(10.0, cosT, cosS);
    const double d = 2.5;  // plane y = 2 - d, facing the light
    const Normal3f normal(0, 1, 0);
    for (double theta : {0.0, 10.0, 17.0, 18.5, 19.9, 21.0}) {
        const double t = theta * M_PI / 180;
        const Point3f ref(float(1 + d * std::tan(t)), float(2 - d), 3.0f);
        EmitterQueryRecord rec(ref);
        const double e = double(light->sample(rec, Point2f(0.1f, 0.9f)).r()) * normal.dot(rec.wi);
        const double expected =
            i0 * falloff(std::cos(t), cosT, cosS) * std::pow(std::cos(t), 3) / (d * d);
        EXPECT_NEAR(e, expected, 1e-4 * i0 / (d * d) + 1e-5 * expected) << theta;
    }
}

// Directions of emitted photons follow the intensity exactly (chi-square over cos theta and
// phi), and each carries `power`, so photon fluxes sum to power.
void checkPhotons(float totalAngle, float falloffStart) {
    auto light = spot("", totalAngle, falloffStart);  // identity: local = world
    const double cosT = std::cos(totalAngle * M_PI / 180),
                 cosS = std::cos(falloffStart * M_PI / 180);
    EXPECT_TRUE(light->power().isApprox(Color3f(10, 20, 5)));
    const int muBins = 24, phiBins = 8, n = 200000;
    std::vector<double> observed(muBins * phiBins, 0.0), expected(muBins * phiBins, 0.0);
    auto mass = [&](double mu) {  // integral of the falloff from cosTotal to mu
        if (mu <= cosT) return 0.0;
        if (mu <= cosS) return (cosS - cosT) / 5.0 * std::pow((mu - cosT) / (cosS - cosT), 5);
        return (cosS - cosT) / 5.0 + (mu - cosS);
    };
    const double total = mass(1.0);
    for (int i = 0; i < muBins; ++i) {
        const double lo = cosT + (1 - cosT) * i / muBins, hi = cosT + (1 - cosT) * (i + 1) / muBins;
        for (int j = 0; j < phiBins; ++j)
            expected[i * phiBins + j] = n * (mass(hi) - mass(lo)) / total / phiBins;
    }
    Rng rng(21, 0, 0, StreamPurpose::Test);
    double flux[3] = {0, 0, 0};
    for (int k = 0; k < n; ++k) {
        Ray3f ray;
        const Color3f f = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                              Point2f(rng.nextFloat(), rng.nextFloat()));
        for (int c = 0; c < 3; ++c) flux[c] += f[c];
        const Vector3f d = ray.d.normalized();
        ASSERT_TRUE(ray.o.isZero());
        ASSERT_GE(d.z(), cosT - 1e-6);
        const int i = std::min(muBins - 1, int((d.z() - cosT) / (1 - cosT) * muBins));
        double phi = std::atan2(d.y(), d.x());
        if (phi < 0) phi += 2 * M_PI;
        const int j = std::min(phiBins - 1, int(phi / (2 * M_PI) * phiBins));
        observed[i * phiBins + j] += 1;
    }
    EXPECT_NEAR(flux[0] / n, 10.0, 1e-4);
    EXPECT_NEAR(flux[1] / n, 20.0, 1e-4);
    EXPECT_NEAR(flux[2] / n, 5.0, 1e-4);
    const auto result = stats::chi2Test(observed, expected, n, 5.0, 0.01);
    EXPECT_TRUE(result.passed) << result.message;
}

TEST(SpotLight, PhotonsFollowTheIntensityAndSumToPower) {
    checkPhotons(30.0f, 25.0f);
    Rng rng(22, 0, 0, StreamPurpose::Test);
    // A rotated spotlight emits around its own axis.
    auto aimed = spot(kAimed);
    Vector3f mean = Vector3f::Zero();
    for (int k = 0; k < 2000; ++k) {
        Ray3f ray;
        aimed->samplePhoton(ray, Point2f(0.5f, 0.5f), Point2f(rng.nextFloat(), rng.nextFloat()));
        mean += ray.d.normalized() / 2000.0f;
        ASSERT_TRUE(ray.o.isApprox(Point3f(1, 2, 3)));
    }
    EXPECT_GT(mean.normalized().dot(Vector3f(0, -1, 0)), 0.999f);
}

// A cone wider than a hemisphere is a cone too (PBRT's spotlight takes any angle): the falloff,
// the flux integral and the photons all work in cos theta in [-1, 1], up to a full sphere at
// 180 degrees. A narrow one renders down to where float cosines end.
TEST(SpotLight, ConesWiderThanAHemisphereAndNarrowOnesRender) {
    checkPhotons(120.0f, 100.0f);
    checkPhotons(180.0f, 150.0f);
    auto wide = spot(kAimed, 120.0f, 100.0f);
    const double cosT = std::cos(120.0 * M_PI / 180), cosS = std::cos(100.0 * M_PI / 180);
    const double i0 = centralIntensity(10.0, cosT, cosS);
    const Vector3f axis(0, -1, 0), perp(1, 0, 0);
    for (float degrees : {0.0f, 99.0f, 110.0f, 119.0f, 121.0f, 170.0f}) {
        const float t = degToRad(degrees);
        EmitterQueryRecord rec(Point3f(1, 2, 3) + 2.0f * (std::cos(t) * axis + std::sin(t) * perp));
        const double intensity = double(wide->sample(rec, Point2f(0.5f, 0.5f)).r()) * 4.0;
        const double expected = i0 * falloff(std::cos(double(t)), cosT, cosS);
        EXPECT_NEAR(intensity, expected, 1e-4 * i0) << degrees;
    }
    // 0.05 degrees: a cone a few float steps of cos theta wide (1 - cos = 3.8e-7, float steps
    // of 6e-8), so its intensity is that of the nearest cone of float cosines, within 20% of
    // the exact one; photons stay inside it.
    auto narrow = spot("", 0.05f, 0.03f);
    const double cosNarrowT = std::cos(double(degToRad(0.05f))),
                 cosNarrowS = std::cos(double(degToRad(0.03f)));
    EmitterQueryRecord onAxis(Point3f(0, 0, 2));
    const double i0Narrow = centralIntensity(10.0, cosNarrowT, cosNarrowS);
    EXPECT_NEAR(double(narrow->sample(onAxis, Point2f(0.5f, 0.5f)).r()) * 4.0, i0Narrow,
                0.2 * i0Narrow);
    Rng rng(23, 0, 0, StreamPurpose::Test);
    for (int k = 0; k < 1000; ++k) {
        Ray3f ray;
        const Color3f f = narrow->samplePhoton(ray, Point2f(0.5f, 0.5f),
                                               Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_TRUE(f.isApprox(Color3f(10, 20, 5)));
        ASSERT_GE(ray.d.normalized().z(), float(cosNarrowT) - 1e-7f);
    }
}

TEST(SpotLight, ClearErrors) {
    expectParseError("spot_order.xml", R"(<scene>
  <emitter type="spotlight">
    <color name="power" value="1"/>
    <float name="totalAngle" value="20"/><float name="falloffStart" value="25"/>
  </emitter>
</scene>)",
                     2, "falloffStart");
    expectParseError("spot_wide.xml", R"(<emitter type="spotlight">
    <color name="power" value="1"/><float name="totalAngle" value="181"/>
</emitter>)",
                     1, "totalAngle must be in (0, 180] degrees, got 181");
    expectParseError("spot_narrow.xml", R"(<emitter type="spotlight">
    <color name="power" value="1"/>
    <float name="totalAngle" value="0.01"/><float name="falloffStart" value="0.01"/>
</emitter>)",
                     1, "totalAngle 0.01 degrees is too narrow to render in float precision");
    expectParseError("spot_zero.xml", R"(<emitter type="spotlight">
    <color name="power" value="1"/><float name="totalAngle" value="0"/>
</emitter>)",
                     1, "totalAngle");
    expectParseError("spot_nopower.xml", R"(<emitter type="spotlight"/>)", 1, "power");
}

}  // namespace
}  // namespace alphorn
