// <medium type="heterogeneous">: coefficients that vary in space,
//
//     sigmaS(x) = density * S(x),   sigmaA(x) = density * A(x),
//
// where S and A are the colours or nested 3D textures named `sigmaS` and `sigmaA` (any 3D
// texture: constant, checkerboard3d, exponential3d, perlin3d, combination) and `density` a
// float scale. Texture values below zero (raw noise) count as zero.
//
// The majorant mu is the largest channel of density * (upper(S) + upper(A)), from the textures'
// true upper bounds, so it is never exceeded; a texture without a finite bound, or one that
// depends on uv, is an error at load time. An optional `majorant` declares a larger bound
// (an error when the textures can exceed it).
//
// Free-flight sampling is delta tracking (Woodcock; Novák et al. 2018): tentative collisions at
// rate mu, each absorbing, scattering or null with probabilities sigmaA, sigmaS, sigmaN = mu -
// sigmaT over mu. Chromatic media choose by the path's hero channel and weight each event by
// the spectral MIS ratios sigma_c / sigma_hero (see MediumSample), which is exactly classic
// delta tracking (weights 1) when the channels agree.
//
// Transmittance is ratio tracking (Novák, Selle, Jarosz 2014), or with `residual` = true
// residual ratio tracking with the constant control sigmaC = density * (lower(S) + lower(A)):
// T = exp(-sigmaC d) * prod (1 - (sigmaT(x) - sigmaC) / max_c(upper_c - sigmaC_c)). The control
// removes the part of the density that is known everywhere, so a constant density gives the exact
// transmittance with no random numbers at all (tests/statistical and medium_test.cpp measure
// the variance of both). Once an estimate is exactly zero the tracking stops; once it falls below
// kRouletteThreshold, Russian roulette ends it early (unbiased), so the steps after the light is
// gone cost little however large majorant * distance is.
//
// When `sigmaA` is written exactly as `sigmaS` (the same texture element with the same contents,
// as the stage's fog absorbs where it scatters), one evaluation gives both: the same values bit
// for bit, at half the cost of the textures, which dominate tracking in procedural fog.
//
// A medium whose coefficients are the same everywhere (plain colours, or textures whose lower and
// upper bounds agree) is a homogeneous medium, and without a declared `majorant` it is rendered as
// one: free flight and transmittance by their closed forms (homogeneous.cpp), with equiangular
// sampling where that applies, instead of tracking that spends random numbers, and ratio
// tracking's variance, on nothing. Same expected image (the closed forms are what tracking
// estimates); bench_feature_cost measures the time saved. A declared `majorant` keeps the
// tracking at that rate, for tests and comparisons.
#include "common/medium/medium.h"
#include "common/texture/texture_slot.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class HeterogeneousMedium : public Medium {
  public:
    explicit HeterogeneousMedium(const PropertyList& props)
        : m_sigmaS(props, "sigmaS", Color3f(0.0f)), m_sigmaA(props, "sigmaA", Color3f(0.0f)) {
        m_density = props.getNonNegativeFloat("density", 1.0f);
        if (!std::isfinite(m_density)) props.fail("density must be finite, got %g", m_density);
        m_hasDeclaredMajorant = props.has("majorant");
        m_declaredMajorant = props.getNonNegativeFloat("majorant", 0.0f);
        m_residual = props.getBoolean("residual", false);
        for (const TexturedColor* slot : {&m_sigmaS, &m_sigmaA})
            if (!slot->isTextured() && !isNonNegativeFinite(slot->upperBound()))
                props.fail("\"%s\" must have finite components >= 0, got %s", slot->name(),
                           slot->upperBound().toString());
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_sigmaS.addChild(child, name, *this) || m_sigmaA.addChild(child, name, *this)) return;
        if (child->kind() == ObjectKind::Texture)
            fail("a heterogeneous medium takes textures named \"sigmaS\" or \"sigmaA\", got \"%s\"",
                 name);
        Medium::addChild(child, name);
    }

    void activate() override {
        Medium::activate();
        for (const TexturedColor* slot : {&m_sigmaS, &m_sigmaA}) {
            if (!slot->isTextured()) continue;
            if (!slot->texture()->is3D())
                fail("the \"%s\" texture (%s) depends on surface uv; a medium needs a 3D texture",
                     slot->name(), slot->texture()->toString());
            if (!slot->upperBound().allFinite())
                fail("the \"%s\" texture (%s) has no finite upper bound %s, so no majorant exists",
                     slot->name(), slot->texture()->toString(), slot->upperBound().toString());
        }
        m_sigmaAIsSigmaS = m_sigmaS.isTextured() && m_sigmaA.isTextured() &&
                           !m_sigmaS.texture()->definition().empty() &&
                           m_sigmaS.texture()->definition() == m_sigmaA.texture()->definition();
        // Negative texture values are clamped to zero, so the bounds are clamped too.
        const Color3f upper =
            m_density * (m_sigmaS.upperBound().max(0.0f) + m_sigmaA.upperBound().max(0.0f));
        const Color3f lower =
            m_density * (m_sigmaS.lowerBound().max(0.0f) + m_sigmaA.lowerBound().max(0.0f));
        if (!upper.allFinite())
            fail("density * (sigmaS + sigmaA) has no finite upper bound (%s)", upper.toString());
        m_majorant = upper.maxCoeff();
        if (m_hasDeclaredMajorant) {
            if (m_declaredMajorant < m_majorant)
                fail("the density can reach %g, above the declared majorant %g", m_majorant,
                     m_declaredMajorant);
            m_majorant = m_declaredMajorant;
        }
        // The residual sigmaT - sigmaC of channel c is at most upper[c] - sigmaC[c], so the
        // largest of those bounds every channel (0 for a constant density: no tracking at all).
        m_control = m_residual ? lower.min(upper) : Color3f(0.0f);
        m_residualMajorant = m_residual ? (upper - m_control).maxCoeff() : m_majorant;
        if (!m_hasDeclaredMajorant && isConstant(m_sigmaS) && isConstant(m_sigmaA)) {
            PropertyList props(source() + " (constant coefficients: a homogeneous medium)");
            props.setColor("sigmaS", m_density * m_sigmaS.upperBound().max(0.0f));
            props.setColor("sigmaA", m_density * m_sigmaA.upperBound().max(0.0f));
            m_homogeneous = std::static_pointer_cast<Medium>(
                ObjectFactory::create(ObjectKind::Medium, "homogeneous", props));
            m_homogeneous->activate();
        }
    }

    MediumSample sampleDistance(const Ray3f& ray, float tMax, Sampler& sampler,
                                int& hero) const override {
        if (m_homogeneous) return m_homogeneous->sampleDistance(ray, tMax, sampler, hero);
        MediumSample result;
        if (isVacuum()) return result;
        const int h = heroChannel(hero, sampler);
        // f / p_hero and p_c / p_hero agree for every event of delta tracking (f = p = sigma/mu
        // per channel), so one product serves as both; kept at mean 1 so it cannot overflow.
        Color3f ratio(1.0f);
        float t = 0.0f;
        for (;;) {
            t += sampleExponential(sampler.next1D(), m_majorant);
            if (!(t < tMax)) {
                result.t = tMax;
                result.weight = result.pdfRatio = ratio;
                return result;
            }
            const Point3f p = ray(t);
            Color3f sigmaS, sigmaA;
            coefficients(p, sigmaS, sigmaA);
            const Color3f sigmaN = (m_majorant - sigmaS - sigmaA).max(0.0f);
            // Normalised by the hero's own total, so an event drawn always has probability > 0.
            const float total = sigmaA[h] + sigmaS[h] + sigmaN[h];
            const float u = std::min(sampler.next1D() * total, std::nextafter(total, 0.0f));
            if (u < sigmaA[h]) break;
            if (u < sigmaA[h] + sigmaS[h]) {
                ratio *= sigmaS / sigmaS[h];
                result.event = MediumSample::Event::Scattered;
                result.t = t;
                result.p = p;
                result.weight = result.pdfRatio = ratio;
                return result;
            }
            ratio *= sigmaN / sigmaN[h];
            const float mean = ratio.mean();
            if (mean != 1.0f) ratio /= mean;
        }
        result.event = MediumSample::Event::Absorbed;
        result.t = t;
        result.weight = Color3f(0.0f);
        return result;
    }

    Color3f transmittance(const Ray3f& ray, float tMax, Sampler& sampler) const override {
        if (m_homogeneous) return m_homogeneous->transmittance(ray, tMax, sampler);
        if (isVacuum()) return Color3f(1.0f);
        Color3f result = beerLambert(m_control, tMax);
        if (!(m_residualMajorant > 0.0f)) return result;
        float t = 0.0f;
        for (;;) {
            t += sampleExponential(sampler.next1D(), m_residualMajorant);
            if (!(t < tMax)) return result;
            Color3f sigmaS, sigmaA;
            coefficients(ray(t), sigmaS, sigmaA);
            result *= (1.0f - (sigmaS + sigmaA - m_control) / m_residualMajorant).max(0.0f);
            // Zero stays zero: stopping here changes no expectation.
            if (result.isBlack()) return result;
            // A negligible estimate is not worth its remaining steps, and factors above 1/2 keep
            // the smallest subnormal float from ever reaching zero (it rounds back to itself),
            // which in a dense medium left every shadow ray walking all majorant * tMax steps.
            // Russian roulette keeps it with probability largest / kRouletteThreshold and
            // rescales it by the inverse, which leaves its expectation unchanged.
            const float largest = result.maxCoeff();
            if (largest < kRouletteThreshold) {
                if (!(sampler.next1D() * kRouletteThreshold < largest)) return Color3f(0.0f);
                result *= kRouletteThreshold / largest;
            }
        }
    }

    bool isVacuum() const override { return !(m_majorant > 0.0f); }
    float trackingMajorant() const override { return m_homogeneous ? 0.0f : m_majorant; }
    std::optional<GreyHomogeneous> greyHomogeneous() const override {
        return m_homogeneous ? m_homogeneous->greyHomogeneous() : std::nullopt;
    }

    std::string toString() const override {
        if (m_homogeneous)
            return absl::StrFormat(
                "heterogeneous medium, sigmaS %s, sigmaA %s, density %g, constant: rendered as a "
                "homogeneous medium",
                m_sigmaS.toString(), m_sigmaA.toString(), m_density);
        return absl::StrFormat(
            "heterogeneous medium, sigmaS %s, sigmaA %s%s, density %g, majorant %g",
            m_sigmaS.toString(), m_sigmaA.toString(),
            m_sigmaAIsSigmaS ? " (written as sigmaS: evaluated once for both)" : "", m_density,
            m_majorant);
    }

  private:
    // Below this largest channel, ratio tracking plays Russian roulette (see transmittance()).
    // Small enough that the variance the roulette adds (a·(threshold − a) for an estimate a below
    // it, at most threshold² / 4) is nothing next to ratio tracking's own; estimates that stay
    // above it draw exactly the numbers they drew before.
    static constexpr float kRouletteThreshold = 1e-3f;

    static bool isNonNegativeFinite(const Color3f& c) { return c.allFinite() && c.minCoeff() >= 0; }
    // The same value everywhere (after the clamp of negative values to zero).
    static bool isConstant(const TexturedColor& slot) {
        return (slot.lowerBound().max(0.0f) == slot.upperBound().max(0.0f)).all();
    }

    void coefficients(const Point3f& p, Color3f& sigmaS, Color3f& sigmaA) const {
        sigmaS = m_density * m_sigmaS.eval(Point2f::Zero(), p).max(0.0f);
        sigmaA =
            m_sigmaAIsSigmaS ? sigmaS : m_density * m_sigmaA.eval(Point2f::Zero(), p).max(0.0f);
        // The textures' bounds are true bounds, so this cannot happen unless a texture breaks its
        // contract; a silent clamp would bias the image, so stop with a clear message instead.
        if (!((sigmaS + sigmaA).maxCoeff() <= m_majorant * (1.0f + 1e-5f)))
            fail("the density %s at (%g, %g, %g) exceeds the majorant %g",
                 Color3f(sigmaS + sigmaA).toString(), p.x(), p.y(), p.z(), m_majorant);
    }

    TexturedColor m_sigmaS, m_sigmaA;
    bool m_sigmaAIsSigmaS = false;  // sigmaA's texture is written as sigmaS's: evaluate once
    float m_density = 1.0f;
    bool m_hasDeclaredMajorant = false;
    float m_declaredMajorant = 0.0f;
    bool m_residual = false;
    float m_majorant = 0.0f;
    Color3f m_control = Color3f(0.0f);
    float m_residualMajorant = 0.0f;
    std::shared_ptr<Medium> m_homogeneous;  // set for constant coefficients (see the top)
};

ALPHORN_REGISTER(Medium, "heterogeneous", HeterogeneousMedium);

}  // namespace alphorn
