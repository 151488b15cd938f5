// Unit tests of the mirror, dielectric and microfacet BSDFs and the shared Fresnel term. Every
// expected value comes from a closed form or an independent computation, never from the code
// under test; Monte Carlo checks use fixed seeds and tolerances of 5 standard errors.
#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/core/frame.h"
#include "common/core/rng.h"
#include "common/core/warp.h"

#include "common/stats/student_t.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

std::shared_ptr<BSDF> makeBSDF(const std::string& type,
                               const PropertyList& props = PropertyList()) {
    auto bsdf =
        std::static_pointer_cast<BSDF>(ObjectFactory::create(ObjectKind::BSDF, type, props));
    bsdf->activate();
    return bsdf;
}

Vector3f directionAt(float thetaDeg, float phi = 0.3f) {
    return sphericalDirection(degToRad(thetaDeg), phi);
}

// Fresnel reflectance by the textbook sine/tangent forms in double precision: a different
// formula from the cosine form used by the code.
double fresnelReference(double thetaI, double n1, double n2) {
    if (thetaI == 0.0) return std::pow((n1 - n2) / (n1 + n2), 2);
    const double sinT = n1 / n2 * std::sin(thetaI);
    if (sinT >= 1.0) return 1.0;
    const double thetaT = std::asin(sinT);
    const double rs = std::pow(std::sin(thetaI - thetaT) / std::sin(thetaI + thetaT), 2);
    const double rp = std::pow(std::tan(thetaI - thetaT) / std::tan(thetaI + thetaT), 2);
    return 0.5 * (rs + rp);
}

bool equal(const Color3f& a, const Color3f& b) {
    return (a == b).all();
}

// Glass of index 1.5 in air met from outside and from inside at angles from normal to grazing:
// the direction towards the camera, the indices on each side and the reference Fresnel
// reflectance.
struct GlassIncidence {
    float degrees;
    bool inside;
    Vector3f wi;
    double n1, n2, reflectance;
};
std::vector<GlassIncidence> glassIncidences() {
    std::vector<GlassIncidence> cases;
    for (float deg : {0.0f, 20.0f, 40.0f, 60.0f, 85.0f}) {
        for (bool inside : {false, true}) {
            Vector3f wi = directionAt(deg);
            if (inside) wi.z() = -wi.z();
            const double n1 = inside ? 1.5 : 1.0, n2 = inside ? 1.0 : 1.5;
            cases.push_back({deg, inside, wi, n1, n2, fresnelReference(degToRad(deg), n1, n2)});
        }
    }
    return cases;
}

TEST(Fresnel, NormalIncidenceMatchesClosedForm) {
    const float n1 = 1.000277f, n2 = 1.5046f;
    const float expected = ((n1 - n2) / (n1 + n2)) * ((n1 - n2) / (n1 + n2));
    EXPECT_NEAR(fresnelDielectric(1.0f, n1, n2), expected, 1e-6f);
    // From inside, the reflectance at normal incidence is the same.
    EXPECT_NEAR(fresnelDielectric(-1.0f, n1, n2), expected, 1e-6f);
    EXPECT_NEAR(fresnelDielectric(1.0f, 1.0f, 1.5f), 0.04f, 1e-6f);
}

TEST(Fresnel, MatchesSineTangentFormsOutsideAndInside) {
    for (double deg : {10.0, 30.0, 45.0, 60.0, 80.0, 89.0}) {
        const double theta = deg * M_PI / 180.0;
        EXPECT_NEAR(fresnelDielectric(float(std::cos(theta)), 1.0f, 1.5f),
                    fresnelReference(theta, 1.0, 1.5), 2e-5)
            << deg;
        // Arriving from inside: indices swap (and beyond ~41.8 degrees the reference gives TIR).
        EXPECT_NEAR(fresnelDielectric(float(-std::cos(theta)), 1.0f, 1.5f),
                    fresnelReference(theta, 1.5, 1.0), 2e-5)
            << deg;
    }
}

TEST(Fresnel, TotalInternalReflectionBeyondCriticalAngle) {
    const float critical = std::asin(1.0f / 1.5f);
    EXPECT_EQ(fresnelDielectric(-std::cos(critical + 0.01f), 1.0f, 1.5f), 1.0f);
    EXPECT_EQ(fresnelDielectric(-std::cos(critical + 0.5f), 1.0f, 1.5f), 1.0f);
    EXPECT_LT(fresnelDielectric(-std::cos(critical - 0.01f), 1.0f, 1.5f), 1.0f);
    // Index-matched: no interface, no reflection; grazing from the outside: all reflected.
    EXPECT_EQ(fresnelDielectric(0.3f, 1.33f, 1.33f), 0.0f);
    EXPECT_NEAR(fresnelDielectric(0.0f, 1.0f, 1.5f), 1.0f, 1e-6f);
}

TEST(Mirror, ReflectsWithUnitWeightAndIsBlackBehind) {
    auto mirror = makeBSDF("mirror");
    BSDFQueryRecord rec(directionAt(35.0f));
    EXPECT_TRUE(equal(mirror->sample(rec, Point2f(0.5f, 0.5f)), Color3f(1.0f)));
    EXPECT_EQ(rec.measure, Measure::Discrete);
    EXPECT_NEAR((rec.wo - directionAt(35.0f, 0.3f + Pi)).norm(), 0.0f, 1e-6f);
    EXPECT_TRUE(equal(mirror->eval(rec), Color3f(0.0f)));
    EXPECT_EQ(mirror->pdf(rec), 0.0f);
    BSDFQueryRecord below(Vector3f(0.0f, 0.6f, -0.8f));
    EXPECT_TRUE(mirror->sample(below, Point2f(0.5f, 0.5f)).isBlack());
    EXPECT_FALSE(mirror->isDiffuse());
}

TEST(Dielectric, DefaultsAreNoris) {
    // With Nori's defaults the normal-incidence reflectance is ((1.000277-1.5046)/(2.504877))^2.
    auto glass = makeBSDF("dielectric");
    const double expected = std::pow((1.000277 - 1.5046) / (1.000277 + 1.5046), 2);
    int reflected = 0;
    const int n = 100000;
    for (int i = 0; i < n; ++i) {
        BSDFQueryRecord rec(Vector3f(0.0f, 0.0f, 1.0f));
        glass->sample(rec, Point2f((i + 0.5f) / n, 0.5f));
        if (rec.wo.z() > 0.0f) ++reflected;
    }
    EXPECT_NEAR(reflected / double(n), expected, 2.0 / n);
}

// Every sample is either a reflection or a refraction (the probabilities sum to 1, nothing is
// absorbed), reflection happens with probability F, refraction obeys Snell's law, and the
// weights are 1 (reflection) and 1/eta^2 (refraction, radiance scaling).
TEST(Dielectric, ReflectRefractProbabilitiesAndDirections) {
    PropertyList props;
    props.setFloat("intIOR", 1.5f);
    props.setFloat("extIOR", 1.0f);
    auto glass = makeBSDF("dielectric", props);
    for (const auto& [deg, inside, wi, n1, n2, F] : glassIncidences()) {
        const int n = 20000;
        int reflected = 0, refracted = 0;
        for (int i = 0; i < n; ++i) {
            BSDFQueryRecord rec(wi);
            const Color3f w = glass->sample(rec, Point2f((i + 0.5f) / n, 0.37f));
            ASSERT_TRUE(w.allFinite());
            ASSERT_NEAR(rec.wo.norm(), 1.0f, 1e-5f);
            EXPECT_EQ(rec.measure, Measure::Discrete);
            if (rec.wo.z() * wi.z() > 0.0f) {
                ++reflected;
                EXPECT_TRUE(equal(w, Color3f(1.0f)));
                EXPECT_NEAR((rec.wo - Vector3f(-wi.x(), -wi.y(), wi.z())).norm(), 0.0f, 1e-6f);
            } else {
                ++refracted;
                const float eta = float(n2 / n1);
                EXPECT_NEAR(rec.eta, eta, 1e-6f);
                EXPECT_NEAR(w.r(), 1.0f / (eta * eta), 1e-5f);
                // Snell: n1 sin(theta_i) = n2 sin(theta_t), in the plane of incidence.
                EXPECT_NEAR(n1 * Frame::sinTheta(wi), n2 * Frame::sinTheta(rec.wo), 1e-5);
                EXPECT_NEAR(rec.wo.x() * wi.y() - rec.wo.y() * wi.x(), 0.0f, 1e-6f);
                EXPECT_LT(rec.wo.x() * wi.x() + rec.wo.y() * wi.y(), 1e-6f);
            }
        }
        EXPECT_EQ(reflected + refracted, n);
        EXPECT_NEAR(reflected / double(n), F, 2.0 / n) << deg << (inside ? " inside" : "");
    }
}

// deltaLobes() lists what sample() chooses among: the reflection with weight F, the refraction
// with (1 - F) / eta² and sample()'s direction and eta; under total internal reflection only the
// reflection, with weight 1. Other BSDFs have none.
TEST(Dielectric, DeltaLobesAreSampleChoicesWithTheirChance) {
    PropertyList props;
    props.setFloat("intIOR", 1.5f);
    props.setFloat("extIOR", 1.0f);
    auto glass = makeBSDF("dielectric", props);
    for (const auto& [deg, inside, wi, n1, n2, F] : glassIncidences()) {
        DeltaLobe lobes[BSDF::kMaxDeltaLobes];
        const int count = glass->deltaLobes(BSDFQueryRecord(wi), lobes);
        BSDFQueryRecord reflected(wi), refracted(wi);
        glass->sample(reflected, Point2f(0.0f, 0.5f));
        const Color3f refractedWeight = glass->sample(refracted, Point2f(0.99999f, 0.5f));
        if (F >= 1.0) {
            ASSERT_EQ(count, 1) << deg;
        } else {
            ASSERT_EQ(count, 2) << deg << (inside ? " inside" : "");
            EXPECT_EQ(lobes[1].wo, refracted.wo);
            EXPECT_EQ(lobes[1].eta, refracted.eta);
            EXPECT_NEAR(lobes[1].weight.r(), (1.0 - F) * refractedWeight.r(), 1e-6);
        }
        EXPECT_EQ(lobes[0].wo, reflected.wo);
        EXPECT_EQ(lobes[0].eta, 1.0f);
        EXPECT_NEAR(lobes[0].weight.r(), F, 1e-6) << deg;
    }
    // Beyond the critical angle from inside: reflection only.
    Vector3f wi = directionAt(60.0f);
    wi.z() = -wi.z();
    DeltaLobe lobes[BSDF::kMaxDeltaLobes];
    ASSERT_EQ(glass->deltaLobes(BSDFQueryRecord(wi), lobes), 1);
    EXPECT_EQ(lobes[0].weight.r(), 1.0f);
    EXPECT_EQ(makeBSDF("mirror", PropertyList())->deltaLobes(BSDFQueryRecord(wi), lobes), 0);
}

TEST(Dielectric, TotalInternalReflectionAlwaysReflects) {
    PropertyList props;
    props.setFloat("intIOR", 1.5f);
    props.setFloat("extIOR", 1.0f);
    auto glass = makeBSDF("dielectric", props);
    // 45 degrees inside glass of index 1.5 is beyond the critical angle of 41.8 degrees.
    Vector3f wi = directionAt(45.0f);
    wi.z() = -wi.z();
    for (float u : {0.0f, 0.5f, 0.99999994f}) {
        BSDFQueryRecord rec(wi);
        EXPECT_TRUE(equal(glass->sample(rec, Point2f(u, 0.5f)), Color3f(1.0f)));
        EXPECT_LT(rec.wo.z(), 0.0f);
        EXPECT_EQ(rec.eta, 1.0f);
    }
}

TEST(Dielectric, RejectsNonPositiveIndices) {
    PropertyList props;
    props.setFloat("intIOR", 0.0f);
    EXPECT_THROW(makeBSDF("dielectric", props), Error);
}

PropertyList microfacetProps(float alpha, const Color3f& kd) {
    PropertyList props;
    props.setFloat("alpha", alpha);
    props.setColor("kd", kd);
    return props;
}

TEST(Microfacet, EvalIsReciprocal) {
    auto bsdf = makeBSDF("microfacet", microfacetProps(0.3f, Color3f(0.2f, 0.4f, 0.1f)));
    Rng rng(7, 0, 0, StreamPurpose::Test);
    int nonzero = 0;
    for (int i = 0; i < 1000; ++i) {
        const Vector3f a =
            warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        const Vector3f b =
            warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        const Color3f fab = bsdf->eval(BSDFQueryRecord(a, b, Measure::SolidAngle));
        const Color3f fba = bsdf->eval(BSDFQueryRecord(b, a, Measure::SolidAngle));
        ASSERT_TRUE(fab.allFinite());
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(fab[c], fba[c], 1e-5f * std::max(1.0f, fab[c]));
        if (fab.maxCoeff() > 0.0f) ++nonzero;
    }
    EXPECT_GT(nonzero, 900);
}

TEST(Microfacet, MatchesCookTorranceWithBeckmannAndSmith) {
    // An independent evaluation at one configuration: kd/pi + ks D F G / (4 cos_i cos_o) with
    // D = exp(-tan^2/alpha^2) / (pi alpha^2 cos^4) and the rational G1 written out here.
    const float alpha = 0.25f;
    auto bsdf = makeBSDF("microfacet", microfacetProps(alpha, Color3f(0.3f)));
    const Vector3f wi = directionAt(30.0f, 0.0f), wo = directionAt(50.0f, Pi * 0.8f);
    const Vector3f h = (wi + wo).normalized();
    const double cosH = h.z(), tan2H = (1.0 - cosH * cosH) / (cosH * cosH);
    const double D =
        std::exp(-tan2H / (alpha * alpha)) / (M_PI * alpha * alpha * std::pow(cosH, 4));
    auto g1 = [&](const Vector3f& v) {
        const double b = 1.0 / (alpha * std::tan(std::acos(double(v.z()))));
        return b < 1.6 ? (3.535 * b + 2.181 * b * b) / (1.0 + 2.276 * b + 2.577 * b * b) : 1.0;
    };
    const double theta = std::acos(double(wi.dot(h)));
    const double F = fresnelReference(theta, 1.000277, 1.5046);
    const double expected = 0.3 / M_PI + 0.7 * D * F * g1(wi) * g1(wo) / (4.0 * wi.z() * wo.z());
    const Color3f f = bsdf->eval(BSDFQueryRecord(wi, wo, Measure::SolidAngle));
    EXPECT_NEAR(f.r(), expected, 1e-4 * expected);
    // Below the surface, or with the wrong measure, the BRDF is zero.
    EXPECT_TRUE(
        bsdf->eval(BSDFQueryRecord(wi, Vector3f(0, 0.6f, -0.8f), Measure::SolidAngle)).isBlack());
    EXPECT_TRUE(bsdf->eval(BSDFQueryRecord(wi, wo, Measure::Discrete)).isBlack());
}

TEST(Microfacet, SampleWeightIsEvalCosOverPdf) {
    auto bsdf = makeBSDF("microfacet", microfacetProps(0.2f, Color3f(0.4f, 0.3f, 0.2f)));
    Rng rng(11, 0, 0, StreamPurpose::Test);
    for (float deg : {0.0f, 30.0f, 60.0f, 85.0f}) {
        int valid = 0;
        for (int i = 0; i < 2000; ++i) {
            BSDFQueryRecord rec(directionAt(deg));
            const Color3f w = bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
            ASSERT_TRUE(w.allFinite());
            if (w.isBlack()) continue;
            ++valid;
            EXPECT_EQ(rec.measure, Measure::SolidAngle);
            const float pdf = bsdf->pdf(rec);
            ASSERT_GT(pdf, 0.0f);
            const Color3f expected = bsdf->eval(rec) * Frame::cosTheta(rec.wo) / pdf;
            for (int c = 0; c < 3; ++c) EXPECT_NEAR(w[c], expected[c], 1e-4f * expected[c]);
        }
        EXPECT_GT(valid, 1500) << deg;
    }
}

// pdf() must integrate over the hemisphere to the probability that sample() succeeds; this
// checks the half-vector Jacobian and the lobe mixture independently of sample().
TEST(Microfacet, PdfIntegratesToSuccessProbability) {
    auto bsdf = makeBSDF("microfacet", microfacetProps(0.3f, Color3f(0.25f)));
    for (float deg : {10.0f, 45.0f, 75.0f}) {
        const Vector3f wi = directionAt(deg);
        Rng rng(13, 0, 0, StreamPurpose::Test);
        stats::RunningStats integral;
        const int n = 400000;
        for (int i = 0; i < n; ++i) {
            const Vector3f wo =
                warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
            integral.add(bsdf->pdf(BSDFQueryRecord(wi, wo, Measure::SolidAngle)) / Inv2Pi);
        }
        int success = 0;
        const int m = 200000;
        for (int i = 0; i < m; ++i) {
            BSDFQueryRecord rec(wi);
            if (!bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).isBlack()) ++success;
        }
        const double p = success / double(m);
        const double sigma = std::hypot(integral.standardError(), std::sqrt(p * (1 - p) / m));
        EXPECT_NEAR(integral.mean, p, 5.0 * sigma + 1e-6) << deg;
        EXPECT_LE(p, 1.0);
    }
}

// Directional albedo = E[sample weight] must not exceed 1 (energy conservation), and in the
// smooth limit the specular lobe alone reflects the Fresnel reflectance.
TEST(Microfacet, AlbedoAtMostOneAndSmoothLimitIsFresnel) {
    struct Case {
        float alpha;
        Color3f kd;
    };
    for (const Case& c : {Case{0.1f, Color3f(0.5f)}, Case{0.5f, Color3f(0.0f)},
                          Case{1.0f, Color3f(0.9f, 0.2f, 0.1f)}, Case{0.05f, Color3f(0.0f)}}) {
        auto bsdf = makeBSDF("microfacet", microfacetProps(c.alpha, c.kd));
        for (float deg : {0.0f, 30.0f, 60.0f, 80.0f, 89.0f}) {
            Rng rng(17, 0, 0, StreamPurpose::Test);
            stats::RunningStats albedo;
            for (int i = 0; i < 100000; ++i) {
                BSDFQueryRecord rec(directionAt(deg));
                const Color3f w = bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
                ASSERT_TRUE(w.allFinite());
                albedo.add(w.maxCoeff());
            }
            EXPECT_LE(albedo.mean, 1.0 + 5.0 * albedo.standardError()) << c.alpha << " " << deg;
        }
    }
    // alpha = 0.01, kd = 0: nearly a smooth dielectric reflector, albedo ~ F(theta).
    auto smooth = makeBSDF("microfacet", microfacetProps(0.01f, Color3f(0.0f)));
    for (float deg : {0.0f, 30.0f, 60.0f, 75.0f}) {
        Rng rng(19, 0, 0, StreamPurpose::Test);
        stats::RunningStats albedo;
        for (int i = 0; i < 20000; ++i) {
            BSDFQueryRecord rec(directionAt(deg));
            albedo.add(smooth->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).r());
        }
        const double F = fresnelReference(degToRad(deg), 1.000277, 1.5046);
        EXPECT_NEAR(albedo.mean, F, 0.02 * F + 5.0 * albedo.standardError()) << deg;
    }
}

// A nested texture for kd (or alpha) drives the same BRDF as the plain value, and a texture
// whose range leaves [0, 1] (for kd) or (0, inf) (for alpha) is rejected at load time.
TEST(Microfacet, TexturedParametersMatchPlainValues) {
    auto constant = [](const Color3f& value) {
        PropertyList props;
        props.setColor("value", value);
        auto texture = ObjectFactory::create(ObjectKind::Texture, "constant", props);
        texture->activate();
        return texture;
    };
    auto plain = makeBSDF("microfacet", microfacetProps(0.3f, Color3f(0.2f, 0.4f, 0.1f)));
    auto textured = std::static_pointer_cast<BSDF>(
        ObjectFactory::create(ObjectKind::BSDF, "microfacet", PropertyList()));
    textured->addChild(constant(Color3f(0.2f, 0.4f, 0.1f)), "kd");
    textured->addChild(constant(Color3f(0.3f)), "alpha");
    textured->activate();
    const Vector3f wi = directionAt(40.0f), wo = directionAt(25.0f, 2.0f);
    const Color3f a = plain->eval(BSDFQueryRecord(wi, wo, Measure::SolidAngle));
    const Color3f b = textured->eval(BSDFQueryRecord(wi, wo, Measure::SolidAngle));
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(a[c], b[c], 1e-6f * a[c]);
    EXPECT_NEAR(plain->pdf(BSDFQueryRecord(wi, wo, Measure::SolidAngle)),
                textured->pdf(BSDFQueryRecord(wi, wo, Measure::SolidAngle)), 1e-5f);

    auto tooBright = std::static_pointer_cast<BSDF>(
        ObjectFactory::create(ObjectKind::BSDF, "microfacet", PropertyList()));
    tooBright->addChild(constant(Color3f(1.5f, 0.1f, 0.1f)), "kd");
    EXPECT_THROW(tooBright->activate(), Error);
    auto flat = std::static_pointer_cast<BSDF>(
        ObjectFactory::create(ObjectKind::BSDF, "microfacet", PropertyList()));
    flat->addChild(constant(Color3f(0.0f)), "alpha");
    EXPECT_THROW(flat->activate(), Error);
}

TEST(Microfacet, RejectsKdAboveOneAndNonPositiveAlpha) {
    EXPECT_THROW(makeBSDF("microfacet", microfacetProps(0.1f, Color3f(1.2f, 0.1f, 0.1f))), Error);
    EXPECT_THROW(makeBSDF("microfacet", microfacetProps(-0.1f, Color3f(0.5f))), Error);
    // The refusals say why: 0 is a delta, and an alpha whose square is no normal float loses
    // the distribution's peak.
    auto messageFor = [](float alpha) -> std::string {
        try {
            makeBSDF("microfacet", microfacetProps(alpha, Color3f(0.5f)));
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_NE(messageFor(0.0f).find("alpha 0 is a perfectly smooth surface"), std::string::npos)
        << messageFor(0.0f);
    EXPECT_NE(messageFor(1e-20f).find("alpha 1e-20 is too small to render in float precision"),
              std::string::npos)
        << messageFor(1e-20f);
}

// Roughness near 0 renders, down to where float ends: the sampled lobe is then a mirror
// reflection weighted by the Fresnel reflectance, with finite weights at every angle (Nori
// courses use alpha 1e-3; the t-test at alpha 1e-8 and 2e-19 gave exactly the mirror's F).
TEST(Microfacet, RoughnessNearZeroRendersAsAFresnelMirror) {
    for (float alpha : {1e-3f, 1e-8f, 2e-19f}) {
        auto bsdf = makeBSDF("microfacet", microfacetProps(alpha, Color3f(0.0f)));
        for (float deg : {0.0f, 30.0f, 60.0f, 75.0f, 85.0f}) {
            Rng rng(29, 0, 0, StreamPurpose::Test);
            stats::RunningStats albedo;
            for (int i = 0; i < 5000; ++i) {
                BSDFQueryRecord rec(directionAt(deg));
                const Color3f w = bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
                ASSERT_TRUE(w.allFinite()) << alpha << " " << deg;
                albedo.add(w.r());
            }
            const double F = fresnelReference(degToRad(deg), 1.000277, 1.5046);
            EXPECT_NEAR(albedo.mean, F, 0.01 * F + 5.0 * albedo.standardError())
                << alpha << " " << deg;
        }
    }
}

}  // namespace
}  // namespace alphorn
