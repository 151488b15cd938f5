// Spectra to linear sRGB; see spectrum.h for the conventions.
#include "common/core/spectrum.h"

#include "common/core/error.h"

#include <absl/strings/str_format.h>

#include <array>
#include <cmath>
#include <map>
#include <string>

namespace alphorn {

// Optical constants at room temperature, from the publications named; the rows are the
// published values in the visible range (plus the nearest point outside it).
const std::vector<MeasuredMetal>& measuredMetals() {
    static const std::vector<MeasuredMetal> data = {
        // P. B. Johnson and R. W. Christy, "Optical constants of the noble metals", Phys. Rev. B
        // 6, 4370 (1972).
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
        {"Ag",
         {{0.3542, 0.10, 1.419},
          {0.3679, 0.07, 1.657},
          {0.3815, 0.05, 1.864},
          {0.3974, 0.05, 2.070},
          {0.4133, 0.05, 2.275},
          {0.4305, 0.04, 2.462},
          {0.4509, 0.04, 2.657},
          {0.4714, 0.05, 2.869},
          {0.4959, 0.05, 3.093},
          {0.5209, 0.05, 3.324},
          {0.5486, 0.06, 3.586},
          {0.5821, 0.05, 3.858},
          {0.6168, 0.06, 4.152},
          {0.6595, 0.05, 4.483},
          {0.7045, 0.04, 4.838},
          {0.7560, 0.03, 5.242},
          {0.8211, 0.04, 5.727},
          {0.8920, 0.04, 6.312}}},
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
        // A. D. Rakic, "Algorithm for the determination of intrinsic optical constants of metal
        // films: application to aluminum", Appl. Opt. 34, 4755 (1995).
        {"Al",
         {{0.30996, 0.28003, 3.7081},
          {0.32628, 0.31474, 3.9165},
          {0.36466, 0.39877, 4.3957},
          {0.41328, 0.52135, 5.0008},
          {0.44280, 0.60790, 5.3676},
          {0.47687, 0.72780, 5.7781},
          {0.51660, 0.87340, 6.2418},
          {0.56357, 1.0728, 6.7839},
          {0.61993, 1.3660, 7.4052},
          {0.65225, 1.5724, 7.7354},
          {0.68881, 1.8301, 8.0601},
          {0.72932, 2.1606, 8.3565},
          {0.77491, 2.6154, 8.4914},
          {0.79478, 2.7675, 8.3866},
          {0.81569, 2.7668, 8.2573},
          {0.83774, 2.6945, 8.1878},
          {0.88561, 2.2802, 8.1134}}},
        // Brass, 70% Cu and 30% Zn: M. R. Querry, "Optical constants", Contractor Report
        // CRDC-CR-85034 (1985).
        {"CuZn",
         {{0.36, 1.503, 1.815}, {0.38, 1.487, 1.818}, {0.40, 1.445, 1.805}, {0.42, 1.350, 1.786},
          {0.44, 1.191, 1.797}, {0.46, 0.994, 1.883}, {0.48, 0.816, 2.046}, {0.50, 0.686, 2.250},
          {0.52, 0.602, 2.464}, {0.54, 0.549, 2.668}, {0.56, 0.505, 2.860}, {0.58, 0.468, 3.059},
          {0.60, 0.450, 3.253}, {0.62, 0.449, 3.434}, {0.64, 0.444, 3.609}, {0.66, 0.445, 3.778},
          {0.68, 0.444, 3.943}, {0.70, 0.446, 4.106}, {0.72, 0.450, 4.266}, {0.74, 0.455, 4.424},
          {0.76, 0.458, 4.579}, {0.78, 0.464, 4.737}, {0.80, 0.473, 4.890}, {0.82, 0.481, 5.039},
          {0.84, 0.486, 5.192}}},
    };
    return data;
}

namespace {

// CIE 1931 2-degree standard observer colour-matching functions x, y, z and the CIE standard
// illuminant D65 (relative, 100 at 560 nm), every 5 nm from 360 to 830 nm, as published by the
// CIE (CIE 015:2018, Colorimetry, 4th edition, tables of the 1931 observer and of D65; the same
// values are distributed by the Colour & Vision Research Laboratory, cvrl.org).
constexpr int kCieCount = 95;
constexpr double kCieFirstNm = 360.0, kCieStepNm = 5.0;
constexpr float kCieX[kCieCount] = {
    0.0001299f,      0.0002321f,      0.0004149f,      0.0007416f,      0.001368f,
    0.002236f,       0.004243f,       0.00765f,        0.01431f,        0.02319f,
    0.04351f,        0.07763f,        0.13438f,        0.21477f,        0.2839f,
    0.3285f,         0.34828f,        0.34806f,        0.3362f,         0.3187f,
    0.2908f,         0.2511f,         0.19536f,        0.1421f,         0.09564f,
    0.05795001f,     0.03201f,        0.0147f,         0.0049f,         0.0024f,
    0.0093f,         0.0291f,         0.06327f,        0.1096f,         0.1655f,
    0.2257499f,      0.2904f,         0.3597f,         0.4334499f,      0.5120501f,
    0.5945f,         0.6784f,         0.7621f,         0.8425f,         0.9163f,
    0.9786f,         1.0263f,         1.0567f,         1.0622f,         1.0456f,
    1.0026f,         0.9384f,         0.8544499f,      0.7514f,         0.6424f,
    0.5419f,         0.4479f,         0.3608f,         0.2835f,         0.2187f,
    0.1649f,         0.1212f,         0.0874f,         0.0636f,         0.04677f,
    0.0329f,         0.0227f,         0.01584f,        0.01135916f,     0.008110916f,
    0.005790346f,    0.004109457f,    0.002899327f,    0.00204919f,     0.001439971f,
    0.0009999493f,   0.0006900786f,   0.0004760213f,   0.0003323011f,   0.0002348261f,
    0.0001661505f,   0.000117413f,    0.00008307527f,  0.00005870652f,  0.00004150994f,
    0.00002935326f,  0.00002067383f,  0.00001455977f,  0.00001025398f,  0.000007221456f,
    0.000005085868f, 0.000003581652f, 0.000002522525f, 0.000001776509f, 0.000001251141f,
};
constexpr float kCieY[kCieCount] = {
    0.000003917f,  0.000006965f,  0.00001239f,    0.00002202f,    0.000039f,      0.000064f,
    0.00012f,      0.000217f,     0.000396f,      0.00064f,       0.00121f,       0.00218f,
    0.004f,        0.0073f,       0.0116f,        0.01684f,       0.023f,         0.0298f,
    0.038f,        0.048f,        0.06f,          0.0739f,        0.09098f,       0.1126f,
    0.13902f,      0.1693f,       0.20802f,       0.2586f,        0.323f,         0.4073f,
    0.503f,        0.6082f,       0.71f,          0.7932f,        0.862f,         0.9148501f,
    0.954f,        0.9803f,       0.9949501f,     1.0f,           0.995f,         0.9786f,
    0.952f,        0.9154f,       0.87f,          0.8163f,        0.757f,         0.6949f,
    0.631f,        0.5668f,       0.503f,         0.4412f,        0.381f,         0.321f,
    0.265f,        0.217f,        0.175f,         0.1382f,        0.107f,         0.0816f,
    0.061f,        0.04458f,      0.032f,         0.0232f,        0.017f,         0.01192f,
    0.00821f,      0.005723f,     0.004102f,      0.002929f,      0.002091f,      0.001484f,
    0.001047f,     0.00074f,      0.00052f,       0.0003611f,     0.0002492f,     0.0001719f,
    0.00012f,      0.0000848f,    0.00006f,       0.0000424f,     0.00003f,       0.0000212f,
    0.00001499f,   0.0000106f,    0.0000074657f,  0.0000052578f,  0.0000037029f,  0.0000026078f,
    0.0000018366f, 0.0000012934f, 0.00000091093f, 0.00000064153f, 0.00000045181f,
};
constexpr float kCieZ[kCieCount] = {
    0.0006061f, 0.001086f,   0.001946f,    0.003486f,    0.006450001f, 0.01054999f,    0.02005001f,
    0.03621f,   0.06785001f, 0.1102f,      0.2074f,      0.3713f,      0.6456f,        1.0390501f,
    1.3856f,    1.62296f,    1.74706f,     1.7826f,      1.77211f,     1.7441f,        1.6692f,
    1.5281f,    1.28764f,    1.0419f,      0.8129501f,   0.6162f,      0.46518f,       0.3533f,
    0.272f,     0.2123f,     0.1582f,      0.1117f,      0.07824999f,  0.05725001f,    0.04216f,
    0.02984f,   0.0203f,     0.0134f,      0.008749999f, 0.005749999f, 0.0039f,        0.002749999f,
    0.0021f,    0.0018f,     0.001650001f, 0.0014f,      0.0011f,      0.001f,         0.0008f,
    0.0006f,    0.00034f,    0.00024f,     0.00019f,     0.0001f,      0.00004999999f, 0.00003f,
    0.00002f,   0.00001f,    0.0f,         0.0f,         0.0f,         0.0f,           0.0f,
    0.0f,       0.0f,        0.0f,         0.0f,         0.0f,         0.0f,           0.0f,
    0.0f,       0.0f,        0.0f,         0.0f,         0.0f,         0.0f,           0.0f,
    0.0f,       0.0f,        0.0f,         0.0f,         0.0f,         0.0f,           0.0f,
    0.0f,       0.0f,        0.0f,         0.0f,         0.0f,         0.0f,           0.0f,
    0.0f,       0.0f,        0.0f,         0.0f,
};
constexpr float kD65[kCieCount] = {
    46.6383f, 49.3637f, 52.0891f, 51.0323f, 49.9755f, 52.3118f, 54.6482f, 68.7015f, 82.7549f,
    87.1204f, 91.486f,  92.4589f, 93.4318f, 90.057f,  86.6823f, 95.7736f, 104.865f, 110.936f,
    117.008f, 117.41f,  117.812f, 116.336f, 114.861f, 115.392f, 115.923f, 112.367f, 108.811f,
    109.082f, 109.354f, 108.578f, 107.802f, 106.296f, 104.79f,  106.239f, 107.689f, 106.047f,
    104.405f, 104.225f, 104.046f, 102.023f, 100.0f,   98.1671f, 96.3342f, 96.0611f, 95.788f,
    92.2368f, 88.6856f, 89.3459f, 90.0062f, 89.8026f, 89.5991f, 88.6489f, 87.6987f, 85.4936f,
    83.2886f, 83.4939f, 83.6992f, 81.863f,  80.0268f, 80.1207f, 80.2146f, 81.2462f, 82.2778f,
    80.281f,  78.2842f, 74.0027f, 69.7213f, 70.6652f, 71.6091f, 72.979f,  74.349f,  67.9765f,
    61.604f,  65.7448f, 69.8856f, 72.4863f, 75.087f,  69.3398f, 63.5927f, 55.0054f, 46.4182f,
    56.6118f, 66.8054f, 65.0941f, 63.3828f, 63.8434f, 64.304f,  61.8779f, 59.4519f, 55.7054f,
    51.959f,  54.6998f, 57.4406f, 58.8765f, 60.3125f,
};

// XYZ to linear sRGB (IEC 61966-2-1, Rec. 709 primaries, D65 white).
constexpr double kXyzToRgb[3][3] = {{3.2404542, -1.5371385, -0.4985314},
                                    {-0.9692660, 1.8760108, 0.0415560},
                                    {0.0556434, -0.2040259, 1.0572252}};

// Integration is at 1 nm over the tabulated range, with the tables interpolated linearly, so
// that sampled spectra with finer detail than 5 nm are not aliased.
constexpr double kLambdaMin = 360.0, kLambdaMax = 830.0;

double tableAt(const float* table, double lambda) {
    const double x = (lambda - kCieFirstNm) / kCieStepNm;
    if (x <= 0.0) return table[0];
    if (x >= kCieCount - 1) return table[kCieCount - 1];
    const int i = static_cast<int>(x);
    const double t = x - i;
    return (1.0 - t) * table[i] + t * table[i + 1];
}

template <typename Spectrum>
std::array<double, 3> xyzOf(const Spectrum& s, bool weightByD65) {
    std::array<double, 3> xyz{0.0, 0.0, 0.0};
    for (double lambda = kLambdaMin; lambda <= kLambdaMax; lambda += 1.0) {
        const double v = s(lambda) * (weightByD65 ? tableAt(kD65, lambda) : 1.0);
        xyz[0] += v * tableAt(kCieX, lambda);
        xyz[1] += v * tableAt(kCieY, lambda);
        xyz[2] += v * tableAt(kCieZ, lambda);
    }
    return xyz;
}

std::array<double, 3> rgbOfXyz(const std::array<double, 3>& xyz) {
    std::array<double, 3> rgb{};
    for (int i = 0; i < 3; ++i)
        rgb[i] = kXyzToRgb[i][0] * xyz[0] + kXyzToRgb[i][1] * xyz[1] + kXyzToRgb[i][2] * xyz[2];
    return rgb;
}

// The projection of spectrum.h: Reflectance and Unbounded under D65, normalised channel by
// channel so that a constant 1 is exactly (1, 1, 1); Illuminant over the integral of y.
template <typename Spectrum>
Color3f project(const Spectrum& s, SpectrumUse use) {
    if (use == SpectrumUse::Illuminant) {
        const std::array<double, 3> xyz = xyzOf(s, false);
        const double yIntegral = xyzOf([](double) { return 1.0; }, false)[1];
        const std::array<double, 3> rgb =
            rgbOfXyz({xyz[0] / yIntegral, xyz[1] / yIntegral, xyz[2] / yIntegral});
        return Color3f(float(rgb[0]), float(rgb[1]), float(rgb[2]));
    }
    static const std::array<double, 3> white = rgbOfXyz(xyzOf([](double) { return 1.0; }, true));
    const std::array<double, 3> rgb = rgbOfXyz(xyzOf(s, true));
    return Color3f(float(rgb[0] / white[0]), float(rgb[1] / white[1]), float(rgb[2] / white[2]));
}

// Piecewise-linear (lambda in nm, value) data, constant beyond its ends (the measurements below
// cover 360-830 nm, or nearly: holding the end values is the smallest assumption).
struct Tabulated {
    std::vector<double> lambda, value;
    bool zeroOutside = false;
    double operator()(double l) const {
        if (l <= lambda.front()) return zeroOutside && l < lambda.front() ? 0.0 : value.front();
        if (l >= lambda.back()) return zeroOutside && l > lambda.back() ? 0.0 : value.back();
        size_t i = 1;
        while (lambda[i] < l) ++i;
        const double t = (l - lambda[i - 1]) / (lambda[i] - lambda[i - 1]);
        return (1.0 - t) * value[i - 1] + t * value[i];
    }
};

// Transparent crystals that pbrt-v4 lists among its metals, by their dispersion formulas
// (lambda in micrometres), with k = 0 in the visible:
// MgO: R. E. Stephens and I. H. Malitson, J. Res. Natl. Bur. Stand. 49, 249 (1952);
// TiO2 (rutile, ordinary ray): J. R. DeVore, J. Opt. Soc. Am. 41, 416 (1951), valid from 430 nm
// (held at its 430 nm value below, towards its absorption edge).
double mgoIndex(double um) {
    const double l2 = um * um;
    return std::sqrt(2.956362 + 0.02195770 / (l2 - 0.01428322) - 0.01062387 * l2 -
                     0.0000204968 * l2 * l2);
}
double tio2Index(double um) {
    const double l2 = std::max(um, 0.43) * std::max(um, 0.43);
    return std::sqrt(5.913 + 0.2441 / (l2 - 0.0803));
}

// Schott's Sellmeier coefficients (B1, C1, B2, C2, B3, C3; lambda in micrometres) from the
// SCHOTT optical glass catalogue (2017), for pbrt-v4's glass names.
struct Glass {
    const char* name;
    double b1, c1, b2, c2, b3, c3;
};
constexpr Glass kGlasses[] = {
    {"glass-BK7", 1.03961212, 0.00600069867, 0.231792344, 0.0200179144, 1.01046945, 103.560653},
    {"glass-BAF10", 1.5851495, 0.00926681282, 0.143559385, 0.0424489805, 1.08521269, 105.613573},
    {"glass-FK51A", 0.971247817, 0.00472301995, 0.216901417, 0.0153575612, 0.904651666, 168.68133},
    {"glass-LASF9", 2.00029547, 0.0121426017, 0.298926886, 0.0538736236, 1.80691843, 156.530829},
    {"glass-F5", 1.46141885, 0.0111826126, 0.247713019, 0.0508594669, 0.949995832, 112.041888},
    {"glass-F10", 1.62153902, 0.0122241457, 0.256287842, 0.0595736775, 1.64447552, 147.468793},
    {"glass-F11", 1.73759695, 0.013188707, 0.313747346, 0.0623068142, 1.89878101, 155.23629},
};
constexpr double kGlassWavelengthUm = 0.55;

double sellmeier(const Glass& g, double um) {
    const double l2 = um * um;
    return std::sqrt(1.0 + g.b1 * l2 / (l2 - g.c1) + g.b2 * l2 / (l2 - g.c2) +
                     g.b3 * l2 / (l2 - g.c3));
}

struct ConductorRgb {
    Color3f eta, k;
};

// The RGB (eta, k) of spectral (n, k), by the method of spectrum.h: eta is the projection of n;
// k is chosen per channel so that the RGB normal-incidence reflectance equals the projection
// of the spectral one. Where even k = 0 would reflect too much, k is 0 and eta is lowered to
// the index that reflects the target alone.
template <typename N, typename K>
ConductorRgb fitConductor(const N& n, const K& k) {
    const Color3f eta = project(n, SpectrumUse::Unbounded);
    const Color3f target = project(
        [&](double l) {
            const double nl = n(l), kl = k(l);
            return ((nl - 1) * (nl - 1) + kl * kl) / ((nl + 1) * (nl + 1) + kl * kl);
        },
        SpectrumUse::Reflectance);
    ConductorRgb out;
    for (int c = 0; c < 3; ++c) {
        const double R = std::clamp(double(target[c]), 0.0, 0.9999);
        const double e = eta[c];
        const double k2 = (R * (e + 1) * (e + 1) - (e - 1) * (e - 1)) / (1.0 - R);
        if (k2 >= 0.0) {
            out.eta[c] = float(e);
            out.k[c] = float(std::sqrt(k2));
        } else {
            const double s = std::sqrt(R);
            // Both (1 + s) / (1 - s) and its inverse reflect R; keep eta's side of 1.
            out.eta[c] = float(e >= 1.0 ? (1 + s) / (1 - s) : (1 - s) / (1 + s));
            out.k[c] = 0.0f;
        }
    }
    return out;
}

const std::map<std::string, ConductorRgb>& conductors() {
    static const std::map<std::string, ConductorRgb> table = [] {
        std::map<std::string, ConductorRgb> t;
        for (const MeasuredMetal& m : measuredMetals()) {
            Tabulated n, k;
            for (const auto& row : m.rows) {
                n.lambda.push_back(row[0] * 1000.0);
                n.value.push_back(row[1]);
                k.lambda.push_back(row[0] * 1000.0);
                k.value.push_back(row[2]);
            }
            t[m.name] = fitConductor(n, k);
        }
        const auto zero = [](double) { return 0.0; };
        t["MgO"] = fitConductor([](double l) { return mgoIndex(l / 1000.0); }, zero);
        t["TiO2"] = fitConductor([](double l) { return tio2Index(l / 1000.0); }, zero);
        return t;
    }();
    return table;
}

// CIE standard illuminant A, a Planckian radiator of 2856 K by its CIE definition (relative,
// 100 at 560 nm; the CIE formula uses c2 = 1.435e7 nm K and T = 2848 K).
double illuminantA(double lambda) {
    const double c = 1.435e7 / 2848.0;
    return 100.0 * std::pow(560.0 / lambda, 5.0) * std::expm1(c / 560.0) / std::expm1(c / lambda);
}

}  // namespace

std::optional<Color3f> namedSpectrumRgb(std::string_view name, SpectrumUse use) {
    const std::string key(name);
    for (const Glass& g : kGlasses)
        if (key == g.name) return Color3f(float(sellmeier(g, kGlassWavelengthUm)));
    if (key.rfind("metal-", 0) == 0) {
        const size_t dash = key.rfind('-');
        const std::string metal = key.substr(6, dash - 6), part = key.substr(dash + 1);
        const auto it = conductors().find(metal);
        if (it == conductors().end() || dash <= 6) return std::nullopt;
        if (part == "eta") return it->second.eta;
        if (part == "k") return it->second.k;
        return std::nullopt;
    }
    if (key == "stdillum-D65") return project([](double l) { return tableAt(kD65, l); }, use);
    if (key == "stdillum-A") return project(illuminantA, use);
    return std::nullopt;
}

Color3f sampledSpectrumRgb(const std::vector<float>& lambdaNm, const std::vector<float>& values,
                           SpectrumUse use) {
    if (lambdaNm.size() != values.size())
        throw Error(
            absl::StrFormat("a sampled spectrum needs as many values as wavelengths "
                            "(%d wavelengths, %d values)",
                            lambdaNm.size(), values.size()));
    if (lambdaNm.size() < 2)
        throw Error(
            absl::StrFormat("a sampled spectrum needs at least 2 points, got %d", lambdaNm.size()));
    Tabulated s;
    s.zeroOutside = true;
    for (size_t i = 0; i < lambdaNm.size(); ++i) {
        if (!std::isfinite(lambdaNm[i]) || !std::isfinite(values[i]))
            throw Error(
                absl::StrFormat("a sampled spectrum has a non-finite entry at point %d", i + 1));
        if (i > 0 && !(lambdaNm[i] > lambdaNm[i - 1]))
            throw Error(
                absl::StrFormat("the wavelengths of a sampled spectrum must increase "
                                "(%g nm follows %g nm)",
                                lambdaNm[i], lambdaNm[i - 1]));
        s.lambda.push_back(lambdaNm[i]);
        s.value.push_back(values[i]);
    }
    return project(s, use);
}

Color3f blackbodyRgb(float kelvin) {
    if (!(kelvin > 0.0f) || !std::isfinite(kelvin))
        throw Error(
            absl::StrFormat("a blackbody temperature must be positive and finite, got %g", kelvin));
    // Planck's law in wavelength; the constant factor 2 h c^2 cancels in the normalisation.
    const double c2 = 1.438776877e7;  // h c / k_B in nm K
    const double T = kelvin;
    const auto planck = [&](double lambda) {
        return 1.0 / (std::pow(lambda, 5.0) * std::expm1(c2 / (lambda * T)));
    };
    // Wien's displacement law gives the peak: b = 2.897771955e6 nm K.
    const double peak = planck(2.897771955e6 / T);
    return project([&](double lambda) { return planck(lambda) / peak; }, SpectrumUse::Illuminant);
}

}  // namespace alphorn
