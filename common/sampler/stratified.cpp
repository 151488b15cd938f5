// <sampler type="stratified">: jittered stratification across the passes of a pixel.
//   sampleCount  samples per pixel, N (Nori's name; default 1)
//   dimension    how many leading dimensions are stratified (default 32); later ones are
//                independent
// A render's pass p is sample p mod N of block p / N of a pixel. In every stratified
// dimension d, block b assigns the N passes to the N strata through a random permutation
// seeded by (seed, b, stream, d), and jitters within the stratum; so over N passes each stratum
// is used exactly once, and the output stays a pure function of (seed, pass, stream,
// dimension) like the independent sampler's -- no state is carried between passes, which is
// what lets any worker render any pass. A 2D draw is stratified on a sqrt(N) x sqrt(N) grid
// when N is a perfect square; otherwise each axis gets N strata with its own permutation
// (Latin hypercube). A 2D draw consumes two dimensions. Permutations are Kensler's
// hash-based ones ("Correlated Multi-Jittered Sampling", 2013): O(1) and table-free.
#include "common/sampler/sampler.h"

namespace alphorn {

class Stratified : public Sampler {
  public:
    explicit Stratified(const PropertyList& props) {
        m_sampleCount = props.getPositiveInteger("sampleCount", 1);
        m_dimensions = props.getInteger("dimension", 32);
        if (m_dimensions < 0) props.fail("dimension must be non-negative, got %d", m_dimensions);
        const int root = static_cast<int>(std::lround(std::sqrt(double(m_sampleCount))));
        m_gridSide = root * root == m_sampleCount ? root : 0;
    }

    std::unique_ptr<Sampler> clone() const override { return std::make_unique<Stratified>(*this); }

    void startStream(uint64_t seed, uint64_t pass, uint64_t stream,
                     StreamPurpose purpose) override {
        m_rng = Rng(seed, pass, stream, purpose);
        const uint64_t block = pass / static_cast<uint64_t>(m_sampleCount);
        m_index = static_cast<uint32_t>(pass % static_cast<uint64_t>(m_sampleCount));
        // The permutation key is shared by the N passes of a block, unlike the jitter stream.
        m_blockKey =
            mix64(seed ^ mix64(block ^ mix64(stream ^ mix64(static_cast<uint64_t>(purpose)))));
        m_dimension = 0;
    }

    float next1D() override {
        const uint32_t d = m_dimension++;
        const float jitter = m_rng.nextFloat();
        if (d >= static_cast<uint32_t>(m_dimensions)) return jitter;
        return stratum1D(permute(m_index, m_sampleCount, key(d)), jitter);
    }

    Point2f next2D() override {
        const uint32_t d = m_dimension;
        m_dimension += 2;
        const float jx = m_rng.nextFloat();
        const float jy = m_rng.nextFloat();
        if (d >= static_cast<uint32_t>(m_dimensions)) return Point2f(jx, jy);
        if (m_gridSide > 0) {
            const uint32_t cell = permute(m_index, m_sampleCount, key(d));
            const uint32_t side = static_cast<uint32_t>(m_gridSide);
            return Point2f(toUnit(cell % side, side, jx), toUnit(cell / side, side, jy));
        }
        return Point2f(stratum1D(permute(m_index, m_sampleCount, key(d)), jx),
                       stratum1D(permute(m_index, m_sampleCount, key(d + 1)), jy));
    }

    std::string toString() const override {
        return "stratified sampler (" + std::to_string(m_sampleCount) + " spp)";
    }

    // Kensler's permutation of [0, n): a bijection chosen by the key p.
    static uint32_t permute(uint32_t i, uint32_t n, uint32_t p) {
        if (n <= 1) return 0;
        uint32_t w = n - 1;
        w |= w >> 1;
        w |= w >> 2;
        w |= w >> 4;
        w |= w >> 8;
        w |= w >> 16;
        do {
            i ^= p;
            i *= 0xe170893d;
            i ^= p >> 16;
            i ^= (i & w) >> 4;
            i ^= p >> 8;
            i *= 0x0929eb3f;
            i ^= p >> 23;
            i ^= (i & w) >> 1;
            i *= 1 | p >> 27;
            i *= 0x6935fa69;
            i ^= (i & w) >> 11;
            i *= 0x74dcb303;
            i ^= (i & w) >> 2;
            i *= 0x9e501cc3;
            i ^= (i & w) >> 2;
            i *= 0xc860a3df;
            i &= w;
            i ^= i >> 5;
        } while (i >= n);
        return (i + p) % n;
    }

  private:
    uint32_t key(uint32_t dimension) const {
        return static_cast<uint32_t>(mix64(m_blockKey ^ (uint64_t(dimension) + 1)) >> 32);
    }
    float stratum1D(uint32_t stratum, float jitter) const {
        return toUnit(stratum, static_cast<uint32_t>(m_sampleCount), jitter);
    }
    // (stratum + jitter) / n, kept below 1 when rounding would reach it.
    static float toUnit(uint32_t stratum, uint32_t n, float jitter) {
        return std::min((static_cast<float>(stratum) + jitter) / static_cast<float>(n),
                        0.99999994f);
    }

    Rng m_rng;
    int m_dimensions = 32, m_gridSide = 0;
    uint32_t m_index = 0, m_dimension = 0;
    uint64_t m_blockKey = 0;
};

ALPHORN_REGISTER(Sampler, "stratified", Stratified);

}  // namespace alphorn
