// Unit tests of the lights at infinity. The two sphere mappings against their documented
// conventions (pbrt-v4's octahedral square: +z at the centre, +x the middle of the right edge, +y
// of the bottom row) and the equal-area property by chi-square; the environment's sample() against
// its pdf() by chi-square on maps with a sun and a gradient; sample, pdf and eval agreeing; the
// sphere integral of the radiance, the illuminance rescaling and the photon flux against closed
// forms or exact sums; the directional light's sample and photons. Fixed seeds, 5-sigma
// tolerances.
#include "common/core/image.h"
#include "common/core/rng.h"
#include "common/core/warp.h"
#include "common/emitter/emitter.h"
#include "common/emitter/sphere_mapping.h"
#include "common/stats/chi_square.h"
#include "common/stats/spherical_histogram.h"
#include "common/stats/student_t.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <filesystem>

namespace alphorn {
namespace {

namespace fs = std::filesystem;

class EnvironmentTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("alphorn_environment_" + std::to_string(::getpid()));
        fs::create_directories(m_dir);
    }
    void TearDown() override { fs::remove_all(m_dir); }

    std::string writeMap(const std::string& name, const Image& image) {
        const std::string path = (m_dir / name).string();
        writeEXR(path, image);
        return path;
    }

    fs::path m_dir;
};

std::shared_ptr<Emitter> create(const std::string& type, const PropertyList& props) {
    auto emitter =
        std::static_pointer_cast<Emitter>(ObjectFactory::create(ObjectKind::Emitter, type, props));
    emitter->activate();
    emitter->setSceneBounds(Point3f(0.5f, -1.0f, 2.0f), 3.0f);
    return emitter;
}

Transform rotation(float degrees, const Vector3f& axis) {
    Matrix4f m = Matrix4f::Identity();
    m.topLeftCorner<3, 3>() = Eigen::AngleAxisf(degToRad(degrees), axis.normalized()).matrix();
    return Transform(m);
}

// A map with a gradient over the whole sphere and one pixel 2000 times brighter (a sun).
Image sunAndGradient(int width, int height, int sunX, int sunY) {
    Image image(width, height);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            image.set(x, y, Color3f(0.2f + float(x) / width, 0.1f + float(y) / height, 0.3f));
    image.set(sunX, sunY, Color3f(2000.0f, 1500.0f, 1000.0f));
    return image;
}

Vector3f randomDirection(Rng& rng) {
    return warp::squareToUniformSphere(Point2f(rng.nextFloat(), rng.nextFloat()));
}

void expectNear(const Point2f& a, const Point2f& b) {
    EXPECT_NEAR(a.x(), b.x(), 1e-5f) << a.transpose() << " vs " << b.transpose();
    EXPECT_NEAR(a.y(), b.y(), 1e-5f) << a.transpose() << " vs " << b.transpose();
}

TEST(SphereMapping, OctahedralFollowsPbrtsConvention) {
    const float s = std::sqrt(0.5f);
    expectNear(octahedralFromDirection(Vector3f(0, 0, 1)), Point2f(0.5f, 0.5f));
    expectNear(octahedralFromDirection(Vector3f(1, 0, 0)), Point2f(1.0f, 0.5f));
    expectNear(octahedralFromDirection(Vector3f(-1, 0, 0)), Point2f(0.0f, 0.5f));
    expectNear(octahedralFromDirection(Vector3f(0, 1, 0)), Point2f(0.5f, 1.0f));
    expectNear(octahedralFromDirection(Vector3f(0, -1, 0)), Point2f(0.5f, 0.0f));
    expectNear(octahedralFromDirection(Vector3f(0, 0, -1)), Point2f(1.0f, 1.0f));
    expectNear(octahedralFromDirection(Vector3f(s, s, 0)), Point2f(0.75f, 0.75f));
    expectNear(octahedralFromDirection(Vector3f(-s, s, 0)), Point2f(0.25f, 0.75f));
    // 45 degrees from +z towards +x: |z| = 1 - r^2 puts it at r = sqrt(1 - 1/sqrt 2).
    expectNear(octahedralFromDirection(Vector3f(s, 0, s)),
               Point2f(0.5f * (1.0f + std::sqrt(1.0f - s)), 0.5f));
    // Below the equator, towards +x: the right half of the square, beyond the diamond.
    expectNear(octahedralFromDirection(Vector3f(s, 0, -s)),
               Point2f(0.5f * (1.0f + 1.0f), 0.5f * (1.0f + (1.0f - std::sqrt(1.0f - s)))));
    Rng rng(7, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 10000; ++i) {
        const Vector3f d = randomDirection(rng);
        const Vector3f back = octahedralToDirection(octahedralFromDirection(d));
        ASSERT_LT((back - d).norm(), 2e-5f) << d.transpose();
        const Point2f uv(rng.nextFloat(), rng.nextFloat());
        const Vector3f w = octahedralToDirection(uv);
        ASSERT_NEAR(w.norm(), 1.0f, 1e-5f);
        const Point2f uvBack = octahedralFromDirection(w);
        ASSERT_LT((uvBack - uv).norm(), 2e-5f) << uv.transpose();
    }
}

TEST(SphereMapping, EquirectConvention) {
    expectNear(equirectFromDirection(Vector3f(0, 0, -1)), Point2f(0.0f, 0.5f));
    expectNear(equirectFromDirection(Vector3f(1, 0, 0)), Point2f(0.25f, 0.5f));
    expectNear(equirectFromDirection(Vector3f(0, 0, 1)), Point2f(0.5f, 0.5f));
    expectNear(equirectFromDirection(Vector3f(-1, 0, 0)), Point2f(0.75f, 0.5f));
    EXPECT_NEAR(equirectFromDirection(Vector3f(0, 1, 0)).y(), 0.0f, 1e-6f);
    EXPECT_NEAR(equirectFromDirection(Vector3f(0, -1, 0)).y(), 1.0f, 1e-6f);
    Rng rng(8, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 10000; ++i) {
        const Vector3f d = randomDirection(rng);
        ASSERT_LT((equirectToDirection(equirectFromDirection(d)) - d).norm(), 2e-5f);
    }
}

// Uniform points of the square land uniformly on the sphere: the mapping is equal-area.
TEST(SphereMapping, OctahedralIsEqualArea) {
    stats::SphericalGrid grid;
    grid.cosThetaResolution = 16;
    grid.phiResolution = 32;
    const int n = 200000;
    std::vector<double> observed(grid.cellCount(), 0.0);
    Rng rng(9, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < n; ++i)
        observed[grid.cellOf(octahedralToDirection(Point2f(rng.nextFloat(), rng.nextFloat())))] +=
            1;
    const auto expected = stats::expectedFrequencies(
        grid, [](const Vector3f&) { return 1.0 / (4.0 * M_PI); }, n);
    const auto result = stats::chi2Test(observed, expected, n, 5.0, 0.01);
    EXPECT_TRUE(result.passed) << result.message;
}

// The camera looking along a known direction sees that direction's pixel (nearest lookup).
TEST_F(EnvironmentTest, KnownDirectionsSeeTheirPixels) {
    Image oct(5, 5);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 5; ++x) oct.set(x, y, Color3f(float(x), float(y), 1.0f));
    PropertyList props;
    props.setString("filename", writeMap("oct.exr", oct));
    props.setString("mapping", "octahedral");
    auto light = create("environment", props);
    auto seen = [&](const Vector3f& d) {
        EmitterQueryRecord rec(Point3f(0.3f, 0.2f, 0.1f));
        rec.wi = d.normalized();
        return light->eval(rec);
    };
    auto expectPixel = [&](const Vector3f& d, int x, int y) {
        const Color3f c = seen(d);
        EXPECT_TRUE(c.isApprox(Color3f(float(x), float(y), 1.0f)))
            << d.transpose() << " sees " << c.toString() << ", expected pixel " << x << ", " << y;
    };
    expectPixel(Vector3f(0, 0, 1), 2, 2);
    expectPixel(Vector3f(1, 0, 0), 4, 2);
    expectPixel(Vector3f(-1, 0, 0), 0, 2);
    expectPixel(Vector3f(0, 1, 0), 2, 4);
    expectPixel(Vector3f(0, -1, 0), 2, 0);
    expectPixel(Vector3f(0.01f, 0.01f, -1), 4, 4);
    expectPixel(Vector3f(-0.01f, -0.01f, -1), 0, 0);
    expectPixel(Vector3f(1, 1, 0.02f), 3, 3);

    // Equirect, +y up: row 0 around +y, the middle row at the horizon; -z at the left edge.
    Image lat(8, 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 8; ++x) lat.set(x, y, Color3f(float(x), float(y), 2.0f));
    PropertyList latProps;
    latProps.setString("filename", writeMap("lat.exr", lat));
    // A quarter turn about +y: the light's -z (left edge) is the world's -x.
    latProps.setTransform("toWorld", rotation(90.0f, Vector3f::UnitY()));
    light = create("environment", latProps);
    auto expectLat = [&](const Vector3f& d, int x, int y) {
        const Color3f c = seen(d);
        EXPECT_TRUE(c.isApprox(Color3f(float(x), float(y), 2.0f)))
            << d.transpose() << " sees " << c.toString() << ", expected pixel " << x << ", " << y;
    };
    expectLat(Vector3f(-1, 0, -0.01f), 0, 1);  // light space (-0.01, 0, -1): just left of u = 1
    expectLat(Vector3f(-1, 0, 0.01f), 7, 1);
    expectLat(Vector3f(0, 0, -1), 2, 1);             // light +x: u = 1/4
    expectLat(Vector3f(1, 0, 0), 4, 1);              // light +z: the centre
    expectLat(Vector3f(0.0924f, 1, 0.0383f), 4, 0);  // light phi = 202.5 degrees
    expectLat(Vector3f(0.0924f, -1, 0.0383f), 4, 2);
}

// sample() draws directions with the density pdf() reports, for both mappings, on maps with a
// sun and a gradient, rotated into the world.
TEST_F(EnvironmentTest, SamplingMatchesThePdfByChiSquare) {
    for (const std::string mapping : {"equirect", "octahedral"}) {
        const bool octahedral = mapping == "octahedral";
        const Image map = octahedral ? sunAndGradient(8, 8, 5, 2) : sunAndGradient(16, 8, 11, 2);
        PropertyList props;
        props.setString("filename", writeMap(mapping + ".exr", map));
        props.setString("mapping", mapping);
        props.setTransform("toWorld", rotation(30.0f, Vector3f(1.0f, 2.0f, 0.5f)));
        auto light = create("environment", props);
        stats::SphericalGrid grid;
        grid.cosThetaResolution = 20;
        grid.phiResolution = 40;
        const int n = 500000;
        std::vector<double> observed(grid.cellCount(), 0.0);
        Rng rng(11, 0, 0, StreamPurpose::Test);
        int sunSamples = 0;
        for (int i = 0; i < n; ++i) {
            EmitterQueryRecord rec(Point3f(0.0f, 0.0f, 0.0f));
            const Color3f value = light->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
            ASSERT_GT(rec.pdf, 0.0f) << mapping << " sample " << i << " " << rec.wi.transpose();
            ASSERT_TRUE(value.allFinite());
            observed[grid.cellOf(rec.wi)] += 1;
            sunSamples += light->eval(rec).r() > 1000.0f ? 1 : 0;
        }
        // The sun's share of the mean colour times solid angle is most of the map's.
        EXPECT_GT(sunSamples, n / 4) << mapping;
        auto pdf = [&](const Vector3f& w) {
            EmitterQueryRecord rec(Point3f(0.0f, 0.0f, 0.0f));
            rec.wi = w.normalized();
            return double(light->pdf(rec));
        };
        const auto expected = stats::expectedFrequencies(grid, pdf, n);
        double total = 0.0;
        for (double e : expected) total += e;
        EXPECT_NEAR(total / n, 1.0, 2e-3) << mapping;
        const auto result = stats::chi2Test(observed, expected, n, 5.0, 0.01);
        EXPECT_TRUE(result.passed) << mapping << ": " << result.message;
    }
}

// radiance / pdf returned by sample() is eval() / pdf() of the record; the shadow ray runs to
// infinity; E[L / pdf] is the radiance integrated over the sphere, power() / (pi r^2).
TEST_F(EnvironmentTest, SampleEvalAndPdfAgreeAndIntegrateToThePower) {
    for (const std::string mapping : {"", "equirect", "octahedral"}) {
        PropertyList props;
        if (mapping.empty()) {
            props.setColor("radiance", Color3f(0.5f, 1.0f, 2.0f));
        } else {
            props.setString("mapping", mapping);
            props.setString("filename", writeMap(mapping + ".exr", sunAndGradient(16, 16, 3, 9)));
            props.setFloat("scale", 0.25f);
        }
        auto light = create("environment", props);
        Rng rng(12, 0, 0, StreamPurpose::Test);
        stats::RunningStats integral;
        const Point3f ref(1.0f, 2.0f, -3.0f);
        for (int i = 0; i < 200000; ++i) {
            EmitterQueryRecord rec(ref);
            const Color3f value = light->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
            ASSERT_GT(rec.pdf, 0.0f);
            ASSERT_NEAR(rec.wi.norm(), 1.0f, 1e-5f);
            ASSERT_EQ(rec.shadowRay.maxt, Infinity);
            ASSERT_TRUE(rec.shadowRay.o.isApprox(ref));
            ASSERT_NEAR(light->pdf(rec), rec.pdf, 1e-6f * rec.pdf);
            const Color3f expected = light->eval(rec) / light->pdf(rec);
            ASSERT_TRUE(value.isApprox(expected, 1e-6f)) << value.toString();
            integral.add(value.g());
        }
        // power() = pi r^2 * integral of L over the sphere (r = 3 here).
        const double expected = light->power().g() / (M_PI * 9.0);
        EXPECT_NEAR(integral.mean, expected, 5.0 * integral.standardError() + 1e-6 * expected)
            << mapping;
        if (mapping.empty()) {
            EXPECT_NEAR(expected, 4.0 * M_PI, 1e-5);
            EXPECT_EQ(integral.standardError(), 0.0);  // uniform sampling of a constant
        } else {
            // The exact sum of pixel radiance times pixel solid angle, green channel.
            const Image map = sunAndGradient(16, 16, 3, 9);
            double sum = 0.0;
            for (int y = 0; y < 16; ++y)
                for (int x = 0; x < 16; ++x) {
                    const double omega =
                        mapping == "octahedral"
                            ? 4.0 * M_PI / 256.0
                            : 2.0 * M_PI / 16.0 *
                                  (std::cos(M_PI * y / 16.0) - std::cos(M_PI * (y + 1) / 16.0));
                    sum += 0.25 * map.get(x, y).g() * omega;
                }
            EXPECT_NEAR(expected, sum, 1e-5 * sum) << mapping;
        }
    }
}

// `illuminance` rescales the map so that a surface facing +z receives it: pi Y(L) for a constant,
// and for a map the cosine-weighted luminance over the upper hemisphere, estimated here by
// sampling the light.
TEST_F(EnvironmentTest, IlluminanceRescalesTheMap) {
    PropertyList constant;
    constant.setColor("radiance", Color3f(1.0f, 2.0f, 3.0f));
    constant.setFloat("illuminance", 10.0f);
    auto light = create("environment", constant);
    EmitterQueryRecord rec(Point3f::Zero());
    rec.wi = Vector3f::UnitZ();
    const Color3f expected =
        Color3f(1.0f, 2.0f, 3.0f) * (10.0f / (Pi * Color3f(1, 2, 3).luminance()));
    EXPECT_TRUE(light->eval(rec).isApprox(expected, 1e-5f)) << light->eval(rec).toString();

    for (const std::string mapping : {"equirect", "octahedral"}) {
        Image map(64, 64);
        for (int y = 0; y < 64; ++y)
            for (int x = 0; x < 64; ++x)
                map.set(x, y, Color3f(1.0f + x / 16.0f, 0.5f, 2.0f - y / 40.0f));
        PropertyList props;
        props.setString("mapping", mapping);
        props.setString("filename", writeMap(mapping + ".exr", map));
        props.setFloat("scale", 0.5f);  // still multiplies, as in pbrt-v4
        props.setFloat("illuminance", 6.0f);
        light = create("environment", props);
        Rng rng(13, 0, 0, StreamPurpose::Test);
        stats::RunningStats illuminance;
        for (int i = 0; i < 400000; ++i) {
            EmitterQueryRecord r(Point3f::Zero());
            const Color3f value = light->sample(r, Point2f(rng.nextFloat(), rng.nextFloat()));
            illuminance.add(r.wi.z() > 0.0f ? value.luminance() * r.wi.z() : 0.0f);
        }
        // 5 standard errors plus the midpoint rule's error on 64^2 pixels (well under 0.5%).
        EXPECT_NEAR(illuminance.mean, 3.0, 5.0 * illuminance.standardError() + 0.015) << mapping;
        EXPECT_LT(illuminance.standardError(), 0.01);
    }
}

// Photons start outside the bounding sphere, travel into it, and their mean flux is power().
TEST_F(EnvironmentTest, PhotonsEnterTheSceneAndSumToPower) {
    PropertyList props;
    props.setString("mapping", "octahedral");
    props.setString("filename", writeMap("photons.exr", sunAndGradient(8, 8, 6, 1)));
    auto light = create("environment", props);
    const Point3f centre(0.5f, -1.0f, 2.0f);
    const float radius = 3.0f;
    Rng rng(14, 0, 0, StreamPurpose::Test);
    stats::RunningStats flux;
    for (int i = 0; i < 200000; ++i) {
        Ray3f ray;
        const Color3f f = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                              Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_TRUE(f.allFinite());
        const Vector3f d = ray.d.normalized();
        const Vector3f offset = ray.o - centre;
        // On the disk that touches the sphere where the light comes from, facing it.
        ASSERT_NEAR(offset.dot(-d), radius, 1e-4f * radius);
        ASSERT_LE((offset - offset.dot(d) * d).norm(), radius * (1.0f + 1e-5f));
        flux.add(f.b());
    }
    EXPECT_NEAR(flux.mean, light->power().b(), 5.0 * flux.standardError());
}

TEST(DirectionalLight, SamplesAndPhotons) {
    PropertyList props;
    props.setColor("irradiance", Color3f(2.0f, 3.0f, 4.0f));
    props.setVector("direction", Vector3f(0.0f, 0.0f, -2.0f));
    props.setTransform("toWorld", rotation(90.0f, Vector3f::UnitX()));  // -z becomes +y
    auto light = create("directional", props);
    EXPECT_TRUE(light->isDelta());
    EXPECT_TRUE(light->isInfinite());
    EmitterQueryRecord rec(Point3f(1.0f, 1.0f, 1.0f));
    const Color3f value = light->sample(rec, Point2f(0.3f, 0.7f));
    EXPECT_TRUE(value.isApprox(Color3f(2.0f, 3.0f, 4.0f)));
    EXPECT_EQ(rec.pdf, 1.0f);
    EXPECT_TRUE(rec.wi.isApprox(Vector3f(0.0f, -1.0f, 0.0f), 1e-6f)) << rec.wi.transpose();
    EXPECT_EQ(rec.shadowRay.maxt, Infinity);
    EXPECT_EQ(light->pdf(rec), 0.0f);
    EXPECT_TRUE(light->eval(rec).isZero());
    const float area = Pi * 9.0f;
    EXPECT_TRUE(light->power().isApprox(area * Color3f(2.0f, 3.0f, 4.0f)));
    Rng rng(15, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 1000; ++i) {
        Ray3f ray;
        const Color3f f = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                              Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_TRUE(f.isApprox(light->power()));
        ASSERT_TRUE(ray.d.normalized().isApprox(Vector3f(0.0f, 1.0f, 0.0f), 1e-6f));
        ASSERT_NEAR(ray.o.y(), -1.0f - 3.0f, 1e-5f);
        ASSERT_LE(Vector2f(ray.o.x() - 0.5f, ray.o.z() - 2.0f).norm(), 3.0f + 1e-5f);
    }
}

TEST_F(EnvironmentTest, ClearErrors) {
    auto expectError = [&](const std::string& type, const PropertyList& props,
                           const std::string& expected) {
        try {
            create(type, props);
            ADD_FAILURE() << "accepted: " << expected;
        } catch (const Error& e) {
            EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
        }
    };
    const std::string square = writeMap("square.exr", sunAndGradient(4, 4, 1, 1));
    const std::string wide = writeMap("wide.exr", sunAndGradient(8, 4, 1, 1));
    PropertyList both("here.xml:3");
    both.setColor("radiance", Color3f(1.0f));
    both.setString("filename", square);
    expectError("environment", both, "here.xml:3: give either \"radiance\" or \"filename\"");
    PropertyList notSquare;
    notSquare.setString("filename", wide);
    notSquare.setString("mapping", "octahedral");
    expectError("environment", notSquare, "must be square");
    PropertyList mapping;
    mapping.setString("mapping", "cube");
    expectError("environment", mapping, "\"mapping\" must be");
    PropertyList missing;
    missing.setString("filename", (m_dir / "none.exr").string());
    expectError("environment", missing, "does not exist");
    PropertyList sheared;
    Matrix4f m = Matrix4f::Identity();
    m(0, 1) = 0.5f;
    sheared.setTransform("toWorld", Transform(m));
    expectError("environment", sheared, "\"toWorld\" must be a rotation");
    PropertyList dark;
    dark.setColor("radiance", Color3f(0.0f));
    dark.setFloat("illuminance", 1.0f);
    expectError("environment", dark, "\"illuminance\"");
    PropertyList noDirection;
    noDirection.setVector("direction", Vector3f::Zero());
    expectError("directional", noDirection, "\"direction\"");
    // A uniform scale in toWorld does not matter; pbrt's mirrored maps (scale -1 1 1) are fine.
    PropertyList mirrored;
    Matrix4f mirror = Matrix4f::Identity() * 2.0f;
    mirror(0, 0) = -2.0f;
    mirror(3, 3) = 1.0f;
    mirrored.setTransform("toWorld", Transform(mirror));
    EXPECT_NO_THROW(create("environment", mirrored));
}

}  // namespace
}  // namespace alphorn
