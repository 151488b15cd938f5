// The RGB conductors fitted from measured spectra (spectrum.h): at normal incidence the RGB
// Fresnel term must reflect what the spectral one does, projected to RGB, within 1% per channel;
// towards grazing incidence the two differ, by the amount spectrum.h states. The spectral side
// is computed here from the published optical constants the fit is made from (Johnson and
// Christy, Phys. Rev. B 6, 4370 (1972)), interpolated at 1 nm, with the Fresnel term per
// wavelength.
#include "common/bsdf/fresnel.h"
#include "common/core/spectrum.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

namespace alphorn {
namespace {

// The metals tested, gold and copper, with the constants the fit reads (spectrum.h's table).
std::vector<MeasuredMetal> measured() {
    std::vector<MeasuredMetal> tested;
    for (const MeasuredMetal& m : measuredMetals())
        if (std::string(m.name) == "Au" || std::string(m.name) == "Cu") tested.push_back(m);
    return tested;
}

// The spectral Fresnel reflectance at cosI projected to RGB as a reflectance.
Color3f spectralReflectance(const MeasuredMetal& m, float cosI) {
    std::vector<float> lambda, value;
    for (int nm = 360; nm <= 830; ++nm) {
        const double um = nm / 1000.0;
        size_t i = 1;
        while (i + 1 < m.rows.size() && m.rows[i][0] < um) ++i;
        const double t =
            std::clamp((um - m.rows[i - 1][0]) / (m.rows[i][0] - m.rows[i - 1][0]), 0.0, 1.0);
        const double n = (1 - t) * m.rows[i - 1][1] + t * m.rows[i][1];
        const double k = (1 - t) * m.rows[i - 1][2] + t * m.rows[i][2];
        lambda.push_back(float(nm));
        value.push_back(fresnelConductor(cosI, Color3f(float(n)), Color3f(float(k))).r());
    }
    return sampledSpectrumRgb(lambda, value, SpectrumUse::Reflectance);
}

TEST(ConductorSpectra, NormalIncidenceMatchesTheSpectralProjection) {
    ASSERT_EQ(measured().size(), 2u);  // the table still names both
    for (const MeasuredMetal& m : measured()) {
        const std::string name = m.name;
        const Color3f eta =
            namedSpectrumRgb("metal-" + name + "-eta", SpectrumUse::Unbounded).value();
        const Color3f k = namedSpectrumRgb("metal-" + name + "-k", SpectrumUse::Unbounded).value();
        const Color3f rgb = fresnelConductor(1.0f, eta, k);
        const Color3f spectral = spectralReflectance(m, 1.0f);
        for (int c = 0; c < 3; ++c) {
            // Gold's red is outside the sRGB gamut (its projection exceeds 1, which no
            // reflectance can): the fit holds it at 0.9999, as spectrum.h says.
            const float target = std::min(spectral[c], 0.9999f);
            EXPECT_NEAR(rgb[c], target, 0.01f * target) << name << " " << c;
        }
    }
    // Gold and copper are warm: red reflects more than blue.
    for (const char* name : {"Au", "Cu", "CuZn"}) {
        const std::string n = name;
        const Color3f R = fresnelConductor(
            1.0f, namedSpectrumRgb("metal-" + n + "-eta", SpectrumUse::Unbounded).value(),
            namedSpectrumRgb("metal-" + n + "-k", SpectrumUse::Unbounded).value());
        EXPECT_GT(R.r(), R.b() + 0.2f) << name;
    }
    for (const char* name : {"Ag", "Al", "MgO", "TiO2"}) {
        const std::string n = name;
        ASSERT_TRUE(namedSpectrumRgb("metal-" + n + "-eta", SpectrumUse::Unbounded)) << name;
        ASSERT_TRUE(namedSpectrumRgb("metal-" + n + "-k", SpectrumUse::Unbounded)) << name;
    }
}

// The price of RGB: away from normal incidence the RGB model's Fresnel curve is not the
// projection of the spectral curves. Measured here every 5 degrees; spectrum.h states the bound.
TEST(ConductorSpectra, GrazingAngleDifferenceIsSmall) {
    for (const MeasuredMetal& m : measured()) {
        const std::string name = m.name;
        const Color3f eta =
            namedSpectrumRgb("metal-" + name + "-eta", SpectrumUse::Unbounded).value();
        const Color3f k = namedSpectrumRgb("metal-" + name + "-k", SpectrumUse::Unbounded).value();
        float worst = 0.0f;
        for (int deg = 0; deg <= 85; deg += 5) {
            const float cosI = std::cos(float(deg) * float(M_PI) / 180.0f);
            const Color3f diff =
                (fresnelConductor(cosI, eta, k) - spectralReflectance(m, cosI).min(0.9999f)).abs();
            worst = std::max(worst, diff.maxCoeff());
        }
        EXPECT_LT(worst, 0.02f) << name;  // the bound spectrum.h states
        std::printf("%s: largest RGB-vs-spectral Fresnel difference up to 85 degrees: %.4f\n",
                    m.name, worst);
    }
}

}  // namespace
}  // namespace alphorn
