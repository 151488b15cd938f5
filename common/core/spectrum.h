// pbrt-v4's spectra as linear sRGB (Rec. 709 primaries, D65 white), for the pbrt scene front
// end: Alphorn renders in RGB, so every spectrum a scene names or tabulates is projected once,
// when the scene is loaded.
//
// Projection: a spectrum s(lambda) becomes CIE 1931 XYZ (integrated at 1 nm over 360-830 nm),
// then linear sRGB by the standard XYZ-to-sRGB matrix, normalised by how it is used:
//   Reflectance  XYZ of s(lambda) D65(lambda) over the Y of D65, then each RGB channel over
//                that of a constant 1: a constant c gives exactly (c, c, c).
//   Unbounded    (indices of refraction, extinction coefficients, scale factors) the same.
//   Illuminant   XYZ of s(lambda) itself over the integral of y(lambda) (pbrt-v4's
//                SpectrumToXYZ): a constant 1 has Y = 1; the CIE D65 table (100 at 560 nm) is
//                neutral; brightness normalisation (pbrt-v4 divides a
//                light's spectrum by its Y and multiplies by `scale`/`power`) is left to the
//                front end.
// The colour-matching functions are the CIE 1931 2-degree observer at 5 nm from 360 to 830 nm.
//
// Conductors: the named metal-*-eta / metal-*-k pairs are not projected channel by channel.
// Instead the channel's eta is the spectral n projected to RGB (as Unbounded), and its k is
// solved so that the RGB model's normal-incidence reflectance ((eta-1)^2 + k^2) / ((eta+1)^2 +
// k^2) equals the spectral normal-incidence reflectance projected to RGB (as a Reflectance). The
// RGB conductor is therefore right at normal incidence by construction (the unit test checks 1%
// per channel), except where the projection leaves the sRGB gamut: gold's red channel projects
// to 1.037, which no reflectance can be, and is fitted to 0.9999. Towards grazing incidence the
// RGB model's Fresnel curve is not the projection of the spectral curves: for gold and copper
// the difference stays below 0.009 in reflectance at every angle up to 85 degrees (measured by
// the unit test, against the in-gamut target), the price of RGB.
#pragma once

#include "common/core/color.h"

#include <array>
#include <optional>
#include <string_view>
#include <vector>

namespace alphorn {

enum class SpectrumUse { Reflectance, Unbounded, Illuminant };

// A metal's published optical constants, rows of (wavelength in micrometres, n, k), to which
// the named conductor spectra below are fitted (the publications are named at the table).
struct MeasuredMetal {
    const char* name;
    std::vector<std::array<double, 3>> rows;
};
const std::vector<MeasuredMetal>& measuredMetals();

// The linear sRGB of one of pbrt-v4's named spectra, or nothing for a name this table does not
// know. Known: metal-{Au,Ag,Al,Cu,CuZn,MgO,TiO2}-{eta,k} (the conductor fits above, whatever
// `use` says), glass-{BK7,BAF10,FK51A,LASF9,F5,F10,F11} and stdillum-{D65,A}; not yet the
// stdillum-F* fluorescent illuminants, stdillum-D50 or illum-acesD60. The glass-* spectra are
// indices of refraction, which a dielectric uses as one number: each is returned as the same
// value in all three channels, the index at 550 nm (the wavelength near the eye's sensitivity
// peak; pbrt-v4 renders them with dispersion, Alphorn without).
std::optional<Color3f> namedSpectrumRgb(std::string_view name, SpectrumUse use);

// A piecewise-linear spectrum given at wavelengths lambdaNm (increasing, in nanometres) with
// `values`, zero outside its range, projected to linear sRGB. Throws Error (with what is wrong)
// for mismatched sizes, fewer than 2 points, non-increasing wavelengths or non-finite values.
Color3f sampledSpectrumRgb(const std::vector<float>& lambdaNm, const std::vector<float>& values,
                           SpectrumUse use);

// pbrt-v4's "blackbody" spectrum of temperature `kelvin`: Planck's law normalised so that its
// maximum over wavelength is 1, projected as an Illuminant. Throws Error for kelvin <= 0.
Color3f blackbodyRgb(float kelvin);

}  // namespace alphorn
