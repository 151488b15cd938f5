// Unit tests of the Trowbridge-Reitz distribution, the conductor Fresnel term and the conductor
// BSDF. Expected values come from closed forms written out here or from independent numerical
// integration, never from the code under test; Monte Carlo checks use fixed seeds.
#include "common/bsdf/fresnel.h"
#include "common/bsdf/microfacet_distribution.h"
#include "common/bsdf/pbrt_bsdf_testing.h"
#include "common/core/frame.h"
#include "common/core/warp.h"
#include "common/stats/sidak.h"
#include "common/stats/student_t.h"

namespace alphorn {
namespace {

using testing::bsdfChi2;
using testing::directionAt;
using testing::makeBSDF;

// Conductor reflectance by the textbook real-arithmetic form (Born & Wolf's a and b), in
// double: a different formulation from the complex one under test.
double conductorReference(double cosI, double n, double k) {
    const double sin2 = 1.0 - cosI * cosI, tan2 = sin2 / (cosI * cosI);
    const double t = n * n - k * k - sin2;
    const double ab = std::sqrt(t * t + 4.0 * n * n * k * k);
    const double a = std::sqrt(0.5 * (ab + t));
    const double rs = (ab - 2.0 * a * cosI + cosI * cosI) / (ab + 2.0 * a * cosI + cosI * cosI);
    const double sinTan = std::sqrt(sin2 * tan2);
    const double rp =
        rs * (ab - 2.0 * a * sinTan + sin2 * tan2) / (ab + 2.0 * a * sinTan + sin2 * tan2);
    return 0.5 * (rs + rp);
}

TEST(FresnelConductor, MatchesRealFormAtSeveralAngles) {
    const Color3f eta(0.2f, 0.92f, 1.1f), k(3.9f, 2.45f, 2.14f);
    for (double deg : {0.0, 20.0, 45.0, 60.0, 75.0, 85.0, 89.0}) {
        const double cosI = std::cos(deg * M_PI / 180.0);
        const Color3f F = fresnelConductor(float(cosI), eta, k);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(F[c], conductorReference(std::max(cosI, 1e-9), eta[c], k[c]), 2e-5)
                << deg << " " << c;
    }
}

TEST(FresnelConductor, LimitsAndDielectricCase) {
    // No interface: nothing reflects; an infinitely absorbing metal reflects everything.
    EXPECT_NEAR(fresnelConductor(0.7f, Color3f(1.0f), Color3f(0.0f)).maxCoeff(), 0.0f, 1e-7f);
    for (float cosI : {1.0f, 0.5f, 0.1f})
        EXPECT_NEAR(fresnelConductor(cosI, Color3f(1.5f), Color3f(1e5f)).minCoeff(), 1.0f, 1e-4f);
    // k = 0 is a dielectric: the same as the dielectric Fresnel term.
    for (float cosI : {1.0f, 0.8f, 0.4f, 0.05f})
        EXPECT_NEAR(fresnelConductor(cosI, Color3f(1.5f), Color3f(0.0f)).r(),
                    fresnelDielectric(cosI, 1.0f, 1.5f), 1e-6f);
    // Normal incidence closed form ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
    EXPECT_NEAR(fresnelConductor(1.0f, Color3f(0.3f), Color3f(3.0f)).r(),
                (0.49 + 9.0) / (1.69 + 9.0), 1e-6);
}

// GGX written out for an isotropic alpha: D = alpha^2 / (pi cos^4 (alpha^2 + tan^2)^2) and
// Lambda = (sqrt(1 + alpha^2 tan^2) - 1) / 2.
double ggxD(double cosH, double alpha) {
    const double c2 = cosH * cosH, tan2 = (1.0 - c2) / c2, a2 = alpha * alpha;
    return a2 / (M_PI * c2 * c2 * (a2 + tan2) * (a2 + tan2));
}
double ggxLambda(double cosV, double alpha) {
    const double c2 = cosV * cosV, tan2 = (1.0 - c2) / c2;
    return 0.5 * (std::sqrt(1.0 + alpha * alpha * tan2) - 1.0);
}

TEST(TrowbridgeReitz, RemappingAndSmoothThresholdArePbrts) {
    EXPECT_FLOAT_EQ(TrowbridgeReitz::roughnessToAlpha(0.25f), 0.5f);
    EXPECT_FLOAT_EQ(TrowbridgeReitz::roughnessToAlpha(0.0f), 0.0f);
    EXPECT_TRUE(TrowbridgeReitz(0.0009f, 0.0009f).effectivelySmooth());
    EXPECT_FALSE(TrowbridgeReitz(0.0009f, 0.001f).effectivelySmooth());
    const TrowbridgeReitz d(0.3f, 0.3f);
    const Vector3f h = directionAt(25.0f, 1.0f), v = directionAt(60.0f, 2.0f);
    EXPECT_NEAR(d.D(h), ggxD(h.z(), 0.3), 1e-5 * ggxD(h.z(), 0.3));
    EXPECT_NEAR(d.lambda(v), ggxLambda(v.z(), 0.3), 1e-6);
}

// Projected area of the microfacets is the macro surface's: int D(wm) cos(theta_m) dwm = 1, and
// the visible normals' density integrates to 1 for every view; anisotropic too.
TEST(TrowbridgeReitz, DistributionsAreNormalised) {
    for (const auto& [ax, ay] : {std::pair{0.1f, 0.1f}, {0.5f, 0.5f}, {0.2f, 0.7f}}) {
        const TrowbridgeReitz d(ax, ay);
        stats::SphericalGrid grid;
        grid.cosThetaResolution = 100;
        grid.phiResolution = 50;
        grid.cosThetaMin = 0.0;
        // Microfacet normals point up; D itself is even in cos theta.
        const double projected = stats::integrateOverSphere(
            [&](const Vector3f& m) { return m.z() > 0 ? d.D(m) * m.z() : 0.0; }, grid);
        EXPECT_NEAR(projected, 1.0, 2e-3) << ax << " " << ay;
        for (float deg : {0.0f, 45.0f, 80.0f}) {
            const Vector3f w = directionAt(deg, 0.7f);
            const double visible = stats::integrateOverSphere(
                [&](const Vector3f& m) {
                    return m.z() > 0 && m.dot(w) > 0 ? d.visibleD(w, m) : 0.0;
                },
                grid);
            EXPECT_NEAR(visible, 1.0, 3e-3) << ax << " " << ay << " " << deg;
        }
    }
}

TEST(TrowbridgeReitz, VisibleNormalSamplingMatchesItsDensity) {
    const double alpha = stats::sidakAlpha(0.01, 6);
    int index = 0;
    for (const auto& [ax, ay] : {std::pair{0.15f, 0.15f}, {0.6f, 0.25f}}) {
        const TrowbridgeReitz d(ax, ay);
        for (float deg : {10.0f, 50.0f, 85.0f}) {
            const Vector3f w = directionAt(deg, 0.4f);
            stats::SphericalGrid grid;
            std::vector<double> observed(grid.cellCount(), 0.0);
            Rng rng(0x7a, index++, 0, StreamPurpose::Test);
            const int n = 500000;
            for (int i = 0; i < n; ++i) {
                const float u = rng.nextFloat();
                observed[grid.cellOf(d.sampleVisibleNormal(w, Point2f(u, rng.nextFloat())))] += 1.0;
            }
            const auto expected = stats::expectedFrequencies(
                grid,
                [&](const Vector3f& m) {
                    return m.z() > 0 && m.dot(w) > 0 ? d.visibleD(w, m) : 0.0;
                },
                n);
            const auto result = stats::chi2Test(observed, expected, n, 5.0, alpha);
            EXPECT_TRUE(result.passed) << ax << " " << ay << " " << deg << ": " << result.message;
        }
    }
}

PropertyList conductorProps(float roughness, const Color3f& eta, const Color3f& k) {
    PropertyList props;
    props.setFloat("roughness", roughness);
    props.setColor("eta", eta);
    props.setColor("k", k);
    return props;
}

TEST(Conductor, RoughEvalMatchesCookTorranceWithGgx) {
    const float roughness = 0.09f;  // alpha 0.3 after pbrt-v4's remapping
    const Color3f eta(0.2f, 0.9f, 1.1f), k(3.9f, 2.4f, 2.1f);
    auto bsdf = makeBSDF("conductor", conductorProps(roughness, eta, k));
    const Vector3f wi = directionAt(30.0f, 0.0f), wo = directionAt(50.0f, Pi * 0.8f);
    const Vector3f h = (wi + wo).normalized();
    const double alpha = 0.3;
    const double G = 1.0 / (1.0 + ggxLambda(wi.z(), alpha) + ggxLambda(wo.z(), alpha));
    const Color3f f = bsdf->eval(BSDFQueryRecord(wi, wo, Measure::SolidAngle));
    for (int c = 0; c < 3; ++c) {
        const double F = conductorReference(wi.dot(h), eta[c], k[c]);
        const double expected = ggxD(h.z(), alpha) * G * F / (4.0 * wi.z() * wo.z());
        EXPECT_NEAR(f[c], expected, 1e-4 * expected) << c;
    }
    EXPECT_TRUE(bsdf->eval(BSDFQueryRecord(wi, wo, Measure::Discrete)).isBlack());
}

TEST(Conductor, EvalIsReciprocalAndSampleWeightIsEvalCosOverPdf) {
    for (const char* which : {"isotropic", "anisotropic"}) {
        PropertyList props =
            conductorProps(0.2f, Color3f(0.2f, 0.9f, 1.1f), Color3f(3.9f, 2.4f, 2.1f));
        if (std::string(which) == "anisotropic") {
            props = PropertyList();
            props.setFloat("uroughness", 0.05f);
            props.setFloat("vroughness", 0.4f);
        }
        auto bsdf = makeBSDF("conductor", props);
        Rng rng(3, 0, 0, StreamPurpose::Test);
        for (int i = 0; i < 2000; ++i) {
            const Vector3f a =
                warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
            const Vector3f b =
                warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
            const Color3f fab = bsdf->eval(BSDFQueryRecord(a, b, Measure::SolidAngle));
            const Color3f fba = bsdf->eval(BSDFQueryRecord(b, a, Measure::SolidAngle));
            for (int c = 0; c < 3; ++c)
                EXPECT_NEAR(fab[c], fba[c], 1e-5f * std::max(1.0f, fab[c])) << which;
        }
        for (float deg : {0.0f, 40.0f, 80.0f}) {
            int valid = 0;
            for (int i = 0; i < 2000; ++i) {
                BSDFQueryRecord rec(directionAt(deg));
                const Color3f w = bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
                ASSERT_TRUE(w.allFinite());
                if (w.isBlack()) continue;
                ++valid;
                ASSERT_EQ(rec.measure, Measure::SolidAngle);
                const Color3f expected = bsdf->eval(rec) * Frame::cosTheta(rec.wo) / bsdf->pdf(rec);
                for (int c = 0; c < 3; ++c)
                    EXPECT_NEAR(w[c], expected[c], 1e-4f * expected[c] + 1e-7f);
            }
            EXPECT_GT(valid, 1500) << which << " " << deg;
        }
    }
}

TEST(Conductor, SamplingMatchesPdfChiSquare) {
    struct Case {
        float u, v;
    };
    const std::vector<Case> cases = {{0.01f, 0.01f}, {0.2f, 0.2f}, {0.8f, 0.8f}, {0.02f, 0.3f}};
    const std::vector<float> angles = {5.0f, 45.0f, 80.0f};
    const double alpha = stats::sidakAlpha(0.01, int(cases.size() * angles.size()));
    int stream = 0;
    for (const Case& c : cases) {
        PropertyList props;
        props.setFloat("uroughness", c.u);
        props.setFloat("vroughness", c.v);
        auto bsdf = makeBSDF("conductor", props);
        for (float deg : angles) {
            const auto result = bsdfChi2(*bsdf, directionAt(deg, 1.1f), 1000000, stream++, alpha);
            EXPECT_TRUE(result.passed) << c.u << " " << c.v << " " << deg << ": " << result.message;
        }
    }
}

TEST(Conductor, SmoothIsAFresnelWeightedDelta) {
    const Color3f eta(0.2f, 0.9f, 1.1f), k(3.9f, 2.4f, 2.1f);
    auto bsdf = makeBSDF("conductor", conductorProps(0.0f, eta, k));
    EXPECT_FALSE(bsdf->isDiffuse());
    for (float deg : {0.0f, 30.0f, 70.0f}) {
        BSDFQueryRecord rec(directionAt(deg));
        const Color3f w = bsdf->sample(rec, Point2f(0.3f, 0.6f));
        EXPECT_EQ(rec.measure, Measure::Discrete);
        EXPECT_NEAR((rec.wo - Vector3f(-rec.wi.x(), -rec.wi.y(), rec.wi.z())).norm(), 0.0f, 1e-6f);
        for (int c = 0; c < 3; ++c)
            EXPECT_NEAR(w[c], conductorReference(std::cos(degToRad(deg)), eta[c], k[c]), 2e-5);
        EXPECT_TRUE(bsdf->eval(BSDFQueryRecord(rec.wi, rec.wo, Measure::SolidAngle)).isBlack());
    }
}

// pbrt-v4's artist mode: the normal-incidence reflectance is `reflectance`.
TEST(Conductor, ReflectanceModeReflectsItAtNormalIncidence) {
    PropertyList props;
    props.setColor("reflectance", Color3f(0.9f, 0.5f, 0.1f));
    auto bsdf = makeBSDF("conductor", props);
    BSDFQueryRecord rec(Vector3f(0.0f, 0.0f, 1.0f));
    const Color3f w = bsdf->sample(rec, Point2f(0.5f, 0.5f));
    EXPECT_NEAR(w.r(), 0.9f, 1e-5f);
    EXPECT_NEAR(w.g(), 0.5f, 1e-5f);
    EXPECT_NEAR(w.b(), 0.1f, 1e-5f);
    props.setColor("eta", Color3f(1.2f));
    EXPECT_THROW(makeBSDF("conductor", props), Error);
}

// A perfect reflector (F = 1) made rough loses exactly what single-scattering GGX loses: the
// directional albedo is E(wi) = int D(h) G(wi, wo) / (4 cos_i) dwo, computed here by a
// midpoint rule over (cos theta_o, phi_o) with the closed-form D and Lambda above.
TEST(Conductor, RoughPerfectReflectorLosesOnlySingleScatteringEnergy) {
    for (float roughness : {0.1f, 0.5f, 1.0f}) {
        const double alpha = std::sqrt(double(roughness));
        auto bsdf = makeBSDF("conductor", conductorProps(roughness, Color3f(1.0f), Color3f(1e5f)));
        for (float deg : {0.0f, 45.0f, 75.0f}) {
            const Vector3f wi = directionAt(deg, 0.0f);
            double quadrature = 0.0;
            const int nc = 2000, np = 400;
            for (int i = 0; i < nc; ++i) {
                const double cosO = (i + 0.5) / nc, sinO = std::sqrt(1.0 - cosO * cosO);
                for (int j = 0; j < np; ++j) {
                    const double phi = 2.0 * M_PI * (j + 0.5) / np;
                    const Vector3f wo(float(sinO * std::cos(phi)), float(sinO * std::sin(phi)),
                                      float(cosO));
                    const Vector3f h = (wi + wo).normalized();
                    const double G =
                        1.0 / (1.0 + ggxLambda(wi.z(), alpha) + ggxLambda(cosO, alpha));
                    quadrature += ggxD(h.z(), alpha) * G / (4.0 * wi.z());
                }
            }
            quadrature *= (1.0 / nc) * (2.0 * M_PI / np);
            Rng rng(21, 0, 0, StreamPurpose::Test);
            stats::RunningStats albedo;
            for (int i = 0; i < 200000; ++i) {
                BSDFQueryRecord rec(wi);
                albedo.add(bsdf->sample(rec, Point2f(rng.nextFloat(), rng.nextFloat())).g());
            }
            EXPECT_NEAR(albedo.mean, quadrature, 5.0 * albedo.standardError() + 2e-3)
                << roughness << " " << deg;
            EXPECT_LT(quadrature, 1.0);
        }
    }
}

}  // namespace
}  // namespace alphorn
