// Unit tests of the rough dielectric, thin dielectric, diffuse transmission, mix and coated
// BSDFs. Expected values are closed forms or independent estimates; the coated BSDFs' values are
// themselves Monte Carlo estimates, so their checks are statistical (t-tests at fixed seeds).
#include "common/bsdf/fresnel.h"
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

Vector3f below(Vector3f w) {
    w.z() = -w.z();
    return w;
}

// sample() must return eval * |cos| / pdf for every non-delta sample.
void expectWeightIsEvalCosOverPdf(const BSDF& bsdf, const Vector3f& wi, int minValid) {
    Rng rng(5, 0, 0, StreamPurpose::Test);
    int valid = 0;
    for (int i = 0; i < 2000; ++i) {
        BSDFQueryRecord rec(wi);
        const float u = rng.nextFloat();
        const Color3f w = bsdf.sample(rec, Point2f(u, rng.nextFloat()));
        ASSERT_TRUE(w.allFinite());
        if (w.isBlack() || rec.measure == Measure::Discrete) continue;
        ++valid;
        const float pdf = bsdf.pdf(rec);
        ASSERT_GT(pdf, 0.0f);
        const Color3f expected = bsdf.eval(rec) * std::abs(Frame::cosTheta(rec.wo)) / pdf;
        for (int c = 0; c < 3; ++c) EXPECT_NEAR(w[c], expected[c], 2e-4f * expected[c] + 1e-7f);
    }
    EXPECT_GE(valid, minValid);
}

PropertyList roughGlass(float roughness, float eta = 1.5f) {
    PropertyList props;
    props.setFloat("roughness", roughness);
    props.setFloat("eta", eta);
    return props;
}

TEST(RoughDielectric, SamplingMatchesPdfChiSquareBothSides) {
    const std::vector<float> roughnesses = {0.01f, 0.1f, 0.6f};
    const std::vector<float> angles = {10.0f, 50.0f, 80.0f};
    const double alpha = stats::sidakAlpha(0.01, int(roughnesses.size() * angles.size() * 2));
    int stream = 100;
    for (float r : roughnesses) {
        auto bsdf = makeBSDF("dielectric", roughGlass(r));
        EXPECT_TRUE(bsdf->isDiffuse());
        for (float deg : angles)
            for (bool inside : {false, true}) {
                const Vector3f wi = inside ? below(directionAt(deg)) : directionAt(deg);
                const auto result = bsdfChi2(*bsdf, wi, 1000000, stream++, alpha);
                EXPECT_TRUE(result.passed)
                    << r << " " << deg << (inside ? " inside: " : ": ") << result.message;
            }
    }
}

TEST(RoughDielectric, WeightsAndEnergy) {
    auto bsdf = makeBSDF("dielectric", roughGlass(0.2f));
    for (float deg : {0.0f, 45.0f, 80.0f})
        for (bool inside : {false, true}) {
            const Vector3f wi = inside ? below(directionAt(deg)) : directionAt(deg);
            expectWeightIsEvalCosOverPdf(*bsdf, wi, 1500);
            // Energy: reflected plus transmitted flux (radiance weights times eta^2 undo the
            // radiance scaling) is at most 1. Single-scattering GGX loses some: from outside a
            // few per cent (14% at 80 degrees, by masking), from inside more (about 20-30%),
            // where microfacets reflect totally towards directions that the model drops.
            Rng rng(9, 0, 0, StreamPurpose::Test);
            stats::RunningStats flux;
            for (int i = 0; i < 100000; ++i) {
                BSDFQueryRecord rec(wi);
                const float u = rng.nextFloat();
                const Color3f w = bsdf->sample(rec, Point2f(u, rng.nextFloat()));
                flux.add(w.r() * rec.eta * rec.eta);
            }
            EXPECT_LE(flux.mean, 1.0 + 5.0 * flux.standardError()) << deg << inside;
            EXPECT_GT(flux.mean, inside ? 0.6 : 0.8) << deg << inside;  // loose: a gross loss
        }
}

// Generalised reciprocity of refraction with the radiance scaling: radiance is compressed by
// eta^2 entering the denser side, so f(wi, wo) / eta_i^2 = f(wo, wi) / eta_o^2, with eta_x the
// index on x's side; for reflection plain symmetry.
TEST(RoughDielectric, EvalObeysGeneralisedReciprocity) {
    const float eta = 1.5f;
    auto bsdf = makeBSDF("dielectric", roughGlass(0.3f, eta));
    Rng rng(4, 0, 0, StreamPurpose::Test);
    int transmitted = 0;
    for (int i = 0; i < 2000; ++i) {
        const Vector3f a = warp::squareToUniformSphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        const Vector3f b = warp::squareToUniformSphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        const float fab = bsdf->eval(BSDFQueryRecord(a, b, Measure::SolidAngle)).r();
        const float fba = bsdf->eval(BSDFQueryRecord(b, a, Measure::SolidAngle)).r();
        const float na = a.z() > 0 ? 1.0f : eta, nb = b.z() > 0 ? 1.0f : eta;
        EXPECT_NEAR(fab / (na * na), fba / (nb * nb), 1e-4f * std::max(1.0f, fab));
        if (a.z() * b.z() < 0 && fab > 0) ++transmitted;
    }
    EXPECT_GT(transmitted, 150);
}

// Walter et al. 2007's rough dielectric written out for one reflection and one refraction pair
// (isotropic GGX, alpha = sqrt(roughness), height-correlated Smith G, eta 1.5 in air).
TEST(RoughDielectric, EvalMatchesWaltersModel) {
    const double alpha = 0.5, eta = 1.5;
    auto bsdf = makeBSDF("dielectric", roughGlass(0.25f, float(eta)));
    auto D = [&](double cosH) {
        const double c2 = cosH * cosH, t2 = (1 - c2) / c2, a2 = alpha * alpha;
        return a2 / (M_PI * c2 * c2 * (a2 + t2) * (a2 + t2));
    };
    auto lambda = [&](double cosV) {
        const double c2 = cosV * cosV, t2 = (1 - c2) / c2;
        return 0.5 * (std::sqrt(1 + alpha * alpha * t2) - 1);
    };
    auto fresnel = [&](double cosI, double n1, double n2) {
        const double sinT = n1 / n2 * std::sqrt(1 - cosI * cosI);
        if (sinT >= 1) return 1.0;
        const double cosT = std::sqrt(1 - sinT * sinT);
        const double rs = (n1 * cosI - n2 * cosT) / (n1 * cosI + n2 * cosT);
        const double rp = (n2 * cosI - n1 * cosT) / (n2 * cosI + n1 * cosT);
        return 0.5 * (rs * rs + rp * rp);
    };
    const Vector3f wi = directionAt(40.0f, 0.0f);
    // Reflection: D F G / (4 |cos_i cos_o|).
    const Vector3f wr = directionAt(25.0f, 2.8f);
    const Vector3f hr = (wi + wr).normalized();
    const double G = 1 / (1 + lambda(wi.z()) + lambda(wr.z()));
    const double fr = D(hr.z()) * fresnel(wi.dot(hr), 1.0, eta) * G / (4 * wi.z() * wr.z());
    EXPECT_NEAR(bsdf->eval(BSDFQueryRecord(wi, wr, Measure::SolidAngle)).r(), fr, 1e-4 * fr);
    // Refraction into the glass: the half vector -(eta_i wi + eta_o wo), and
    // |i.h||o.h| eta_o^2 (1 - F) D G / (|cos_i cos_o| (eta_i i.h + eta_o o.h)^2), over eta^2 for
    // radiance (eta_i = 1 outside, eta_o = eta inside).
    const Vector3f wt = below(directionAt(20.0f, 3.3f));
    const Vector3f ht = -(wi + eta * wt).normalized();
    const Vector3f h = ht.z() < 0 ? Vector3f(-ht) : ht;
    const double Gt = 1 / (1 + lambda(wi.z()) + lambda(-wt.z()));
    const double denom = std::pow(wi.dot(h) + eta * wt.dot(h), 2);
    const double ft = std::abs(wi.dot(h) * wt.dot(h)) * eta * eta *
                      (1 - fresnel(wi.dot(h), 1.0, eta)) * D(h.z()) * Gt /
                      (std::abs(wi.z() * wt.z()) * denom) / (eta * eta);
    EXPECT_NEAR(bsdf->eval(BSDFQueryRecord(wi, wt, Measure::SolidAngle)).r(), ft, 1e-4 * ft);
}

TEST(RoughDielectric, EtaIsASynonymOnlyWithoutIntIorExtIor) {
    PropertyList props = roughGlass(0.2f);
    props.setFloat("intIOR", 1.4f);
    EXPECT_THROW(makeBSDF("dielectric", props), Error);
    // eta = 1.33 alone is intIOR 1.33 over extIOR 1: normal-incidence reflection of
    // ((1.33 - 1) / 2.33)^2 for the smooth interface.
    PropertyList water;
    water.setFloat("eta", 1.33f);
    auto bsdf = makeBSDF("dielectric", water);
    DeltaLobe lobes[BSDF::kMaxDeltaLobes];
    ASSERT_EQ(bsdf->deltaLobes(BSDFQueryRecord(Vector3f(0, 0, 1)), lobes), 2);
    EXPECT_NEAR(lobes[0].weight.r(), std::pow(0.33 / 2.33, 2), 1e-6);
}

// The sheet's reflectance sums the bounces inside it: R + T R T + T R^3 T + ... with the single
// interface's R and T; the sum is taken term by term here.
TEST(ThinDielectric, ReflectanceIsTheSeriesAndNothingIsAbsorbed) {
    PropertyList props;
    props.setFloat("eta", 1.5f);
    auto bsdf = makeBSDF("thindielectric", props);
    for (float deg : {0.0f, 30.0f, 60.0f, 85.0f})
        for (bool back : {false, true}) {
            const Vector3f wi = back ? below(directionAt(deg)) : directionAt(deg);
            const double R = fresnelDielectric(std::cos(degToRad(deg)), 1.0f, 1.5f), T = 1 - R;
            double series = R, bounce = T * R * T;
            for (int j = 0; j < 200; ++j, bounce *= R * R) series += bounce;
            DeltaLobe lobes[BSDF::kMaxDeltaLobes];
            ASSERT_EQ(bsdf->deltaLobes(BSDFQueryRecord(wi), lobes), 2);
            EXPECT_NEAR(lobes[0].weight.r(), series, 1e-5) << deg;
            EXPECT_NEAR(lobes[0].weight.r() + lobes[1].weight.r(), 1.0f, 1e-6f);
            EXPECT_NEAR((lobes[1].wo + wi).norm(), 0.0f, 1e-7f);  // straight through
            int reflected = 0;
            const int n = 20000;
            for (int i = 0; i < n; ++i) {
                BSDFQueryRecord rec(wi);
                const Color3f w = bsdf->sample(rec, Point2f((i + 0.5f) / n, 0.5f));
                EXPECT_EQ(w.r(), 1.0f);
                EXPECT_EQ(rec.measure, Measure::Discrete);
                if (rec.wo.z() * wi.z() > 0) ++reflected;
            }
            EXPECT_NEAR(reflected / double(n), series, 2.0 / n);
        }
}

TEST(DiffuseTransmission, AlbedoIsReflectancePlusTransmittance) {
    PropertyList props;
    props.setColor("reflectance", Color3f(0.3f, 0.2f, 0.1f));
    props.setColor("transmittance", Color3f(0.5f, 0.1f, 0.6f));
    props.setFloat("scale", 1.2f);
    auto bsdf = makeBSDF("diffusetransmission", props);
    const double alpha = stats::sidakAlpha(0.01, 4);
    int stream = 200;
    for (float deg : {20.0f, 70.0f})
        for (bool back : {false, true}) {
            const Vector3f wi = back ? below(directionAt(deg)) : directionAt(deg);
            expectWeightIsEvalCosOverPdf(*bsdf, wi, 1900);
            Rng rng(8, 0, 0, StreamPurpose::Test);
            stats::RunningStats reflected[3], transmitted[3];
            for (int i = 0; i < 200000; ++i) {
                BSDFQueryRecord rec(wi);
                const float u = rng.nextFloat();
                const Color3f w = bsdf->sample(rec, Point2f(u, rng.nextFloat()));
                const bool refl = rec.wo.z() * wi.z() > 0;
                for (int c = 0; c < 3; ++c) {
                    reflected[c].add(refl ? w[c] : 0.0);
                    transmitted[c].add(refl ? 0.0 : w[c]);
                }
            }
            const Color3f R = Color3f(0.3f, 0.2f, 0.1f) * 1.2f,
                          T = Color3f(0.5f, 0.1f, 0.6f) * 1.2f;
            for (int c = 0; c < 3; ++c) {
                EXPECT_NEAR(reflected[c].mean, R[c], 5.0 * reflected[c].standardError() + 1e-6);
                EXPECT_NEAR(transmitted[c].mean, T[c], 5.0 * transmitted[c].standardError() + 1e-6);
            }
            const auto result = bsdfChi2(*bsdf, wi, 500000, stream++, alpha);
            EXPECT_TRUE(result.passed) << deg << back << ": " << result.message;
        }
}

std::shared_ptr<BSDF> makeMix(float amount) {
    PropertyList props;
    props.setFloat("amount", amount);
    auto mix =
        std::static_pointer_cast<BSDF>(ObjectFactory::create(ObjectKind::BSDF, "mix", props));
    PropertyList metal;
    metal.setFloat("roughness", 0.05f);
    PropertyList matte;
    matte.setColor("albedo", Color3f(0.7f, 0.5f, 0.3f));
    mix->addChild(makeBSDF("conductor", metal), "");
    mix->addChild(makeBSDF("diffuse", matte), "");
    mix->activate();
    return mix;
}

TEST(Mix, IsTheLinearBlendWithAmountWeightingTheSecond) {
    PropertyList metalProps;
    metalProps.setFloat("roughness", 0.05f);
    auto metal = makeBSDF("conductor", metalProps);
    PropertyList matteProps;
    matteProps.setColor("albedo", Color3f(0.7f, 0.5f, 0.3f));
    auto matte = makeBSDF("diffuse", matteProps);
    const float amount = 0.3f;
    auto mix = makeMix(amount);
    const Vector3f wi = directionAt(35.0f), wo = directionAt(40.0f, 0.3f + Pi);
    const BSDFQueryRecord q(wi, wo, Measure::SolidAngle);
    const Color3f expected = 0.7f * metal->eval(q) + 0.3f * matte->eval(q);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(mix->eval(q)[c], expected[c], 1e-5f * expected[c]);
    EXPECT_NEAR(mix->pdf(q), 0.7f * metal->pdf(q) + 0.3f * matte->pdf(q), 1e-5f * mix->pdf(q));
    // Albedo: the blend of the two albedos, each estimated on its own.
    auto albedo = [&](const BSDF& bsdf, uint64_t seed) {
        Rng rng(seed, 0, 0, StreamPurpose::Test);
        stats::RunningStats s;
        for (int i = 0; i < 200000; ++i) {
            BSDFQueryRecord rec(wi);
            const float u = rng.nextFloat();
            s.add(bsdf.sample(rec, Point2f(u, rng.nextFloat())).g());
        }
        return s;
    };
    const auto a = albedo(*metal, 1), b = albedo(*matte, 2), m = albedo(*mix, 3);
    const double blend = 0.7 * a.mean + 0.3 * b.mean;
    const double se = std::sqrt(m.standardError() * m.standardError() +
                                0.49 * a.standardError() * a.standardError() +
                                0.09 * b.standardError() * b.standardError());
    EXPECT_NEAR(m.mean, blend, 5.0 * se);
    const auto result = bsdfChi2(*mix, directionAt(50.0f), 1000000, 300, 0.01);
    EXPECT_TRUE(result.passed) << result.message;
}

TEST(Mix, RefusesWrongChildCountAndAmount) {
    auto mix = std::static_pointer_cast<BSDF>(
        ObjectFactory::create(ObjectKind::BSDF, "mix", PropertyList()));
    mix->addChild(makeBSDF("diffuse"), "");
    EXPECT_THROW(mix->activate(), Error);
    PropertyList props;
    props.setFloat("amount", 1.5f);
    EXPECT_THROW(ObjectFactory::create(ObjectKind::BSDF, "mix", props), Error);
}

// ---- coated BSDFs ----

PropertyList coatedDiffuse(float roughness, const Color3f& reflectance, int maxDepth = 10) {
    PropertyList props;
    props.setFloat("roughness", roughness);
    props.setColor("reflectance", reflectance);
    props.setInteger("maxdepth", maxDepth);
    return props;
}
PropertyList whiteFurnace(float roughness) {
    PropertyList props = coatedDiffuse(roughness, Color3f(1.0f), 400);
    props.setFloat("thickness", 1e-7f);
    return props;
}

// White furnace: a white Lambertian base under a clear coat loses nothing, so the directional
// albedo is 1. The layer between them absorbs (pbrt-v4's albedo 0 is an absorbing layer of
// `thickness` mean free paths), so it is made negligibly thin, and the walk's depth limit is
// raised so that no energy is cut off. A smooth coat must give 1 (t-test). A coat of roughness
// 1e-4 (alpha 0.01, the rough code path) loses a little, as single-scattering GGX does at grazing
// angles (0.13% to 0.18% measured), so it is held to within 0.5% of 1. A rougher coat loses what
// single-scattering GGX loses at each of the many bounces under it (microfacets seen from inside
// reflect totally towards directions the model drops: a fifth of them at alpha 0.5), so its albedo
// is well below 1; it is only bounded here, and the walk's agreement with eval() is checked below.
TEST(CoatedDiffuse, WhiteFurnaceReflectsEverything) {
    for (float roughness : {0.0f, 1e-4f, 0.3f}) {
        auto bsdf = makeBSDF("coateddiffuse", whiteFurnace(roughness));
        for (float deg : {0.0f, 45.0f, 80.0f}) {
            Rng rng(12, 0, 0, StreamPurpose::Test);
            std::vector<double> values;
            for (int i = 0; i < 100000; ++i) {
                BSDFQueryRecord rec(directionAt(deg));
                rec.uv = Point2f(rng.nextFloat(), rng.nextFloat());
                const float u = rng.nextFloat();
                values.push_back(bsdf->sample(rec, Point2f(u, rng.nextFloat())).g());
            }
            const auto mv = stats::meanAndVariance(values.data(), values.size());
            if (roughness > 0.0f && roughness < 0.01f) {
                EXPECT_NEAR(mv.mean, 1.0, 5e-3) << deg;
                EXPECT_LT(mv.mean, 1.0) << deg;
                continue;
            }
            if (roughness > 0.01f) {
                EXPECT_LT(mv.mean, 1.0) << deg;
                EXPECT_GT(mv.mean, 0.3) << deg;
                std::printf("coateddiffuse white furnace, coat roughness %g, %g degrees: %.4f\n",
                            roughness, deg, mv.mean);
                continue;
            }
            const auto t = stats::studentTTest(mv.mean, mv.variance, 1.0, values.size(),
                                               stats::sidakAlpha(0.01, 6));
            EXPECT_TRUE(t.passed) << roughness << " " << deg << ": " << t.message;
        }
    }
}

// sample() and eval() estimate the same BSDF: over each of a few bands of cos theta_o, the mean
// sampling weight that lands there equals int_band f cos dwo, estimated with eval() at uniformly
// drawn directions (each with its own uv, so the estimates are independent). A two-sample
// t-test per band; this is the check that the walk's weights and its value agree (pdf() is only
// an approximation of sample()'s density, so a chi-square test of the two does not apply).
void expectSampleAgreesWithEval(const BSDF& bsdf, const Vector3f& wi, double alpha,
                                const std::string& what) {
    const int bands = 4, n = 200000;
    std::vector<stats::RunningStats> sampled(bands), evaluated(bands);
    Rng rng(31, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < n; ++i) {
        BSDFQueryRecord rec(wi);
        rec.uv = Point2f(rng.nextFloat(), rng.nextFloat());
        const float u = rng.nextFloat();
        const Color3f w = bsdf.sample(rec, Point2f(u, rng.nextFloat()));
        // Delta reflections are not in eval(); they are left out of both sides.
        const bool counted = rec.measure == Measure::SolidAngle && rec.wo.z() * wi.z() > 0;
        const int band = std::min(bands - 1, int(std::abs(rec.wo.z()) * bands));
        for (int b = 0; b < bands; ++b) sampled[b].add(counted && b == band ? w.g() : 0.0);
        const Vector3f wo =
            warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
        BSDFQueryRecord q(wi, wi.z() > 0 ? wo : below(wo), Measure::SolidAngle);
        q.uv = Point2f(rng.nextFloat(), rng.nextFloat());
        const double value = bsdf.eval(q).g() * wo.z() / warp::squareToUniformHemispherePdf(wo);
        const int evalBand = std::min(bands - 1, int(wo.z() * bands));
        for (int b = 0; b < bands; ++b) evaluated[b].add(b == evalBand ? value : 0.0);
    }
    for (int b = 0; b < bands; ++b) {
        const double diff = sampled[b].mean - evaluated[b].mean;
        const double se = std::hypot(sampled[b].standardError(), evaluated[b].standardError());
        const double p = stats::studentTTwoSidedPValue(diff / se, 2.0 * n - 2.0);
        EXPECT_GT(p, alpha) << what << " band " << b << ": sampled " << sampled[b].mean
                            << " evaluated " << evaluated[b].mean << " (se " << se << ")";
    }
}

TEST(CoatedDiffuse, SampleWeightsAgreeWithEval) {
    const double alpha = stats::sidakAlpha(0.01, 4 * 6);
    for (float roughness : {0.0f, 0.3f}) {
        PropertyList props = coatedDiffuse(roughness, Color3f(0.2f, 0.6f, 0.9f));
        auto bsdf = makeBSDF("coateddiffuse", props);
        props.setColor("albedo", Color3f(0.8f));
        props.setFloat("thickness", 0.3f);
        props.setFloat("g", 0.4f);
        auto medium = makeBSDF("coateddiffuse", props);
        for (float deg : {20.0f, 70.0f}) {
            expectSampleAgreesWithEval(*bsdf, directionAt(deg), alpha,
                                       "clear " + std::to_string(roughness));
            if (deg > 50.0f)
                expectSampleAgreesWithEval(*medium, directionAt(deg), alpha,
                                           "medium " + std::to_string(roughness));
        }
    }
}

TEST(CoatedConductor, SampleWeightsAgreeWithEval) {
    const double alpha = stats::sidakAlpha(0.01, 4 * 3);
    int i = 0;
    for (const auto& [interface, conductor] :
         {std::pair{0.0f, 0.2f}, {0.2f, 0.05f}, {0.3f, 0.0f}}) {
        PropertyList props;
        props.setFloat("interface.roughness", interface);
        props.setFloat("conductor.roughness", conductor);
        auto bsdf = makeBSDF("coatedconductor", props);
        expectSampleAgreesWithEval(*bsdf, directionAt(i++ == 1 ? 60.0f : 30.0f), alpha,
                                   std::to_string(interface) + " " + std::to_string(conductor));
    }
}

// Reciprocity, within the estimators' noise: for a fixed pair, eval at many uv (independent
// walks) estimates f(a, b) and f(b, a); the two means must agree (two-sample t-test).
void expectReciprocal(const BSDF& bsdf, const std::string& what) {
    const std::vector<std::pair<float, float>> pairs = {{10, 50}, {35, 70}, {60, 20}};
    for (const auto& [da, db] : pairs) {
        const Vector3f a = directionAt(da, 0.2f), b = directionAt(db, 2.5f);
        Rng rng(44, 0, 0, StreamPurpose::Test);
        stats::RunningStats fab, fba;
        for (int i = 0; i < 20000; ++i) {
            BSDFQueryRecord q(a, b, Measure::SolidAngle), r(b, a, Measure::SolidAngle);
            q.uv = Point2f(rng.nextFloat(), rng.nextFloat());
            r.uv = Point2f(rng.nextFloat(), rng.nextFloat());
            fab.add(bsdf.eval(q).g());
            fba.add(bsdf.eval(r).g());
        }
        const double se = std::hypot(fab.standardError(), fba.standardError());
        const double p = stats::studentTTwoSidedPValue((fab.mean - fba.mean) / se, 39998.0);
        EXPECT_GT(p, stats::sidakAlpha(0.01, 3 * 4))
            << what << " " << da << " " << db << ": " << fab.mean << " vs " << fba.mean;
        EXPECT_GT(fab.mean, 0.0);
    }
}

TEST(Coated, EvalIsReciprocalWithinNoise) {
    expectReciprocal(*makeBSDF("coateddiffuse", coatedDiffuse(0.0f, Color3f(0.6f))), "smooth");
    expectReciprocal(*makeBSDF("coateddiffuse", coatedDiffuse(0.3f, Color3f(0.6f))), "rough");
    PropertyList props;
    props.setFloat("interface.roughness", 0.1f);
    props.setFloat("conductor.roughness", 0.2f);
    expectReciprocal(*makeBSDF("coatedconductor", props), "conductor");
    props.setColor("albedo", Color3f(0.5f));
    props.setFloat("thickness", 0.2f);
    expectReciprocal(*makeBSDF("coatedconductor", props), "conductor in a medium");
}

// The estimates are functions of the query: the same query gives the same bits, and another
// uv gives another (independent) walk.
TEST(Coated, EvalAndPdfAreDeterministicPerQuery) {
    auto bsdf = makeBSDF("coateddiffuse", coatedDiffuse(0.3f, Color3f(0.6f)));
    BSDFQueryRecord q(directionAt(30.0f), directionAt(60.0f, 2.0f), Measure::SolidAngle);
    q.uv = Point2f(0.25f, 0.75f);
    const Color3f f = bsdf->eval(q);
    const float p = bsdf->pdf(q);
    EXPECT_TRUE((bsdf->eval(q) == f).all());
    EXPECT_EQ(bsdf->pdf(q), p);
    BSDFQueryRecord other = q;
    other.uv = Point2f(0.5f, 0.75f);
    EXPECT_FALSE((bsdf->eval(other) == f).all());
    EXPECT_TRUE(bsdf->isDiffuse());
    // A smooth coat's mirror reflection is a delta; the rest is not.
    int discrete = 0, solid = 0;
    auto smooth = makeBSDF("coateddiffuse", coatedDiffuse(0.0f, Color3f(0.6f)));
    for (int i = 0; i < 1000; ++i) {
        BSDFQueryRecord rec(directionAt(40.0f));
        smooth->sample(rec, Point2f((i + 0.5f) / 1000.0f, 0.3f));
        (rec.measure == Measure::Discrete ? discrete : solid)++;
    }
    EXPECT_GT(discrete, 10);
    EXPECT_GT(solid, 500);
}

TEST(Coated, RefusesAbsurdParameters) {
    for (const auto& [name, value] :
         {std::pair<std::string, float>{"thickness", 0.0f}, {"g", 1.0f}, {"eta", -1.0f}}) {
        PropertyList props;
        props.setFloat(name, value);
        EXPECT_THROW(makeBSDF("coateddiffuse", props), Error) << name;
    }
    PropertyList props;
    props.setInteger("maxdepth", 100000);
    EXPECT_THROW(makeBSDF("coateddiffuse", props), Error);
    PropertyList both;
    both.setColor("reflectance", Color3f(0.5f));
    both.setColor("conductor.eta", Color3f(0.5f));
    EXPECT_THROW(makeBSDF("coatedconductor", both), Error);
}

}  // namespace
}  // namespace alphorn
