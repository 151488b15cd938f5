// <medium type="homogeneous">: constant scattering and absorption coefficients `sigmaS` and
// `sigmaA` (RGB, per unit length, >= 0), extinction sigmaT = sigmaS + sigmaA.
//
// No tracking: free-flight distances and transmittance are closed forms. The extinction may
// differ per channel: the distance is drawn from
// sigmaT[h] exp(-sigmaT[h] t) of the path's hero channel h and the path is weighted by the
// average density over the channels (spectral MIS, see MediumSample):
//
//     scattered at t < tMax:  weight_c = sigmaS[c] e^(-sigmaT[c] t) / (sigmaT[h] e^(-sigmaT[h] t))
//                             ratio_c  = sigmaT[c] e^(-sigmaT[c] t) / (sigmaT[h] e^(-sigmaT[h] t))
//     passed:                 weight_c = ratio_c = e^(-(sigmaT[c] - sigmaT[h]) tMax),
//
// written with differences of exponents so that nothing underflows. A grey medium needs no hero
// channel: its weights are the albedo and 1, its ratios 1.
#include "common/medium/medium.h"

#include <absl/strings/str_format.h>

namespace alphorn {

class HomogeneousMedium : public Medium {
  public:
    explicit HomogeneousMedium(const PropertyList& props) {
        m_sigmaS = props.getNonNegativeColor("sigmaS", Color3f(0.0f));
        m_sigmaA = props.getNonNegativeColor("sigmaA", Color3f(0.0f));
        m_sigmaT = m_sigmaS + m_sigmaA;
        if (!m_sigmaT.allFinite()) props.fail("sigmaS + sigmaA must be finite");
        m_grey = m_sigmaT[0] == m_sigmaT[1] && m_sigmaT[1] == m_sigmaT[2];
    }

    MediumSample sampleDistance(const Ray3f& ray, float tMax, Sampler& sampler,
                                int& hero) const override {
        MediumSample result;
        if (isVacuum()) return result;
        const int h = m_grey ? 0 : heroChannel(hero, sampler);
        const float sigmaH = m_sigmaT[h];
        const float t = sigmaH > 0.0f ? sampleExponential(sampler.next1D(), sigmaH) : Infinity;
        if (t < tMax) {
            result.event = MediumSample::Event::Scattered;
            result.t = t;
            result.p = ray(t);
            for (int c = 0; c < 3; ++c) {
                const float relative = expAttenuation(m_sigmaT[c] - sigmaH, t);
                result.weight[c] = m_sigmaS[c] / sigmaH * relative;
                result.pdfRatio[c] = m_sigmaT[c] / sigmaH * relative;
            }
        } else {
            result.t = tMax;
            for (int c = 0; c < 3; ++c)
                result.weight[c] = result.pdfRatio[c] = expAttenuation(m_sigmaT[c] - sigmaH, tMax);
        }
        return result;
    }

    Color3f transmittance(const Ray3f&, float tMax, Sampler&) const override {
        return beerLambert(m_sigmaT, tMax);
    }

    bool isVacuum() const override { return m_sigmaT.isBlack(); }

    std::optional<GreyHomogeneous> greyHomogeneous() const override {
        if (!m_grey) return std::nullopt;
        return GreyHomogeneous{m_sigmaT[0], m_sigmaS};
    }

    std::string toString() const override {
        return absl::StrFormat("homogeneous medium, sigmaS %s, sigmaA %s", m_sigmaS.toString(),
                               m_sigmaA.toString());
    }

  private:
    Color3f m_sigmaS, m_sigmaA, m_sigmaT;
    bool m_grey = true;
};

ALPHORN_REGISTER(Medium, "homogeneous", HomogeneousMedium);

}  // namespace alphorn
