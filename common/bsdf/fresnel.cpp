#include "common/bsdf/fresnel.h"

#include "common/core/common.h"

#include <complex>

namespace alphorn {

float fresnelDielectric(float cosThetaI, float extIOR, float intIOR) {
    float etaI = extIOR, etaT = intIOR;
    // Index-matched: no interface at all, so nothing is reflected (and no 0/0 below).
    if (extIOR == intIOR) return 0.0f;
    if (cosThetaI < 0.0f) {
        std::swap(etaI, etaT);
        cosThetaI = -cosThetaI;
    }
    cosThetaI = std::min(cosThetaI, 1.0f);
    // Snell's law gives the transmitted sine; beyond the critical angle everything reflects.
    const float eta = etaI / etaT;
    const float sinThetaTSqr = eta * eta * (1.0f - cosThetaI * cosThetaI);
    if (sinThetaTSqr >= 1.0f) return 1.0f;
    const float cosThetaT = std::sqrt(1.0f - sinThetaTSqr);
    const float rs = (etaI * cosThetaI - etaT * cosThetaT) / (etaI * cosThetaI + etaT * cosThetaT);
    const float rp = (etaT * cosThetaI - etaI * cosThetaT) / (etaT * cosThetaI + etaI * cosThetaT);
    return 0.5f * (rs * rs + rp * rp);
}

namespace {

// One channel. With the complex index n = eta + i k, Snell's law gives a complex cos(theta_t),
// and the s and p amplitudes keep the dielectric's form; their squared moduli are the
// reflectances. Computed in double: for large k the two terms of each amplitude nearly cancel.
float conductorChannel(double cosI, double eta, double k) {
    using Complex = std::complex<double>;
    const Complex n(eta, k);
    const double sin2I = 1.0 - cosI * cosI;
    const Complex cosT = std::sqrt(1.0 - sin2I / (n * n));
    const Complex rs = (cosI - n * cosT) / (cosI + n * cosT);
    const Complex rp = (n * cosI - cosT) / (n * cosI + cosT);
    return static_cast<float>(0.5 * (std::norm(rs) + std::norm(rp)));
}

}  // namespace

Color3f fresnelConductor(float cosThetaI, const Color3f& eta, const Color3f& k) {
    const double cosI = std::clamp(static_cast<double>(cosThetaI), 0.0, 1.0);
    return Color3f(conductorChannel(cosI, eta.r(), k.r()), conductorChannel(cosI, eta.g(), k.g()),
                   conductorChannel(cosI, eta.b(), k.b()));
}

}  // namespace alphorn
