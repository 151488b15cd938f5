// <bsdf type="coateddiffuse">: pbrt-v4's coated diffuse material, a Lambertian base of
// `reflectance` under a dielectric coat of index `eta` (smooth, or GGX-rough by `roughness` /
// `uroughness` / `vroughness` and `remaproughness`), with an optional scattering medium of
// `albedo` and `g` and `thickness` between them (plastic, varnished wood, paint). The random-walk
// estimators are in layered.h; `maxdepth` bounds a walk's bounces and `nsamples` is the number of
// walks per evaluation.
#include "common/bsdf/coated.h"

namespace alphorn {

class CoatedDiffuse : public Coated<lobes::Lambertian> {
  public:
    explicit CoatedDiffuse(const PropertyList& props)
        : Coated(props, "", "eta"), m_reflectance(props, "reflectance", Color3f(0.5f)) {
        const Color3f r = props.getNonNegativeColor("reflectance", Color3f(0.5f));
        if (r.maxCoeff() > 1.0f)
            props.fail("\"reflectance\" must not exceed 1 in any channel (got %s)", r.toString());
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_reflectance.addChild(child, name, *this)) return;
        Coated::addChild(child, name);
    }

    void activate() override {
        Coated::activate();
        if (!(m_reflectance.lowerBound().minCoeff() >= 0.0f) ||
            !(m_reflectance.upperBound().maxCoeff() <= 1.0f))
            fail("the \"reflectance\" texture must stay within [0, 1] (from %s to %s)",
                 m_reflectance.lowerBound().toString(), m_reflectance.upperBound().toString());
    }

    std::string toString() const override {
        return "coateddiffuse, reflectance " + m_reflectance.toString() + ", " + Coated::toString();
    }

  protected:
    // A Lambertian base is never a delta.
    bool baseMayBeRough() const override { return true; }
    lobes::Lambertian base(const BSDFQueryRecord& rec) const override {
        return lobes::Lambertian{m_reflectance.eval(rec.uv, rec.p)};
    }
    const char* textureNames() const override {
        return "reflectance, roughness, uroughness, vroughness, thickness, albedo";
    }
    const char* typeName() const override { return "coateddiffuse"; }

  private:
    TexturedColor m_reflectance;
};

ALPHORN_REGISTER(BSDF, "coateddiffuse", CoatedDiffuse);

}  // namespace alphorn
