// <bsdf type="twosided">: shades both sides of a surface with the nested reflective BSDF, which
// sees every query from its front: a query from the back (wi below the surface) is turned over
// (wi and wo negated) before the nested BSDF evaluates or samples it. pbrt-v4's reflective
// materials (diffuse, conductor, the coated ones) shade both sides this way, so its scenes may
// wind their triangles either way; Nori's and Alphorn's other BSDFs shade their front only.
// Only for BSDFs that reflect: one that transmits handles both sides itself.
#include "common/bsdf/bsdf.h"

namespace alphorn {

class TwoSided : public BSDF {
  public:
    explicit TwoSided(const PropertyList&) {}

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (child->kind() != ObjectKind::BSDF) return BSDF::addChild(child, name);
        if (m_nested) fail("twosided takes exactly one nested BSDF");
        m_nested = std::static_pointer_cast<BSDF>(child);
    }

    void activate() override {
        if (!m_nested) fail("twosided needs a nested <bsdf>");
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        return m_nested->eval(facingFront(rec));
    }

    float pdf(const BSDFQueryRecord& rec) const override { return m_nested->pdf(facingFront(rec)); }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        const bool back = rec.wi.z() < 0.0f;
        if (back) rec.wi = -rec.wi;
        const Color3f weight = m_nested->sample(rec, sample);
        if (back) {
            rec.wi = -rec.wi;
            rec.wo = -rec.wo;
        }
        return weight;
    }

    int deltaLobes(const BSDFQueryRecord& rec, DeltaLobe* lobes) const override {
        const int count = m_nested->deltaLobes(facingFront(rec), lobes);
        if (rec.wi.z() < 0.0f)
            for (int i = 0; i < count; ++i) lobes[i].wo = -lobes[i].wo;
        return count;
    }

    bool isDiffuse() const override { return m_nested->isDiffuse(); }
    bool needsTangentFrame() const override { return m_nested->needsTangentFrame(); }
    std::string toString() const override { return "twosided " + m_nested->toString(); }

  private:
    static BSDFQueryRecord facingFront(const BSDFQueryRecord& rec) {
        if (rec.wi.z() >= 0.0f) return rec;
        BSDFQueryRecord front = rec;
        front.wi = -rec.wi;
        front.wo = -rec.wo;
        return front;
    }

    std::shared_ptr<BSDF> m_nested;
};

ALPHORN_REGISTER(BSDF, "twosided", TwoSided);

}  // namespace alphorn
