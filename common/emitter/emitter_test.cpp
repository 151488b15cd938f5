// Unit tests of the area and point emitters against closed forms: the solid angle of a
// rectangle, pi * A * L for the power of a Lambertian emitter, the inverse-square law, and the
// moments of cosine-weighted and uniform photon directions. Fixed seeds, 5-sigma tolerances.
#include "common/emitter/emitter.h"
#include "common/core/rng.h"
#include "common/scene/mesh.h"

#include "common/stats/student_t.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

namespace alphorn {
namespace {

// The quad [-1, 1]^2 in the xz plane at y = 0 with normal +y, carrying an area light.
std::shared_ptr<Mesh> makeQuadLight(const Color3f& radiance, bool twoSided = false) {
    PropertyList meshProps;
    meshProps.setString("filename", sourcePath("scenes/meshes/quad.obj"));
    auto mesh =
        std::static_pointer_cast<Mesh>(ObjectFactory::create(ObjectKind::Mesh, "obj", meshProps));
    PropertyList lightProps;
    lightProps.setColor("radiance", radiance);
    if (twoSided) lightProps.setBoolean("twoSided", true);
    auto light = ObjectFactory::create(ObjectKind::Emitter, "area", lightProps);
    light->activate();
    mesh->addChild(light, "");
    mesh->activate();
    return mesh;
}

std::shared_ptr<Emitter> makePointLight(const Point3f& position, const Color3f& power) {
    PropertyList props;
    props.setPoint("position", position);
    props.setColor("power", power);
    auto light = std::static_pointer_cast<Emitter>(
        ObjectFactory::create(ObjectKind::Emitter, "point", props));
    light->activate();
    return light;
}

// Solid angle of the rectangle [x1,x2] x [z1,z2] (in the plane y = 0) seen from (px, h, pz).
double rectangleSolidAngle(double x1, double x2, double z1, double z2, double px, double h,
                           double pz) {
    auto f = [&](double a, double b) {
        a -= px;
        b -= pz;
        return std::atan(a * b / (h * std::sqrt(h * h + a * a + b * b)));
    };
    return f(x2, z2) - f(x1, z2) - f(x2, z1) + f(x1, z1);
}

TEST(AreaLight, SampleAndPdfAgreeAndIntegrateTheSolidAngle) {
    auto mesh = makeQuadLight(Color3f(2.0f, 1.0f, 0.5f));
    const Emitter& light = *mesh->emitter();
    const Point3f ref(0.3f, 1.5f, -0.2f);
    Rng rng(3, 0, 0, StreamPurpose::Test);
    stats::RunningStats estimate;
    for (int i = 0; i < 200000; ++i) {
        EmitterQueryRecord rec(ref);
        const Color3f value = light.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_GT(rec.pdf, 0.0f);
        // The point lies on the quad, the record is consistent, and pdf() recomputes rec.pdf.
        ASSERT_NEAR(rec.p.y(), 0.0f, 1e-6f);
        ASSERT_LE(std::abs(rec.p.x()), 1.0f + 1e-6f);
        ASSERT_NEAR((rec.wi - (rec.p - ref).normalized()).norm(), 0.0f, 1e-5f);
        ASSERT_NEAR(light.pdf(rec), rec.pdf, 1e-5f * rec.pdf);
        ASSERT_NEAR(value.r(), light.eval(rec).r() / rec.pdf, 1e-5f * value.r());
        // The shadow ray ends just short of the light.
        ASSERT_NEAR(rec.shadowRay.maxt, (rec.p - ref).norm() - Epsilon, 1e-5f);
        // Radiance / pdf in the green channel, whose radiance is 1: E[L/pdf] = L * Omega.
        estimate.add(value.g());
    }
    const double omega = rectangleSolidAngle(-1, 1, -1, 1, 0.3, 1.5, -0.2);
    EXPECT_NEAR(estimate.mean, 1.0 * omega, 5.0 * estimate.standardError());
    EXPECT_GT(estimate.standardError(), 0.0);
}

TEST(AreaLight, IsOneSided) {
    auto mesh = makeQuadLight(Color3f(1.0f));
    const Emitter& light = *mesh->emitter();
    Rng rng(5, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 1000; ++i) {
        EmitterQueryRecord rec(Point3f(0.1f, -2.0f, 0.4f));
        EXPECT_TRUE(light.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).isBlack());
        EXPECT_EQ(light.pdf(rec), 0.0f);
        EXPECT_TRUE(light.eval(rec).isBlack());
    }
    // Seen from above, the same point emits.
    EmitterQueryRecord front(Point3f(0.0f, 1.0f, 0.0f), Point3f(0.2f, 0.0f, 0.1f),
                             Normal3f(0, 1, 0));
    EXPECT_EQ(light.eval(front).r(), 1.0f);
    EmitterQueryRecord back(Point3f(0.0f, -1.0f, 0.0f), Point3f(0.2f, 0.0f, 0.1f),
                            Normal3f(0, 1, 0));
    EXPECT_EQ(light.eval(back).r(), 0.0f);
}

TEST(AreaLight, GrazingAndCoincidentSamplesAreFinite) {
    auto mesh = makeQuadLight(Color3f(1.0f));
    const Emitter& light = *mesh->emitter();
    Rng rng(9, 0, 0, StreamPurpose::Test);
    // In the plane of the light (every sample edge-on) and on the light itself.
    for (const Point3f& ref : {Point3f(3.0f, 0.0f, 0.0f), Point3f(0.0f, 0.0f, 0.0f)}) {
        for (int i = 0; i < 1000; ++i) {
            EmitterQueryRecord rec(ref);
            const Color3f v = light.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
            EXPECT_TRUE(v.allFinite());
            EXPECT_TRUE(std::isfinite(rec.pdf));
        }
    }
}

TEST(AreaLight, PowerIsPiAreaRadianceAndPhotonsAreCosineDistributed) {
    auto mesh = makeQuadLight(Color3f(1.0f, 2.0f, 3.0f));
    const Emitter& light = *mesh->emitter();
    // Area 4: Phi = pi * 4 * L.
    EXPECT_NEAR(light.power().g(), Pi * 4.0f * 2.0f, 1e-4f);
    Rng rng(21, 0, 0, StreamPurpose::Test);
    stats::RunningStats flux, cosine, x;
    for (int i = 0; i < 100000; ++i) {
        Ray3f ray;
        const Color3f phi = light.samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                               Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_NEAR(ray.o.y(), 0.0f, 1e-6f);
        ASSERT_GT(ray.d.y(), 0.0f);  // one-sided emission
        flux.add(phi.g());
        cosine.add(ray.d.y());
        x.add(ray.o.x());
    }
    // Photon fluxes average to the power; a cosine (Lambertian) emitter has E[cos] = 2/3;
    // positions are uniform over [-1, 1], so E[x] = 0.
    EXPECT_NEAR(flux.mean, light.power().g(), 5.0 * flux.standardError() + 1e-4);
    EXPECT_NEAR(cosine.mean, 2.0 / 3.0, 5.0 * cosine.standardError());
    EXPECT_NEAR(x.mean, 0.0, 5.0 * x.standardError());
}

// pbrt-v4's two-sided area light: both sides emit the radiance, the power doubles, light samples
// from behind have the density the front's have, and photons leave both sides in equal numbers,
// cosine-distributed about the side's normal.
TEST(AreaLight, TwoSidedEmitsOnBothSides) {
    auto mesh = makeQuadLight(Color3f(1.0f, 2.0f, 3.0f), true);
    const Emitter& light = *mesh->emitter();
    EXPECT_NEAR(light.power().g(), 2.0f * Pi * 4.0f * 2.0f, 1e-4f);
    EmitterQueryRecord front(Point3f(0.0f, 1.0f, 0.0f), Point3f(0.2f, 0.0f, 0.1f),
                             Normal3f(0, 1, 0));
    EmitterQueryRecord back(Point3f(0.0f, -1.0f, 0.0f), Point3f(0.2f, 0.0f, 0.1f),
                            Normal3f(0, 1, 0));
    EXPECT_EQ(light.eval(front).g(), 2.0f);
    EXPECT_EQ(light.eval(back).g(), 2.0f);
    EXPECT_GT(light.pdf(back), 0.0f);
    EXPECT_FLOAT_EQ(light.pdf(back), light.pdf(front));
    // Sampled from below, the light integrates its solid angle like from above.
    const double omega = rectangleSolidAngle(-1, 1, -1, 1, 0.3, 1.5, -0.2);
    Rng rng(17, 0, 0, StreamPurpose::Test);
    stats::RunningStats estimate, below, cosine;
    for (int i = 0; i < 20000; ++i) {
        EmitterQueryRecord rec(Point3f(0.3f, -1.5f, -0.2f));
        estimate.add(light.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).r());
    }
    EXPECT_NEAR(estimate.mean, omega, 5.0 * estimate.standardError());
    for (int i = 0; i < 100000; ++i) {
        Ray3f ray;
        const Color3f phi = light.samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                               Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_EQ(phi.g(), light.power().g());
        below.add(ray.d.y() < 0.0f ? 1.0 : 0.0);
        cosine.add(std::abs(ray.d.y()));
    }
    EXPECT_NEAR(below.mean, 0.5, 5.0 * below.standardError());
    EXPECT_NEAR(cosine.mean, 2.0 / 3.0, 5.0 * cosine.standardError());
}

// A light of zero area (here one degenerate triangle) loads, with a warning: it emits nothing.
// Its power is 0 (never chosen by power), and its light samples carry nothing with density 0,
// so uniform light selection stays unbiased. Refusing it refused a scene that renders.
TEST(AreaLight, OfZeroAreaLoadsAndEmitsNothing) {
    const std::string obj = ::testing::TempDir() + "alphorn_zero_area_light.obj";
    std::ofstream(obj) << "v 0 1 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\n";
    PropertyList meshProps;
    meshProps.setString("filename", obj);
    auto mesh =
        std::static_pointer_cast<Mesh>(ObjectFactory::create(ObjectKind::Mesh, "obj", meshProps));
    PropertyList lightProps;
    lightProps.setColor("radiance", Color3f(1.0f));
    auto light = ObjectFactory::create(ObjectKind::Emitter, "area", lightProps);
    light->activate();
    mesh->addChild(light, "");
    EXPECT_NO_THROW(mesh->activate());
    EXPECT_EQ(mesh->surfaceArea(), 0.0f);
    const Emitter& emitter = *mesh->emitter();
    EXPECT_TRUE(emitter.power().isZero());
    Rng rng(11, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < 100; ++i) {
        EmitterQueryRecord rec(Point3f(0.3f, 0.0f, 0.2f));
        const Color3f value = emitter.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
        EXPECT_TRUE(value.isZero());
        EXPECT_EQ(rec.pdf, 0.0f);
    }
    std::remove(obj.c_str());
}

TEST(AreaLight, RejectsMissingRadiance) {
    PropertyList props;
    EXPECT_THROW(ObjectFactory::create(ObjectKind::Emitter, "area", props), Error);
}

TEST(PointLight, InverseSquareLawAndDelta) {
    auto light = makePointLight(Point3f(1.0f, 2.0f, 3.0f), Color3f(4.0f * Pi));
    EXPECT_TRUE(light->isDelta());
    EmitterQueryRecord rec(Point3f(1.0f, 2.0f, 1.0f));  // 2 units below along z
    const Color3f value = light->sample(rec, Point2f(0.5f, 0.5f));
    // Intensity = power / 4pi = 1; irradiance-carrying radiance / pdf = I / d^2 = 1/4.
    EXPECT_NEAR(value.r(), 0.25f, 1e-6f);
    EXPECT_EQ(rec.pdf, 1.0f);
    EXPECT_NEAR((rec.wi - Vector3f(0, 0, 1)).norm(), 0.0f, 1e-6f);
    EXPECT_NEAR(rec.shadowRay.maxt, 2.0f - Epsilon, 1e-6f);
    EXPECT_EQ(light->pdf(rec), 0.0f);
    EXPECT_TRUE(light->eval(rec).isBlack());
    // At the light's own position: no direction, no NaN.
    EmitterQueryRecord at(Point3f(1.0f, 2.0f, 3.0f));
    EXPECT_TRUE(light->sample(at, Point2f(0.5f, 0.5f)).isBlack());
}

TEST(PointLight, PhotonsCarryThePowerUniformly) {
    auto light = makePointLight(Point3f(0.0f, 1.0f, 0.0f), Color3f(5.0f, 6.0f, 7.0f));
    EXPECT_EQ(light->power().b(), 7.0f);
    Rng rng(23, 0, 0, StreamPurpose::Test);
    stats::RunningStats flux, dx, dy, dz, z2;
    for (int i = 0; i < 100000; ++i) {
        Ray3f ray;
        const Color3f phi = light->samplePhoton(ray, Point2f(rng.nextFloat(), rng.nextFloat()),
                                                Point2f(rng.nextFloat(), rng.nextFloat()));
        ASSERT_EQ(ray.o, Point3f(0.0f, 1.0f, 0.0f));
        ASSERT_NEAR(ray.d.norm(), 1.0f, 1e-5f);
        flux.add(phi.b());
        dx.add(ray.d.x());
        dy.add(ray.d.y());
        dz.add(ray.d.z());
        z2.add(ray.d.z() * ray.d.z());
    }
    EXPECT_NEAR(flux.mean, 7.0, 5.0 * flux.standardError() + 1e-5);
    // Uniform on the sphere: zero mean direction and E[z^2] = 1/3.
    EXPECT_NEAR(dx.mean, 0.0, 5.0 * dx.standardError());
    EXPECT_NEAR(dy.mean, 0.0, 5.0 * dy.standardError());
    EXPECT_NEAR(dz.mean, 0.0, 5.0 * dz.standardError());
    EXPECT_NEAR(z2.mean, 1.0 / 3.0, 5.0 * z2.standardError());
}

}  // namespace
}  // namespace alphorn
