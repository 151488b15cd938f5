// <texture type="combination">: combines nested textures, in the order they are written.
//   operation="sum"      the sum of all nested textures (at least one)
//   operation="product"  the product of all nested textures (at least one)
//   operation="mix"      (1 - w) a + w b of exactly two nested textures a, b, with the weight w
//                        from the float `weight` (default 0.5) or a nested texture named
//                        "weight", clamped per channel to [0, 1]
// Nested textures other than the weight may have any name (it labels them for the reader).
// E.g. the fog of scenes/stage/stage.xml: sum of a constant, an exponential3d and a perlin3d.
#include "common/texture/texture.h"

namespace alphorn {

class CombinationTexture : public Texture {
  public:
    enum class Operation { Sum, Product, Mix };

    explicit CombinationTexture(const PropertyList& props) {
        const std::string op = props.getString("operation", "sum");
        if (op == "sum")
            m_operation = Operation::Sum;
        else if (op == "product")
            m_operation = Operation::Product;
        else if (op == "mix")
            m_operation = Operation::Mix;
        else
            props.fail("operation must be sum, product or mix, got \"%s\"", op);
        m_hasWeightValue = props.has("weight");
        m_weightValue = props.getFloat("weight", 0.5f);
        if (m_hasWeightValue && m_operation != Operation::Mix)
            props.fail("weight is only used by operation=\"mix\"");
        if (!(m_weightValue >= 0.0f && m_weightValue <= 1.0f))
            props.fail("weight must be in [0, 1], got %g", m_weightValue);
    }

    void addChild(const std::shared_ptr<Object>& child, const std::string& name) override {
        if (child->kind() != ObjectKind::Texture) return Object::addChild(child, name);
        auto texture = std::static_pointer_cast<Texture>(child);
        texture->setParameterName(name);
        if (m_operation == Operation::Mix && name == "weight") {
            if (m_hasWeightValue || m_weight) fail("the mix weight is given more than once");
            m_weight = texture;
        } else {
            m_operands.push_back(texture);
        }
    }

    void activate() override {
        if (m_operands.empty()) fail("a combination texture needs nested textures");
        if (m_operation == Operation::Mix && m_operands.size() != 2)
            fail(
                "operation=\"mix\" needs exactly two nested textures (plus an optional "
                "\"weight\"), got %zu",
                m_operands.size());
        m_lower = m_operands[0]->lowerBound();
        m_upper = m_operands[0]->upperBound();
        for (size_t i = 1; i < m_operands.size(); ++i) {
            const Color3f lo = m_operands[i]->lowerBound(), hi = m_operands[i]->upperBound();
            switch (m_operation) {
                case Operation::Sum:
                    m_lower += lo;
                    m_upper += hi;
                    break;
                case Operation::Product: {
                    // Signed intervals: the extremes are among the four corner products.
                    const Color3f a = m_lower * lo, b = m_lower * hi, c = m_upper * lo,
                                  d = m_upper * hi;
                    m_lower = a.min(b).min(c).min(d);
                    m_upper = a.max(b).max(c).max(d);
                    break;
                }
                case Operation::Mix:
                    // A convex combination stays between its operands.
                    m_lower = m_lower.min(lo);
                    m_upper = m_upper.max(hi);
                    break;
            }
        }
    }

    Color3f eval(const Point2f& uv, const Point3f& p) const override {
        if (m_operation == Operation::Mix) {
            const Color3f w = m_weight ? Color3f(m_weight->eval(uv, p).max(0.0f).min(1.0f))
                                       : Color3f(m_weightValue);
            const Color3f value =
                (1.0f - w) * m_operands[0]->eval(uv, p) + w * m_operands[1]->eval(uv, p);
            return value.max(m_lower).min(m_upper);
        }
        Color3f value = m_operands[0]->eval(uv, p);
        for (size_t i = 1; i < m_operands.size(); ++i) {
            if (m_operation == Operation::Sum)
                value += m_operands[i]->eval(uv, p);
            else
                value *= m_operands[i]->eval(uv, p);
        }
        return value;
    }

    bool is3D() const override {
        for (const auto& t : m_operands)
            if (!t->is3D()) return false;
        return !m_weight || m_weight->is3D();
    }
    Color3f lowerBound() const override { return m_lower; }
    Color3f upperBound() const override { return m_upper; }
    std::string toString() const override { return "combination"; }

  private:
    Operation m_operation = Operation::Sum;
    std::vector<std::shared_ptr<Texture>> m_operands;
    std::shared_ptr<Texture> m_weight;
    float m_weightValue = 0.5f;
    bool m_hasWeightValue = false;
    Color3f m_lower, m_upper;
};

ALPHORN_REGISTER(Texture, "combination", CombinationTexture);

}  // namespace alphorn
