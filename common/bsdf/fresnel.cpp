#include "common/bsdf/fresnel.h"

#include "common/core/common.h"

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

}  // namespace alphorn
