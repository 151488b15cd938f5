// <medium type="vacuum">: no interaction at all. Useful to say explicitly that the inside of a
// mesh is empty (e.g. a glass sphere in fog); integrators skip it without drawing numbers.
#include "common/medium/medium.h"

namespace alphorn {

class Vacuum : public Medium {
  public:
    explicit Vacuum(const PropertyList&) {}

    MediumSample sampleDistance(const Ray3f&, float, Sampler&, int&) const override {
        return MediumSample{};
    }
    Color3f transmittance(const Ray3f&, float, Sampler&) const override { return Color3f(1.0f); }
    bool isVacuum() const override { return true; }
    std::string toString() const override { return "vacuum"; }
};

ALPHORN_REGISTER(Medium, "vacuum", Vacuum);

}  // namespace alphorn
