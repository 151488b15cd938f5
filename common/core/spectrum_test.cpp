// Unit tests of the spectrum-to-RGB projections: the normalisations spectrum.h promises, the
// refusals of malformed spectra, and the blackbody against Planck's law sampled here.
#include "common/core/spectrum.h"

#include "common/core/error.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace alphorn {
namespace {

TEST(Spectrum, ConstantReflectanceIsGrey) {
    const Color3f one =
        sampledSpectrumRgb({300.0f, 900.0f}, {1.0f, 1.0f}, SpectrumUse::Reflectance);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(one[c], 1.0f, 1e-5f);
    const Color3f half = sampledSpectrumRgb({300.0f, 900.0f}, {0.5f, 0.5f}, SpectrumUse::Unbounded);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(half[c], 0.5f, 1e-5f);
    // A reflectance only above 600 nm is red (so saturated that green and blue leave the sRGB
    // gamut, slightly below 0).
    const Color3f red =
        sampledSpectrumRgb({599.0f, 600.0f, 830.0f}, {0.0f, 1.0f, 1.0f}, SpectrumUse::Reflectance);
    EXPECT_GT(red.r(), 0.5f);
    EXPECT_GT(red.r(), 10.0f * std::max({red.g(), red.b(), 0.0f}));
}

TEST(Spectrum, D65IsNeutralAndEqualEnergyHasUnitLuminance) {
    const Color3f d65 = namedSpectrumRgb("stdillum-D65", SpectrumUse::Illuminant).value();
    EXPECT_NEAR(d65.r() / d65.g(), 1.0f, 2e-3f);
    EXPECT_NEAR(d65.b() / d65.g(), 1.0f, 2e-3f);
    const Color3f e = sampledSpectrumRgb({360.0f, 830.0f}, {1.0f, 1.0f}, SpectrumUse::Illuminant);
    EXPECT_NEAR(e.luminance(), 1.0f, 2e-3f);
    // Illuminant A (2856 K) is orange: red above green above blue.
    const Color3f a = namedSpectrumRgb("stdillum-A", SpectrumUse::Illuminant).value();
    EXPECT_GT(a.r(), a.g());
    EXPECT_GT(a.g(), a.b());
    EXPECT_FALSE(namedSpectrumRgb("stdillum-nonsense", SpectrumUse::Illuminant).has_value());
    EXPECT_FALSE(namedSpectrumRgb("metal-Xx-eta", SpectrumUse::Unbounded).has_value());
}

TEST(Spectrum, GlassesAreTheirIndexAt550nm) {
    // BK7's catalogue index n_d (587.6 nm) is 1.5168; at 550 nm it is slightly higher.
    const Color3f bk7 = namedSpectrumRgb("glass-BK7", SpectrumUse::Unbounded).value();
    EXPECT_EQ(bk7.r(), bk7.b());
    EXPECT_GT(bk7.r(), 1.5168f);
    EXPECT_LT(bk7.r(), 1.52f);
    for (const char* name :
         {"glass-BAF10", "glass-FK51A", "glass-LASF9", "glass-F5", "glass-F10", "glass-F11"}) {
        const auto eta = namedSpectrumRgb(name, SpectrumUse::Unbounded);
        ASSERT_TRUE(eta.has_value()) << name;
        EXPECT_GT(eta->r(), 1.4f) << name;
        EXPECT_LT(eta->r(), 1.9f) << name;
    }
}

TEST(Spectrum, MalformedSpectraAreRefusedWithAReason) {
    auto message = [](const std::vector<float>& l, const std::vector<float>& v) -> std::string {
        try {
            sampledSpectrumRgb(l, v, SpectrumUse::Reflectance);
        } catch (const Error& e) {
            return e.what();
        }
        return "";
    };
    EXPECT_NE(message({400, 500}, {1}).find("as many values"), std::string::npos);
    EXPECT_NE(message({400}, {1}).find("at least 2"), std::string::npos);
    EXPECT_NE(message({500, 400}, {1, 1}).find("must increase"), std::string::npos);
    EXPECT_NE(message({400, NAN}, {1, 1}).find("non-finite"), std::string::npos);
    EXPECT_THROW(blackbodyRgb(0.0f), Error);
    EXPECT_THROW(blackbodyRgb(-5.0f), Error);
}

// The blackbody is Planck's law over its maximum: the same as that spectrum sampled at 1 nm
// here and projected as a sampled illuminant.
TEST(Spectrum, BlackbodyIsNormalisedPlanck) {
    for (float kelvin : {2000.0f, 6500.0f, 12000.0f}) {
        std::vector<float> lambda, value;
        double peak = 0.0;
        const double h = 6.62607015e-34, c = 2.99792458e8, k = 1.380649e-23;
        auto planck = [&](double nm) {
            const double l = nm * 1e-9;
            return 2.0 * h * c * c /
                   (std::pow(l, 5.0) * (std::exp(h * c / (l * k * kelvin)) - 1.0));
        };
        for (double nm = 100.0; nm < 20000.0; nm += 0.5) peak = std::max(peak, planck(nm));
        for (int nm = 360; nm <= 830; ++nm) {
            lambda.push_back(float(nm));
            value.push_back(float(planck(nm) / peak));
        }
        const Color3f expected = sampledSpectrumRgb(lambda, value, SpectrumUse::Illuminant);
        const Color3f got = blackbodyRgb(kelvin);
        for (int ch = 0; ch < 3; ++ch)
            EXPECT_NEAR(got[ch], expected[ch], 1e-3f * std::abs(expected[ch]) + 1e-6f)
                << kelvin << " " << ch;
    }
    EXPECT_GT(blackbodyRgb(2000.0f).r(), blackbodyRgb(2000.0f).b());
    EXPECT_LT(blackbodyRgb(12000.0f).r(), blackbodyRgb(12000.0f).b());
}

}  // namespace
}  // namespace alphorn
