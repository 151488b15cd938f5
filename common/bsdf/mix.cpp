// <bsdf type="mix">: pbrt-v4's mix material: two nested BSDFs, the first and the second <bsdf>
// child in document order, and `amount` (float or texture, default 0.5), the weight of the
// SECOND one: 0 is the first BSDF alone, 1 the second.
//
// pbrt-v4 picks one of the two at each shading point at random, with probability `amount` for
// the second. Alphorn blends instead: eval() and pdf() are (1 - amount) times the first's plus
// amount times the second's, and sample() samples the first with probability 1 - amount and the
// second otherwise, returning that child's own sample (its direction, measure and weight). The
// blend has the same expectation as pbrt-v4's choice, without its per-point noise pattern, and
// pdf() is then exactly the density of sample()'s non-delta directions. The child's own weight
// (rather than the blend's eval * cos / pdf) keeps sample() unbiased also when a child's eval()
// is itself a stochastic estimate (the coated BSDFs) or has delta parts.
#include "common/bsdf/bsdf.h"
#include "common/texture/texture_slot.h"

namespace alphorn {

class Mix : public BSDF {
  public:
    explicit Mix(const PropertyList& props) : m_amount(props, "amount", 0.5f) {
        const float amount = props.getFloat("amount", 0.5f);
        if (!(amount >= 0.0f && amount <= 1.0f))
            props.fail("\"amount\" must be within [0, 1], got %g", amount);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (m_amount.addChild(child, name, *this)) return;
        if (child->kind() == ObjectKind::BSDF) {
            if (m_bsdfs.size() == 2) fail("mix takes exactly two nested <bsdf>s; this is a third");
            m_bsdfs.push_back(std::static_pointer_cast<BSDF>(child));
            return;
        }
        if (child->kind() == ObjectKind::Texture)
            fail("mix has no texture parameter \"%s\" (textures: amount)", name);
        BSDF::addChild(child, name);
    }

    void activate() override {
        if (m_bsdfs.size() != 2)
            fail("mix needs exactly two nested <bsdf>s, got %d", static_cast<int>(m_bsdfs.size()));
        if (!(m_amount.lowerBound() >= 0.0f) || !(m_amount.upperBound() <= 1.0f))
            fail("the \"amount\" texture must stay within [0, 1] (from %g to %g)",
                 m_amount.lowerBound(), m_amount.upperBound());
    }

    Color3f eval(const BSDFQueryRecord& rec) const override {
        const float a = amount(rec);
        Color3f f(0.0f);
        if (a < 1.0f) f += (1.0f - a) * m_bsdfs[0]->eval(rec);
        if (a > 0.0f) f += a * m_bsdfs[1]->eval(rec);
        return f;
    }

    float pdf(const BSDFQueryRecord& rec) const override {
        const float a = amount(rec);
        float p = 0.0f;
        if (a < 1.0f) p += (1.0f - a) * m_bsdfs[0]->pdf(rec);
        if (a > 0.0f) p += a * m_bsdfs[1]->pdf(rec);
        return p;
    }

    Color3f sample(BSDFQueryRecord& rec, const Point2f& sample) const override {
        const float a = amount(rec);
        Point2f u = sample;
        // The choosing number, rescaled to [0, 1), is reused by the chosen child.
        const bool second = u.x() < a;
        u.x() = second ? u.x() / a : (u.x() - a) / (1.0f - a);
        u.x() = std::min(u.x(), 0.99999994f);
        return m_bsdfs[second ? 1 : 0]->sample(rec, u);
    }

    bool isDiffuse() const override { return m_bsdfs[0]->isDiffuse() || m_bsdfs[1]->isDiffuse(); }
    bool needsTangentFrame() const override {
        return m_bsdfs[0]->needsTangentFrame() || m_bsdfs[1]->needsTangentFrame();
    }

    std::string toString() const override {
        return "mix, amount " + m_amount.toString() + " of [" +
               (m_bsdfs.size() > 0 ? m_bsdfs[0]->toString() : "?") + "] and [" +
               (m_bsdfs.size() > 1 ? m_bsdfs[1]->toString() : "?") + "]";
    }

  private:
    float amount(const BSDFQueryRecord& rec) const {
        return std::clamp(m_amount.eval(rec.uv, rec.p), 0.0f, 1.0f);
    }

    TexturedFloat m_amount;
    std::vector<std::shared_ptr<BSDF>> m_bsdfs;
};

ALPHORN_REGISTER(BSDF, "mix", Mix);

}  // namespace alphorn
