#include "common/bsdf/bsdf.h"
#include "common/core/rng.h"
#include "common/core/warp.h"
#include "common/texture/plugin_testing.h"

#include <gtest/gtest.h>

namespace alphorn {
namespace {

using plugin_testing::expectParseError;
using plugin_testing::parseAs;

const char* kNested[] = {
    R"(<bsdf type="diffuse"><color name="albedo" value="0.8, 0.6, 0.3"/></bsdf>)",
    R"(<bsdf type="microfacet"><float name="alpha" value="0.3"/><color name="kd" value="0.4"/></bsdf>)",
};

std::shared_ptr<BSDF> normalMapped(const std::string& nested, const std::string& rgb) {
    return parseAs<BSDF>("normalmap.xml", absl::StrFormat(R"(<bsdf type="normalmap">
  %s
  <texture type="constant" name="normalmap"><color name="value" value="%s"/></texture>
</bsdf>)",
                                                          nested, rgb));
}

Vector3f randomDirection(Rng& rng, bool upper) {
    Vector3f v = warp::squareToUniformHemisphere(Point2f(rng.nextFloat(), rng.nextFloat()));
    if (!upper && rng.nextFloat() < 0.3f) v.z() = -v.z();
    return v;
}

TEST(NormalMap, FlatMapReproducesTheNestedBSDFExactly) {
    for (const char* nestedXml : kNested) {
        auto nested = parseAs<BSDF>("nested.xml", nestedXml);
        auto mapped = normalMapped(nestedXml, "0.5, 0.5, 1.0");
        Rng rng(11, 0, 0, StreamPurpose::Test);
        for (int i = 0; i < 2000; ++i) {
            BSDFQueryRecord a(randomDirection(rng, false), randomDirection(rng, false),
                              Measure::SolidAngle);
            a.uv = Point2f(rng.nextFloat(), rng.nextFloat());
            BSDFQueryRecord b = a;
            const Color3f fa = nested->eval(a), fb = mapped->eval(b);
            for (int c = 0; c < 3; ++c) ASSERT_EQ(fa[c], fb[c]) << nestedXml;
            ASSERT_EQ(nested->pdf(a), mapped->pdf(b));
            const Point2f s(rng.nextFloat(), rng.nextFloat());
            BSDFQueryRecord sa(a.wi), sb(a.wi);
            const Color3f wa = nested->sample(sa, s), wb = mapped->sample(sb, s);
            for (int c = 0; c < 3; ++c) ASSERT_EQ(wa[c], wb[c]);
            if (!wa.isBlack()) {
                for (int k = 0; k < 3; ++k) ASSERT_EQ(sa.wo[k], sb.wo[k]);
            }
            ASSERT_EQ(sa.measure, sb.measure);
        }
    }
}

struct AlbedoEstimate {
    double sampled[3] = {0, 0, 0};     // mean of sample() weights
    double integrated[3] = {0, 0, 0};  // eval |cos| / uniform-sphere pdf
    double integrated2[3] = {0, 0, 0};
    bool finite = true;
};

AlbedoEstimate estimateAlbedo(const BSDF& bsdf, const Vector3f& wi, int n, uint64_t seed) {
    AlbedoEstimate e;
    Rng rng(seed, 0, 0, StreamPurpose::Test);
    for (int i = 0; i < n; ++i) {
        BSDFQueryRecord rec(wi);
        const Color3f w = bsdf.sample(rec, Point2f(rng.nextFloat(), rng.nextFloat()));
        if (!w.allFinite()) e.finite = false;
        if (!w.isBlack()) {
            // Sampled directions are consistent with eval and pdf.
            const float pdf = bsdf.pdf(rec);
            const Color3f f = bsdf.eval(rec) * std::abs(rec.wo.z());
            if (!(pdf > 0.0f) || (f / pdf - w).abs().maxCoeff() > 1e-3f * (1.0f + w.maxCoeff()))
                e.finite = false;
        }
        BSDFQueryRecord q(wi,
                          warp::squareToUniformSphere(Point2f(rng.nextFloat(), rng.nextFloat())),
                          Measure::SolidAngle);
        const Color3f f = bsdf.eval(q) * std::abs(q.wo.z()) * (4.0f * Pi);
        if (!f.allFinite() || (f < 0.0f).any() || !std::isfinite(bsdf.pdf(q))) e.finite = false;
        for (int c = 0; c < 3; ++c) {
            e.sampled[c] += w[c] / n;
            e.integrated[c] += f[c] / n;
            e.integrated2[c] += double(f[c]) * f[c] / n;
        }
    }
    return e;
}

// A furnace for single bounces: with strong and below-horizon normals, the directional albedo
// never exceeds the nested one (0.8, 0.6, 0.3 for the diffuse base), nothing is NaN, and the
// sampled and the integrated estimates agree (so eval, pdf and sample are consistent).
TEST(NormalMap, StrongNormalsGainNoEnergy) {
    const Color3f nestedAlbedo(0.8f, 0.6f, 0.3f);
    const char* normals[] = {
        "0.95, 0.7, 0.6",  // strongly tilted
        "0.9, 0.5, 0.52",  // nearly at the horizon
        "1.0, 0.5, 0.3",   // below the horizon: bent back onto it
        "0.5, 0.5, 0.0",   // straight down: treated as flat
        "0.5, 0.5, 0.5",   // zero vector: treated as flat
    };
    for (const char* rgb : normals) {
        auto bsdf = normalMapped(kNested[0], rgb);
        for (const Vector3f& wiRaw : {Vector3f(0, 0, 1), Vector3f(0.7f, 0.1f, 0.3f),
                                      Vector3f(-0.9f, 0.2f, 0.1f), Vector3f(0.2f, -0.5f, 0.05f)}) {
            const Vector3f wi = wiRaw.normalized();
            const int n = 40000;
            const AlbedoEstimate e = estimateAlbedo(*bsdf, wi, n, 3);
            EXPECT_TRUE(e.finite) << rgb;
            for (int c = 0; c < 3; ++c) {
                const double sigma = std::sqrt(
                    std::max(0.0, e.integrated2[c] - e.integrated[c] * e.integrated[c]) / n);
                EXPECT_LE(e.sampled[c], nestedAlbedo[c] + 1e-5) << rgb;
                EXPECT_LE(e.integrated[c], nestedAlbedo[c] + 5.0 * sigma + 1e-5) << rgb;
                EXPECT_NEAR(e.sampled[c], e.integrated[c], 5.0 * sigma + 0.01) << rgb;
            }
        }
    }
    // A tilted normal really changes the shading (so the checks above can fail): light from
    // the tilt's side is brighter than from the opposite side.
    auto tilted = normalMapped(kNested[0], "0.8, 0.5, 0.9");
    const Vector3f wi(0, 0, 1), towards = Vector3f(0.6f, 0, 0.8f), away = Vector3f(-0.6f, 0, 0.8f);
    const float fTowards = tilted->eval(BSDFQueryRecord(wi, towards, Measure::SolidAngle)).r();
    const float fAway = tilted->eval(BSDFQueryRecord(wi, away, Measure::SolidAngle)).r();
    EXPECT_GT(fTowards, 1.3f * fAway);
}

TEST(NormalMap, ClearErrors) {
    expectParseError("normalmap_no_texture.xml", R"(<bsdf type="normalmap">
  <bsdf type="diffuse"/>
</bsdf>)",
                     1, "normalmap");
    expectParseError("normalmap_no_bsdf.xml", R"(<bsdf type="normalmap">
  <texture type="constant" name="normalmap"/>
</bsdf>)",
                     1, "nested");
    expectParseError("normalmap_bad_name.xml", R"(<bsdf type="normalmap">
  <bsdf type="diffuse"/>
  <texture type="constant" name="normals"/>
</bsdf>)",
                     1, "normals");
}

}  // namespace
}  // namespace alphorn
