// <phase type="isotropic">: every direction equally likely, 1 / (4 pi). The default phase
// function of every medium.
#include "common/core/warp.h"
#include "common/phase/phase.h"

namespace alphorn {

class IsotropicPhase : public PhaseFunction {
  public:
    explicit IsotropicPhase(const PropertyList&) {}

    float sample(const Vector3f&, Vector3f& wo, const Point2f& sample) const override {
        wo = warp::squareToUniformSphere(sample);
        return 1.0f;
    }
    float eval(const Vector3f&, const Vector3f&) const override { return Inv4Pi; }
    float pdf(const Vector3f&, const Vector3f&) const override { return Inv4Pi; }
    std::string toString() const override { return "isotropic phase function"; }
};

ALPHORN_REGISTER(PhaseFunction, "isotropic", IsotropicPhase);

}  // namespace alphorn
