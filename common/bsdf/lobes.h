// The scattering lobes that the pbrt-v4 style BSDFs are made of: a dielectric interface (smooth
// or GGX-rough, reflection and transmission), a conductor (smooth or GGX-rough) and a Lambertian
// reflector, each with f(), pdf() and sample() in the form the layered BSDF's random walk needs:
// restricted to reflection or transmission on request, for radiance or importance transport,
// and defined on both sides of the surface. The conductor, rough dielectric and coated plugins
// are thin wrappers around them, so that a coat's interface is the same model as a plain rough
// dielectric.
//
// Directions follow BSDFQueryRecord: `wi` is the fixed direction (towards the camera when
// transporting radiance), `wo` the sampled or queried one, both pointing away from the surface,
// in the local frame (normal +z).
#pragma once

#include "common/bsdf/bsdf.h"
#include "common/bsdf/fresnel.h"
#include "common/bsdf/microfacet_distribution.h"
#include "common/core/color.h"
#include "common/core/frame.h"
#include "common/core/rng.h"
#include "common/core/warp.h"

#include <cstring>
#include <optional>

namespace alphorn::lobes {

// Radiance: wi leads towards the camera, and refraction scales the value by 1 / eta^2 (radiance
// divided by n^2 is what crosses an interface unchanged). Importance: the adjoint, unscaled.
enum class Transport { Radiance, Importance };
inline Transport adjoint(Transport mode) {
    return mode == Transport::Radiance ? Transport::Importance : Transport::Radiance;
}

// Which half of a lobe sample() and pdf() may use.
enum class Half { Reflection = 1, Transmission = 2, Both = 3 };
inline bool allows(Half half, Half part) {
    return (static_cast<int>(half) & static_cast<int>(part)) != 0;
}

struct Sample {
    Vector3f wo = Vector3f::Zero();
    Color3f f = Color3f(0.0f);  // the lobe's value (for a delta: its weight over |cos theta_o|)
    float pdf = 0.0f;           // solid-angle density, or the choice's probability for a delta
    float eta = 1.0f;           // relative index along wo (transmitted over incident side)
    bool specular = false;
    bool reflection = true;
};

// Writes a lobe's sample into the query (wo, eta, measure) and returns sample()'s weight, f
// |cos theta_o| / pdf, or zero where that is not finite. `eta` is the relative index along wo.
inline Color3f recordSample(BSDFQueryRecord& rec, const Sample& s, float eta) {
    rec.wo = s.wo;
    rec.eta = eta;
    rec.measure = s.specular ? Measure::Discrete : Measure::SolidAngle;
    const Color3f weight = s.f * std::abs(s.wo.z()) / s.pdf;
    return weight.allFinite() ? weight : Color3f(0.0f);
}

// A uniform number in [0, 1) made from the bits of a 2D sample, for a BSDF whose sample() needs a
// third number (a lobe choice that depends on the sampled microfacet). Being discontinuous
// everywhere, it is independent of the sample's smooth uses for all practical purposes, and it
// is deterministic: the same sample gives the same path on every thread and machine.
inline uint64_t bitsOf(float x) {
    uint32_t b;
    std::memcpy(&b, &x, sizeof(b));
    return b;
}
inline float hashToUnit(const Point2f& u) {
    return static_cast<float>(mix64((bitsOf(u.x()) << 32) | bitsOf(u.y())) >> 40) * 0x1p-24f;
}

inline bool sameHemisphere(const Vector3f& a, const Vector3f& b) {
    return a.z() * b.z() > 0.0f;
}
inline Vector3f reflectAboutNormal(const Vector3f& w) {
    return Vector3f(-w.x(), -w.y(), w.z());
}
inline Vector3f reflectAbout(const Vector3f& w, const Vector3f& n) {
    return 2.0f * w.dot(n) * n - w;
}

// Refracts w (pointing away from the surface) through the interface with normal n and relative
// index eta (inside over outside, the inside being the side n does not point to). Returns false
// under total internal reflection; otherwise sets wt and the relative index along it.
inline bool refract(const Vector3f& w, Vector3f n, float eta, Vector3f& wt, float& etaT) {
    float cosI = n.dot(w);
    if (cosI < 0.0f) {
        eta = 1.0f / eta;
        cosI = -cosI;
        n = -n;
    }
    const float sin2T = std::max(0.0f, 1.0f - cosI * cosI) / (eta * eta);
    if (sin2T >= 1.0f) return false;
    const float cosT = std::sqrt(1.0f - sin2T);
    wt = -w / eta + (cosI / eta - cosT) * n;
    etaT = eta;
    return true;
}

// Fresnel reflectance for relative index eta (inside over outside); cosI < 0 arrives from inside.
inline float fresnel(float cosI, float eta) {
    return fresnelDielectric(cosI, 1.0f, eta);
}

// A dielectric interface of relative index eta (below the surface over above it).
struct Dielectric {
    float eta = 1.5f;
    TrowbridgeReitz distribution;

    // An index-matched interface passes light straight through (a delta), rough or not.
    bool specular() const { return eta == 1.0f || distribution.effectivelySmooth(); }

    Color3f f(const Vector3f& wi, const Vector3f& wo, Transport mode) const {
        if (specular()) return Color3f(0.0f);
        HalfVector h;
        if (!halfVector(wi, wo, h)) return Color3f(0.0f);
        const float F = fresnel(wi.dot(h.wm), eta);
        const float D = distribution.D(h.wm), G = distribution.G(wi, wo);
        if (h.reflection) return Color3f(D * G * F / std::abs(4.0f * wi.z() * wo.z()));
        const float denom = sqr(wo.dot(h.wm) + wi.dot(h.wm) / h.etaT) * wo.z() * wi.z();
        float ft = D * (1.0f - F) * G * std::abs(wo.dot(h.wm) * wi.dot(h.wm) / denom);
        if (mode == Transport::Radiance) ft /= sqr(h.etaT);
        return Color3f(ft);
    }

    float pdf(const Vector3f& wi, const Vector3f& wo, Half half = Half::Both) const {
        if (specular()) return 0.0f;
        HalfVector h;
        if (!halfVector(wi, wo, h)) return 0.0f;
        const float R = fresnel(wi.dot(h.wm), eta), T = 1.0f - R;
        const float pr = allows(half, Half::Reflection) ? R : 0.0f;
        const float pt = allows(half, Half::Transmission) ? T : 0.0f;
        if (pr == 0.0f && pt == 0.0f) return 0.0f;
        if (h.reflection)
            return distribution.visibleD(wi, h.wm) / (4.0f * std::abs(wi.dot(h.wm))) * pr /
                   (pr + pt);
        const float denom = sqr(wo.dot(h.wm) + wi.dot(h.wm) / h.etaT);
        return distribution.visibleD(wi, h.wm) * std::abs(wo.dot(h.wm)) / denom * pt / (pr + pt);
    }

    // uc chooses between reflection and transmission (in proportion to Fresnel), u the normal.
    std::optional<Sample> sample(const Vector3f& wi, float uc, const Point2f& u, Transport mode,
                                 Half half = Half::Both) const {
        if (specular()) {
            const float R = fresnel(wi.z(), eta), T = 1.0f - R;
            const float pr = allows(half, Half::Reflection) ? R : 0.0f;
            const float pt = allows(half, Half::Transmission) ? T : 0.0f;
            if (pr == 0.0f && pt == 0.0f) return std::nullopt;
            Sample s;
            s.specular = true;
            if (uc < pr / (pr + pt)) {
                s.wo = reflectAboutNormal(wi);
                s.f = Color3f(R / std::abs(s.wo.z()));
                s.pdf = pr / (pr + pt);
                return s;
            }
            float etaT;
            if (!refract(wi, Vector3f(0.0f, 0.0f, 1.0f), eta, s.wo, etaT)) return std::nullopt;
            float ft = T / std::abs(s.wo.z());
            if (mode == Transport::Radiance) ft /= sqr(etaT);
            s.f = Color3f(ft);
            s.pdf = pt / (pr + pt);
            s.eta = etaT;
            s.reflection = false;
            return s;
        }
        if (wi.z() == 0.0f) return std::nullopt;
        const Vector3f wm = distribution.sampleVisibleNormal(wi, u);
        const float R = fresnel(wi.dot(wm), eta), T = 1.0f - R;
        const float pr = allows(half, Half::Reflection) ? R : 0.0f;
        const float pt = allows(half, Half::Transmission) ? T : 0.0f;
        if (pr == 0.0f && pt == 0.0f) return std::nullopt;
        Sample s;
        if (uc < pr / (pr + pt)) {
            s.wo = reflectAbout(wi, wm);
            if (!sameHemisphere(wi, s.wo)) return std::nullopt;
            s.pdf = distribution.visibleD(wi, wm) / (4.0f * std::abs(wi.dot(wm))) * pr / (pr + pt);
            s.f = Color3f(distribution.D(wm) * distribution.G(wi, s.wo) * R /
                          std::abs(4.0f * wi.z() * s.wo.z()));
            return s;
        }
        float etaT;
        if (!refract(wi, wm, eta, s.wo, etaT) || sameHemisphere(wi, s.wo) || s.wo.z() == 0.0f)
            return std::nullopt;
        const float denom = sqr(s.wo.dot(wm) + wi.dot(wm) / etaT);
        s.pdf = distribution.visibleD(wi, wm) * std::abs(s.wo.dot(wm)) / denom * pt / (pr + pt);
        float ft = T * distribution.D(wm) * distribution.G(wi, s.wo) *
                   std::abs(s.wo.dot(wm) * wi.dot(wm) / (s.wo.z() * wi.z() * denom));
        if (mode == Transport::Radiance) ft /= sqr(etaT);
        s.f = Color3f(ft);
        s.eta = etaT;
        s.reflection = false;
        return s;
    }

  private:
    static float sqr(float x) { return x * x; }

    struct HalfVector {
        Vector3f wm;
        float etaT = 1.0f;
        bool reflection = true;
    };
    // The generalised half vector of a reflection (wi + wo) or refraction (eta_t wo + wi),
    // turned to the upper side; false when the pair has no valid microfacet (grazing, or a
    // microfacet seen from its back side by either direction).
    bool halfVector(const Vector3f& wi, const Vector3f& wo, HalfVector& h) const {
        const float cosI = wi.z(), cosO = wo.z();
        if (cosI == 0.0f || cosO == 0.0f) return false;
        h.reflection = cosI * cosO > 0.0f;
        h.etaT = h.reflection ? 1.0f : (cosI > 0.0f ? eta : 1.0f / eta);
        Vector3f wm = wo * h.etaT + wi;
        if (wm.squaredNorm() == 0.0f) return false;
        wm.normalize();
        if (wm.z() < 0.0f) wm = -wm;
        if (wm.dot(wo) * cosO < 0.0f || wm.dot(wi) * cosI < 0.0f) return false;
        h.wm = wm;
        return true;
    }
};

// A conductor of complex relative index eta + i k; reflection only, the same from both sides.
struct Conductor {
    Color3f eta = Color3f(1.0f), k = Color3f(0.0f);
    TrowbridgeReitz distribution;

    bool specular() const { return distribution.effectivelySmooth(); }

    Color3f f(const Vector3f& wi, const Vector3f& wo, Transport = Transport::Radiance) const {
        if (!sameHemisphere(wi, wo) || specular()) return Color3f(0.0f);
        Vector3f wm = wi + wo;
        if (wm.squaredNorm() == 0.0f) return Color3f(0.0f);
        wm.normalize();
        const Color3f F = fresnelConductor(std::abs(wi.dot(wm)), eta, k);
        return distribution.D(wm) * distribution.G(wi, wo) * F / std::abs(4.0f * wi.z() * wo.z());
    }

    float pdf(const Vector3f& wi, const Vector3f& wo, Half half = Half::Both) const {
        if (!allows(half, Half::Reflection) || !sameHemisphere(wi, wo) || specular()) return 0.0f;
        Vector3f wm = wi + wo;
        if (wm.squaredNorm() == 0.0f) return 0.0f;
        wm.normalize();
        if (wm.z() < 0.0f) wm = -wm;
        return distribution.visibleD(wi, wm) / (4.0f * std::abs(wi.dot(wm)));
    }

    std::optional<Sample> sample(const Vector3f& wi, float, const Point2f& u,
                                 Transport = Transport::Radiance, Half half = Half::Both) const {
        if (!allows(half, Half::Reflection) || wi.z() == 0.0f) return std::nullopt;
        Sample s;
        if (specular()) {
            s.wo = reflectAboutNormal(wi);
            s.f = fresnelConductor(std::abs(wi.z()), eta, k) / std::abs(wi.z());
            s.pdf = 1.0f;
            s.specular = true;
            return s;
        }
        const Vector3f wm = distribution.sampleVisibleNormal(wi, u);
        s.wo = reflectAbout(wi, wm);
        if (!sameHemisphere(wi, s.wo)) return std::nullopt;
        s.pdf = distribution.visibleD(wi, wm) / (4.0f * std::abs(wi.dot(wm)));
        const Color3f F = fresnelConductor(std::abs(wi.dot(wm)), eta, k);
        s.f =
            distribution.D(wm) * distribution.G(wi, s.wo) * F / std::abs(4.0f * wi.z() * s.wo.z());
        return s;
    }
};

// A Lambertian reflector, the same from both sides.
struct Lambertian {
    Color3f reflectance = Color3f(0.0f);

    bool specular() const { return false; }

    Color3f f(const Vector3f& wi, const Vector3f& wo, Transport = Transport::Radiance) const {
        return sameHemisphere(wi, wo) ? Color3f(reflectance * InvPi) : Color3f(0.0f);
    }
    float pdf(const Vector3f& wi, const Vector3f& wo, Half half = Half::Both) const {
        if (!allows(half, Half::Reflection) || !sameHemisphere(wi, wo)) return 0.0f;
        return std::abs(wo.z()) * InvPi;
    }
    std::optional<Sample> sample(const Vector3f& wi, float, const Point2f& u,
                                 Transport = Transport::Radiance, Half half = Half::Both) const {
        if (!allows(half, Half::Reflection) || wi.z() == 0.0f) return std::nullopt;
        Sample s;
        s.wo = warp::squareToCosineHemisphere(u);
        if (wi.z() < 0.0f) s.wo.z() = -s.wo.z();
        s.pdf = std::abs(s.wo.z()) * InvPi;
        s.f = reflectance * InvPi;
        if (s.pdf == 0.0f) return std::nullopt;
        return s;
    }
};

}  // namespace alphorn::lobes
