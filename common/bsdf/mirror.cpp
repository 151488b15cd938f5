// <bsdf type="mirror">: an ideal specular reflector (Nori's). Its only lobe is a delta, so eval()
// and pdf() are zero and all light transport goes through sample().
#include "common/bsdf/bsdf.h"
#include "common/core/frame.h"

namespace alphorn {

class Mirror : public BSDF {
  public:
    explicit Mirror(const PropertyList&) {}

    Color3f eval(const BSDFQueryRecord&) const override { return Color3f(0.0f); }
    float pdf(const BSDFQueryRecord&) const override { return 0.0f; }

    Color3f sample(BSDFQueryRecord& rec, const Point2f&) const override {
        // One-sided like Nori's: the back of a mirror is black.
        if (Frame::cosTheta(rec.wi) <= 0.0f) return Color3f(0.0f);
        rec.wo = Vector3f(-rec.wi.x(), -rec.wi.y(), rec.wi.z());
        rec.measure = Measure::Discrete;
        rec.eta = 1.0f;
        // The delta's eval * cos / pdf is exactly 1: a perfect mirror loses no energy.
        return Color3f(1.0f);
    }

    std::string toString() const override { return "mirror"; }
};

ALPHORN_REGISTER(BSDF, "mirror", Mirror);

}  // namespace alphorn
