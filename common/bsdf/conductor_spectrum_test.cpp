// The RGB conductors fitted from measured spectra (spectrum.h): at normal incidence the RGB
// Fresnel term must reflect what the spectral one does, projected to RGB, within 1% per channel;
// towards grazing incidence the two differ, by the amount spectrum.h states. The spectral side
// is computed here from the published optical constants (Johnson and Christy, Phys. Rev. B 6,
// 4370 (1972)), interpolated at 1 nm, with the Fresnel term per wavelength.
#include "common/bsdf/fresnel.h"
#include "common/core/spectrum.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <vector>

namespace alphorn {
namespace {

struct Metal {
    const char* name;
    std::vector<std::array<double, 3>> rows;  // micrometres, n, k
};

const std::vector<Metal>& measured() {
    static const std::vector<Metal> metals = {
        {"Au",
         {{0.3542, 1.50, 1.866},
          {0.3679, 1.48, 1.895},
          {0.3815, 1.46, 1.933},
          {0.3974, 1.47, 1.952},
          {0.4133, 1.46, 1.958},
          {0.4305, 1.45, 1.948},
          {0.4509, 1.38, 1.914},
          {0.4714, 1.31, 1.849},
          {0.4959, 1.04, 1.833},
          {0.5209, 0.62, 2.081},
          {0.5486, 0.43, 2.455},
          {0.5821, 0.29, 2.863},
          {0.6168, 0.21, 3.272},
          {0.6595, 0.14, 3.697},
          {0.7045, 0.13, 4.103},
          {0.7560, 0.14, 4.542},
          {0.8211, 0.16, 5.083},
          {0.8920, 0.17, 5.663}}},
        {"Cu",
         {{0.3542, 1.37, 1.916},
          {0.3679, 1.36, 1.975},
          {0.3815, 1.33, 2.045},
          {0.3974, 1.32, 2.116},
          {0.4133, 1.28, 2.207},
          {0.4305, 1.25, 2.305},
          {0.4509, 1.24, 2.397},
          {0.4714, 1.25, 2.483},
          {0.4959, 1.22, 2.564},
          {0.5209, 1.18, 2.608},
          {0.5486, 1.02, 2.577},
          {0.5821, 0.70, 2.704},
          {0.6168, 0.30, 3.205},
          {0.6595, 0.22, 3.747},
          {0.7045, 0.21, 4.205},
          {0.7560, 0.24, 4.665},
          {0.8211, 0.26, 5.180},
          {0.8920, 0.30, 5.768}}},
    };
    return metals;
}

// The spectral Fresnel reflectance at cosI projected to RGB as a reflectance.
Color3f spectralReflectance(const Metal& m, float cosI) {
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
    for (const Metal& m : measured()) {
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
    for (const Metal& m : measured()) {
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
