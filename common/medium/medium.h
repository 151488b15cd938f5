// Participating media. A medium answers two questions about a ray segment inside it, both with
// the random numbers of the caller's Sampler so that every result stays a pure function of
// (seed, pass, stream, dimension):
//
//  - sampleDistance(): where along the segment does the light first interact? Free-flight
//    sampling (closed form for homogeneous media, delta tracking for heterogeneous
//    ones). It returns either a scattering point with its weight, or "passed" with the weight of
//    reaching the segment's end.
//  - transmittance(): an unbiased estimate of exp(-optical depth) per channel (exact for
//    homogeneous media, ratio tracking for heterogeneous ones), for shadow rays.
//
// Neither depends on the integrator, so camera paths and photon paths (the volumetric photon
// mapper) use them alike; the phase function comes with the medium.
//
// Media are attached to meshes (<medium name="inside|outside">) and to the camera; a segment
// never crosses a surface, the integrator splits rays at every boundary.
#pragma once

#include "common/core/color.h"
#include "common/core/object.h"
#include "common/core/ray.h"
#include "common/phase/phase.h"
#include "common/sampler/sampler.h"

#include <optional>

namespace alphorn {

// The outcome of free-flight sampling along o + t d, t in (0, tMax).
//
// Chromatic media (coefficients that differ per RGB channel) are sampled by one "hero" channel
// per path, chosen uniformly when the path first needs it, and the path is weighted by the
// average over channels of the densities with which each channel would have produced it
// (spectral MIS with the balance heuristic, as in pbrt-v4). A sample therefore reports, besides
// the usual weight f / p_hero per channel, the ratios p_c / p_hero of the densities of the event
// under every channel; the path keeps their running product R and its estimate is
// throughput / mean(R). Weights stay bounded by 3 over the whole path, where per-event averaging
// multiplies a factor of up to 3 at every event. Grey media report ratios of exactly 1.
struct MediumSample {
    enum class Event {
        Passed,     // no interaction before tMax: continue at the segment's end
        Scattered,  // scattered at t: sample the phase function at `p`
        Absorbed,   // the path ends here (weight 0)
    };
    Event event = Event::Passed;
    float t = Infinity;
    Point3f p = Point3f::Zero();
    // f / p_hero: multiplies the path throughput. For Scattered it already includes sigmaS, so
    // the caller only multiplies the phase function's weight.
    Color3f weight = Color3f(1.0f);
    // p_c / p_hero per channel: multiplies the path's density ratios.
    Color3f pdfRatio = Color3f(1.0f);
};

// The path's channel for chromatic media: -1 until a chromatic medium first needs one, which
// then draws it from the sampler (so paths that never meet one draw nothing).
inline int heroChannel(int& hero, Sampler& sampler) {
    if (hero < 0) hero = std::min(2, static_cast<int>(sampler.next1D() * 3.0f));
    return hero;
}

// A path's throughput under spectral MIS: `throughput` is already divided by the mean of the
// density ratios, which are kept normalised to mean 1 (so neither can overflow).
struct SpectralThroughput {
    Color3f throughput = Color3f(1.0f);
    Color3f pdfRatio = Color3f(1.0f);
    int hero = -1;

    void apply(const MediumSample& sample) {
        throughput *= sample.weight;
        pdfRatio *= sample.pdfRatio;
        const float mean = pdfRatio.mean();
        // Grey media give ratios of exactly 1: skip the division so they cost no rounding.
        if (mean != 1.0f && mean > 0.0f) {
            throughput /= mean;
            pdfRatio /= mean;
        }
    }
};

class Medium : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Medium; }

    // `ray.d` must be unit length; the segment is t in (0, tMax) from ray.o (tMax may be
    // infinite). Draws only from `sampler`; `hero` is the path's channel (see MediumSample).
    virtual MediumSample sampleDistance(const Ray3f& ray, float tMax, Sampler& sampler,
                                        int& hero) const = 0;
    // Unbiased estimate of the transmittance over (0, tMax) along the unit-direction ray.
    virtual Color3f transmittance(const Ray3f& ray, float tMax, Sampler& sampler) const = 0;
    // True for media that never interact (vacuum, or zero density): integrators skip them
    // entirely, drawing no random numbers, so such a medium renders exactly like no medium.
    virtual bool isVacuum() const { return false; }
    // A homogeneous medium whose extinction is the same in every channel: its free-flight
    // density sigmaT e^(-sigmaT t) is then known in closed form, which equiangular sampling
    // needs for its MIS weights (equiangular.h). Empty for every other medium.
    struct GreyHomogeneous {
        float sigmaT;
        Color3f sigmaS;
    };
    virtual std::optional<GreyHomogeneous> greyHomogeneous() const { return std::nullopt; }
    // The rate per unit length of tracking's tentative collisions (delta and ratio tracking), so
    // a crossing of length d costs about majorant * d steps; 0 for media with closed forms.
    virtual float trackingMajorant() const { return 0.0f; }

    const PhaseFunction& phase() const { return *m_phase; }

    // Takes the nested <phase>; anything else goes to the base class.
    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override;
    // Creates the default isotropic phase function; derived classes call this.
    void activate() override;

  protected:
    std::shared_ptr<PhaseFunction> m_phase;
};

// True when `medium` can interact with light (non-null and not vacuum).
inline bool isParticipating(const Medium* medium) {
    return medium && !medium->isVacuum();
}

// exp(-sigma t) per channel, with exp(-0 * inf) = 1 rather than NaN: a channel that does not
// attenuate transmits everything even along an infinite ray.
inline Color3f beerLambert(const Color3f& sigma, float t) {
    Color3f result;
    for (int c = 0; c < 3; ++c) result[c] = sigma[c] > 0.0f ? std::exp(-sigma[c] * t) : 1.0f;
    return result;
}

// exp(-sigma t) for a single channel, with exp(-0 * inf) = 1 (also for differences of sigmas).
inline float expAttenuation(float sigma, float t) {
    return sigma == 0.0f ? 1.0f : std::exp(-sigma * t);
}

// -log(1 - u) / rate for u in [0, 1): finite for every u the sampler can return (1 - u > 0).
inline float sampleExponential(float u, float rate) {
    return -std::log1p(-std::min(u, 0x1.fffffep-1f)) / rate;
}

}  // namespace alphorn
