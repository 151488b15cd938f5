// <sampler type="independent">: independent uniform numbers (Nori's), drawn from the
// deterministic per-(seed, pass, stream) generator.
#include "common/sampler/sampler.h"

namespace alphorn {

class Independent : public Sampler {
  public:
    explicit Independent(const PropertyList& props) {
        m_sampleCount = props.getPositiveInteger("sampleCount", 1);
    }

    std::unique_ptr<Sampler> clone() const override { return std::make_unique<Independent>(*this); }

    void startStream(uint64_t seed, uint64_t pass, uint64_t stream,
                     StreamPurpose purpose) override {
        m_rng = Rng(seed, pass, stream, purpose);
    }

    float next1D() override { return m_rng.nextFloat(); }
    Point2f next2D() override {
        float u = m_rng.nextFloat();
        return Point2f(u, m_rng.nextFloat());
    }

    std::string toString() const override {
        return "independent sampler (" + std::to_string(m_sampleCount) + " spp)";
    }

  private:
    Rng m_rng;
};

ALPHORN_REGISTER(Sampler, "independent", Independent);

}  // namespace alphorn
