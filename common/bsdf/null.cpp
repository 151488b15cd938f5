// <bsdf type="null">: an index-matched boundary. Light passes straight through, unchanged, so a
// mesh can bound a medium without refracting or reflecting anything (a dielectric with
// intIOR == extIOR says the same and is recognised as null too).
//
// The volumetric integrators see isNull() and cross such a surface without a scattering event,
// without drawing random numbers and without counting a bounce. Other integrators sample it like
// any delta BSDF: wo = -wi with weight 1.
#include "common/bsdf/bsdf.h"

namespace alphorn {

class NullBSDF : public BSDF {
  public:
    explicit NullBSDF(const PropertyList&) {}

    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const BSDFQueryRecord&) const override { return 0.0f; }
    Color3f sample(BSDFQueryRecord& rec, const Point2f&) const override {
        rec.wo = -rec.wi;
        rec.measure = Measure::Discrete;
        rec.eta = 1.0f;
        return Color3f(1.0f);
    }
    bool isNull() const override { return true; }
    std::string toString() const override { return "null (index-matched boundary)"; }
};

ALPHORN_REGISTER(BSDF, "null", NullBSDF);

}  // namespace alphorn
