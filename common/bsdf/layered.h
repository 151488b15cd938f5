// The layered BSDF of pbrt-v4's coated materials (coateddiffuse, coatedconductor): a dielectric
// interface on top of an opaque base (Lambertian or conductor), with an optional homogeneous
// medium of single-scattering `albedo` and Henyey-Greenstein `g` between them, `thickness` in
// units of the medium's mean free path. Light enters through the top, bounces between the base,
// the medium and the underside of the top, and leaves through the top. No closed form exists;
// like pbrt-v4 (after Guo et al. 2018, "Position-free Monte Carlo simulation for arbitrary
// layered BSDFs"), the value, the sample and the density are Monte Carlo estimates by random
// walks between the layers:
//   f()      the entrance interface's own reflection, plus `nsamples` walks that enter through
//            the top, with next-event estimation at every vertex towards a direction that leaves
//            through the top to wo (pre-sampled from wo's side), combined by the power heuristic
//            with the walk's own continuation;
//   sample() one walk from wi; its weight (value over density of the whole walk) is unbiased
//            for the integrand, but its density is not known in closed form;
//   pdf()    an estimate of that density from the first few lobes (top-base-top), mixed with a
//            uniform density (10%) so that it is never zero where f is not.
// pdf() is therefore not exactly the density of sample(): multiple importance sampling stays
// unbiased (its weights still sum to one, since every strategy asks the same pdf()), it is only
// not optimal. Both sides of the surface behave the same (a coat on both faces).
//
// The estimates draw random numbers, but the same query must give the same value on every thread
// and machine (same bytes at any thread count): each call seeds its own generator with a hash
// of the bits of its query (wi, wo or the 2D sample, uv), so eval() and pdf() are deterministic
// functions of their arguments.
#pragma once

#include "common/bsdf/lobes.h"
#include "common/phase/phase.h"

#include <pcg_random.hpp>

namespace alphorn::lobes {

// The walk's generator: seeded from a hash of the query, uniform floats in [0, 1).
class WalkRandom {
  public:
    WalkRandom(uint64_t a, uint64_t b) : m_pcg(mix64(a), mix64(b)) {}
    float next() { return static_cast<float>(m_pcg() >> 8) * 0x1p-24f; }
    Point2f next2() {
        const float x = next();
        return Point2f(x, next());
    }

  private:
    pcg32 m_pcg;
};

// Hashes the bits of directions and points into one 64-bit seed, in the given order.
inline uint64_t hashBits(uint64_t h, const Vector3f& v) {
    for (int i = 0; i < 3; ++i) h = mix64(h ^ bitsOf(v[i]) ^ (uint64_t(i + 1) << 40));
    return h;
}
inline uint64_t hashBits(uint64_t h, const Point2f& v) {
    for (int i = 0; i < 2; ++i) h = mix64(h ^ bitsOf(v[i]) ^ (uint64_t(i + 7) << 40));
    return h;
}

struct LayeredConfig {
    float thickness = 0.01f;
    Color3f albedo = Color3f(0.0f);
    const PhaseFunction* phase = nullptr;  // needed when albedo is not black
    int maxDepth = 10;
    int samples = 1;
};

template <typename Base>
class Layered {
  public:
    Layered(const Dielectric& top, const Base& base, const LayeredConfig& config)
        : m_top(top), m_base(base), m_c(config) {
        m_c.thickness = std::max(m_c.thickness, std::numeric_limits<float>::min());
        m_hasMedium = !m_c.albedo.isBlack();
    }

    // Whether everything is a delta: then f() and pdf() are 0 and sample() returns deltas.
    bool allSpecular() const { return m_top.specular() && m_base.specular() && !m_hasMedium; }

    // The value for the pair, averaged over `samples` walks; `seed` carries the query's uv.
    Color3f f(Vector3f wi, Vector3f wo, uint64_t seed) const {
        if (wi.z() < 0.0f) {
            wi = -wi;
            wo = -wo;
        }
        // An opaque base: nothing leaves on the other side.
        if (!sameHemisphere(wi, wo)) return Color3f(0.0f);
        Color3f f = float(m_c.samples) * m_top.f(wi, wo, Transport::Radiance);
        WalkRandom r(hashBits(hashBits(seed ^ 0xf1, wi), wo), 0xf1);
        const float exitZ = m_c.thickness;
        for (int s = 0; s < m_c.samples; ++s) {
            // Into the layers from wi, and (adjoint) from wo: the direction the walk must reach
            // inside to leave towards wo.
            const float uc0 = r.next();
            const auto in =
                m_top.sample(wi, uc0, r.next2(), Transport::Radiance, Half::Transmission);
            if (!valid(in)) continue;
            const float uc1 = r.next();
            const auto out =
                m_top.sample(wo, uc1, r.next2(), Transport::Importance, Half::Transmission);
            if (!valid(out)) continue;

            Color3f beta = in->f * std::abs(in->wo.z()) / in->pdf;
            float z = m_c.thickness;
            Vector3f w = in->wo;
            for (int depth = 0; depth < m_c.maxDepth; ++depth) {
                if (depth > 3 && beta.maxCoeff() < 0.25f) {
                    const float q = std::max(0.0f, 1.0f - beta.maxCoeff());
                    if (r.next() < q) break;
                    beta /= 1.0f - q;
                }
                if (!m_hasMedium) {
                    z = z == m_c.thickness ? 0.0f : m_c.thickness;
                    beta *= transmittance(m_c.thickness, w);
                } else {
                    // Unit extinction: the thickness is measured in mean free paths.
                    const float dz = -std::log1p(-r.next()) * std::abs(w.z());
                    const float zNext = w.z() > 0.0f ? z + dz : z - dz;
                    if (zNext == z) continue;
                    if (0.0f < zNext && zNext < m_c.thickness) {
                        // Scattering in the medium: next-event towards the exit through `out`.
                        float weight = 1.0f;
                        if (!m_top.specular())
                            weight = powerHeuristic(out->pdf, m_c.phase->pdf(-w, -out->wo));
                        f += beta * m_c.albedo * m_c.phase->eval(-w, -out->wo) * weight *
                             transmittance(zNext - exitZ, out->wo) * out->f / out->pdf;
                        Vector3f next;
                        const float phaseWeight = m_c.phase->sample(-w, next, r.next2());
                        if (phaseWeight == 0.0f || next.z() == 0.0f) continue;
                        const float phasePdf = m_c.phase->pdf(-w, next);
                        beta *= m_c.albedo * phaseWeight;
                        w = next;
                        z = zNext;
                        // The continuation itself may leave through the top towards wo.
                        if (z < exitZ && w.z() > 0.0f && !m_top.specular()) {
                            const Color3f fExit = m_top.f(-w, wo, Transport::Radiance);
                            if (!fExit.isBlack()) {
                                // The density with which `out` would have found this
                                // direction (sampled from wo's side).
                                const float exitPdf = m_top.pdf(wo, -w, Half::Transmission);
                                f += beta * transmittance(zNext - exitZ, w) * fExit *
                                     powerHeuristic(phasePdf, exitPdf);
                            }
                        }
                        continue;
                    }
                    z = std::clamp(zNext, 0.0f, m_c.thickness);
                }
                if (z == exitZ) {
                    // Back down off the underside of the top.
                    const float uc = r.next();
                    const auto bs =
                        m_top.sample(-w, uc, r.next2(), Transport::Radiance, Half::Reflection);
                    if (!valid(bs)) break;
                    beta *= bs->f * std::abs(bs->wo.z()) / bs->pdf;
                    w = bs->wo;
                } else {
                    // At the base: next-event towards the exit through `out`, then a bounce.
                    if (!m_base.specular()) {
                        float weight = 1.0f;
                        if (!m_top.specular())
                            weight = powerHeuristic(out->pdf, m_base.pdf(-w, -out->wo));
                        f += beta * m_base.f(-w, -out->wo) * std::abs(out->wo.z()) * weight *
                             transmittance(m_c.thickness, out->wo) * out->f / out->pdf;
                    }
                    const float uc = r.next();
                    const auto bs =
                        m_base.sample(-w, uc, r.next2(), Transport::Radiance, Half::Reflection);
                    if (!valid(bs)) break;
                    beta *= bs->f * std::abs(bs->wo.z()) / bs->pdf;
                    w = bs->wo;
                    if (!m_top.specular()) {
                        const Color3f fExit = m_top.f(-w, wo, Transport::Radiance);
                        if (!fExit.isBlack()) {
                            float weight = 1.0f;
                            // Against the density with which `out`, sampled from wo's side,
                            // would have found this direction: with it the two strategies'
                            // weights sum to 1. (pbrt-v4 uses the density of sampling wo from
                            // -w here, which differs for a rough coat and biased the value by
                            // several per cent against the walk of sample() in our tests.)
                            if (!m_base.specular())
                                weight =
                                    powerHeuristic(bs->pdf, m_top.pdf(wo, -w, Half::Transmission));
                            f += beta * transmittance(m_c.thickness, bs->wo) * fExit * weight;
                        }
                    }
                }
            }
        }
        return f / float(m_c.samples);
    }

    // One walk from wi; uc and u are the caller's numbers for the first interface, and the rest
    // come from a generator seeded by them. The sample's weight is f * |cos theta_o| / pdf, with
    // f and pdf the products along the whole walk; nothing when the walk dies.
    std::optional<Sample> sample(Vector3f wi, float uc, const Point2f& u, uint64_t seed) const {
        bool flip = false;
        if (wi.z() < 0.0f) {
            wi = -wi;
            flip = true;
        }
        auto bs = m_top.sample(wi, uc, u, Transport::Radiance);
        if (!valid(bs)) return std::nullopt;
        if (bs->reflection) {
            if (flip) bs->wo = -bs->wo;
            return bs;
        }
        Vector3f w = bs->wo;
        bool specularPath = bs->specular;
        WalkRandom r(hashBits(hashBits(seed ^ 0x5a, wi), u), bitsOf(uc));
        Color3f f = bs->f * std::abs(bs->wo.z());
        float pdf = bs->pdf;
        float z = m_c.thickness;
        for (int depth = 0; depth < m_c.maxDepth; ++depth) {
            const float rrBeta = f.maxCoeff() / pdf;
            if (depth > 3 && rrBeta < 0.25f) {
                const float q = std::max(0.0f, 1.0f - rrBeta);
                if (r.next() < q) return std::nullopt;
                pdf *= 1.0f - q;
            }
            if (w.z() == 0.0f) return std::nullopt;
            if (m_hasMedium) {
                const float dz = -std::log1p(-r.next()) * std::abs(w.z());
                const float zNext = w.z() > 0.0f ? z + dz : z - dz;
                if (zNext == z) return std::nullopt;
                if (0.0f < zNext && zNext < m_c.thickness) {
                    Vector3f next;
                    if (m_c.phase->sample(-w, next, r.next2()) == 0.0f || next.z() == 0.0f)
                        return std::nullopt;
                    const float phasePdf = m_c.phase->pdf(-w, next);
                    f *= m_c.albedo * m_c.phase->eval(-w, next);
                    pdf *= phasePdf;
                    specularPath = false;
                    w = next;
                    z = zNext;
                    continue;
                }
                z = std::clamp(zNext, 0.0f, m_c.thickness);
            } else {
                z = z == m_c.thickness ? 0.0f : m_c.thickness;
                f *= transmittance(m_c.thickness, w);
            }
            const float ucNext = r.next();
            const Point2f uNext = r.next2();
            const auto next = z == 0.0f ? m_base.sample(-w, ucNext, uNext)
                                        : m_top.sample(-w, ucNext, uNext, Transport::Radiance);
            if (!valid(next)) return std::nullopt;
            f *= next->f;
            pdf *= next->pdf;
            specularPath = specularPath && next->specular;
            w = next->wo;
            if (!next->reflection) {
                // Out through the top: done.
                Sample out;
                out.wo = flip ? Vector3f(-w) : w;
                out.f = f;
                out.pdf = pdf;
                out.specular = specularPath;
                out.reflection = true;
                return out;
            }
            f *= std::abs(next->wo.z());
        }
        return std::nullopt;
    }

    float pdf(Vector3f wi, Vector3f wo, uint64_t seed) const {
        if (wi.z() < 0.0f) {
            wi = -wi;
            wo = -wo;
        }
        WalkRandom r(hashBits(hashBits(seed ^ 0x9d, wo), wi), 0x9d);
        float sum = 0.0f;
        if (sameHemisphere(wi, wo)) {
            sum += float(m_c.samples) * m_top.pdf(wi, wo, Half::Reflection);
            for (int s = 0; s < m_c.samples; ++s) {
                // Transmission in at both ends, and the base's reflection between them.
                const float uc0 = r.next();
                const auto in =
                    m_top.sample(wi, uc0, r.next2(), Transport::Radiance, Half::Transmission);
                const float uc1 = r.next();
                const auto out =
                    m_top.sample(wo, uc1, r.next2(), Transport::Importance, Half::Transmission);
                if (!valid(in) || !valid(out)) continue;
                if (m_top.specular()) {
                    sum += m_base.pdf(-in->wo, -out->wo);
                    continue;
                }
                const float uc2 = r.next();
                const auto rs = m_base.sample(-in->wo, uc2, r.next2());
                if (!valid(rs)) continue;
                if (m_base.specular()) {
                    sum += m_top.pdf(-rs->wo, wo);
                    continue;
                }
                // Two estimates of the same product of densities, by the power heuristic.
                const float rPdf = m_base.pdf(-in->wo, -out->wo);
                sum += powerHeuristic(out->pdf, rPdf) * rPdf;
                const float tPdf = m_top.pdf(-rs->wo, wo);
                sum += powerHeuristic(rs->pdf, tPdf) * tPdf;
            }
        }
        // A tenth of a uniform density keeps it positive wherever the walk can go.
        return 0.1f * Inv4Pi + 0.9f * sum / float(m_c.samples);
    }

  private:
    static bool valid(const std::optional<Sample>& s) {
        return s && !s->f.isBlack() && s->pdf > 0.0f && s->wo.z() != 0.0f;
    }
    static float powerHeuristic(float a, float b) {
        const float a2 = a * a;
        if (std::isinf(a2)) return 1.0f;
        return a2 + b * b > 0.0f ? a2 / (a2 + b * b) : 0.0f;
    }
    // Transmittance over a height difference dz along w (unit extinction).
    static float transmittance(float dz, const Vector3f& w) {
        if (std::abs(dz) <= std::numeric_limits<float>::min()) return 1.0f;
        return std::exp(-std::abs(dz / w.z()));
    }

    Dielectric m_top;
    Base m_base;
    LayeredConfig m_c;
    bool m_hasMedium = false;
};

}  // namespace alphorn::lobes
