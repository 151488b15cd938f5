// <sampler type="sobol">: Owen-scrambled Sobol points, one scrambled sequence per stream and draw.
//   sampleCount  samples per pixel (default 1); best at powers of two, where every draw's
//                points form stratified nets
// There is no sample count to commit to in advance: any prefix of passes is a valid render, and
// pass p is the same numbers on every worker. The passes form two replicates, one per pass
// parity: pass p is sample index p >> 1 of replicate p & 1, and each replicate has scrambles of
// its own. The film keeps its sums in two halves by pass parity, and the error estimate
// (error_estimate.h) reads the image's error from their difference, which is right only when
// the halves are independent estimates of the same image; with the pass as one sequence's sample
// index, the even and the odd passes would be complementary strata (opposite halves of every
// draw's range), whose difference tends to that of two half-domain integrals, not to the error:
// the estimate came out 1.3x to 2.2x the true error on a soft shadow from 16 to 1024 passes
// (docs/error-estimate.md). The image is the mean of two independent randomised quasi-Monte
// Carlo estimates, which costs some of the nets' gain. Following Burley, "Practical
// Hash-based Owen Scrambling" (JCGT 2020), every draw gets its own low-dimensional sequence
// instead of sharing one high-dimensional one:
//   - a 1D draw is the first Sobol dimension (van der Corput), a 2D draw the first two Sobol
//     dimensions, a (0,2)-sequence: the first 2^k samples of a 2D draw put one point in every
//     cell of each 2^a x 2^(k-a) grid;
//   - the sample index is Owen-scrambled (bits reversed) with a key from (seed, stream,
//     dimension, replicate), which shuffles the sequence in aligned blocks of 2^k and so keeps
//     those nets: each replicate's aligned blocks of 2^k of its own passes (passes of one parity)
//     are (0,k,2)-nets, while different draws of one stream see unrelated orders (this
//     decorrelates the dimensions as padding does, with no direction-number table beyond the
//     first two dimensions);
//   - each coordinate is Owen-scrambled with its own key, which makes every point uniform on
//     [0,1)^2 and decorrelates neighbouring pixels.
// Owen scrambling is approximated by a hash in which each output bit depends only on the bits
// above it (the Laine-Karras construction). Sample indices beyond 2^32 (passes beyond 2^33)
// start a new set of scrambles.
#include "common/sampler/sampler.h"

namespace alphorn {

namespace {

// The second Sobol dimension (primitive polynomial x + 1), bit-reversed: its generator matrix is
// Pascal's triangle mod 2, so column k is row k of the triangle, here with its first entry in the
// lowest bit. Tables of the XOR of the columns selected by each byte of the index make the
// product four look-ups (4 KiB).
struct ByteTables {
    uint32_t byte[4][256];
};
constexpr ByteTables makeSecondDimensionReversed() {
    uint32_t columns[32] = {};
    uint32_t column = 1u;
    for (int k = 0; k < 32; ++k) {
        columns[k] = column;
        column ^= column << 1;
    }
    ByteTables tables{};
    for (int b = 0; b < 4; ++b)
        for (uint32_t value = 0; value < 256; ++value)
            for (int bit = 0; bit < 8; ++bit)
                if (value >> bit & 1u) tables.byte[b][value] ^= columns[8 * b + bit];
    return tables;
}
constexpr ByteTables kSecondDimensionReversed = makeSecondDimensionReversed();

[[gnu::always_inline]] inline uint32_t sobolSecondDimensionReversed(uint32_t index) {
    const auto& t = kSecondDimensionReversed.byte;
    return t[0][index & 255u] ^ t[1][index >> 8 & 255u] ^ t[2][index >> 16 & 255u] ^
           t[3][index >> 24];
}

// A key-chosen permutation of 32-bit words in which output bit b depends only on input bits
// 0..b: adding, multiplying by an odd number and xor-ing with an even multiple never carry
// information downwards. Applied to bit-reversed numbers it is a hashed nested uniform (Owen)
// scramble. Each round has its own key-derived addend and odd factor: with a fixed factor (one
// key addition among constant multiplications), numbers that differ in one low bit (neighbouring
// sample indices) get strongly dependent higher bits (a chi-square test of the bits above the
// difference, over many keys, rejects it); two rounds of this form passed that test, the third
// is margin.
// The rounds are written out (and the helpers forced inline) because this is the sampler's whole
// cost: as a loop around a call it was a sixth of a path-traced render's profile.
struct RoundKeys {
    uint32_t addend[3], factor[3];
};
[[gnu::always_inline]] inline RoundKeys roundKeys(uint32_t key) {
    RoundKeys keys;
#pragma GCC unroll 3
    for (int round = 0; round < 3; ++round) {
        keys.addend[round] = key;
        keys.factor[round] = (key >> 7) | 1u;
        key = (key ^ (key >> 16)) * 0x9e3779b9u + 0x7f4a7c15u;
    }
    return keys;
}
[[gnu::always_inline]] inline uint32_t lowToHighPermutation(uint32_t x, const RoundKeys& keys) {
#pragma GCC unroll 3
    for (int round = 0; round < 3; ++round) {
        x += keys.addend[round];
        x *= keys.factor[round];
        x ^= x * 0x9a3c5e14u;
    }
    return x;
}
[[gnu::always_inline]] inline uint32_t lowToHighPermutation(uint32_t x, uint32_t key) {
    return lowToHighPermutation(x, roundKeys(key));
}

// A byte swap (one instruction) followed by the swaps within bytes.
[[gnu::always_inline]] inline uint32_t reverseBits(uint32_t x) {
    x = __builtin_bswap32(x);
    x = ((x & 0x0f0f0f0fu) << 4) | ((x & 0xf0f0f0f0u) >> 4);
    x = ((x & 0x33333333u) << 2) | ((x & 0xccccccccu) >> 2);
    return ((x & 0x55555555u) << 1) | ((x & 0xaaaaaaaau) >> 1);
}

// 24 bits, so that the float is exact and below 1.
[[gnu::always_inline]] inline float toUnitFloat(uint32_t fraction) {
    return static_cast<float>(fraction >> 8) * 0x1p-24f;
}

}  // namespace

class Sobol : public Sampler {
  public:
    explicit Sobol(const PropertyList& props) {
        m_sampleCount = props.getPositiveInteger("sampleCount", 1);
    }

    std::unique_ptr<Sampler> clone() const override { return std::make_unique<Sobol>(*this); }

    void startStream(uint64_t seed, uint64_t pass, uint64_t stream,
                     StreamPurpose purpose) override {
        // Pass p is sample `index` of replicate p & 1. The replicate enters the key, so the two
        // are independently scrambled; the index must not, except for the 2^32-sample block it
        // belongs to.
        const uint64_t replicate = pass & 1u, index = pass >> 1;
        m_streamKey = mix64(seed ^ mix64(stream ^ mix64(static_cast<uint64_t>(purpose) ^
                                                        mix64((index >> 32) << 1 | replicate))));
        m_reversedIndex = reverseBits(static_cast<uint32_t>(index));
        m_dimension = 0;
    }

    // Owen scrambling works on bit-reversed numbers (lowToHighPermutation), so the values stay
    // bit-reversed until they become floats. The first Sobol dimension of an index is the
    // index reversed: reversed once more, the index itself.
    float next1D() override {
        const uint64_t key = drawKey(m_dimension++, 0);
        const uint32_t index = shuffledIndex(key);
        return toUnitFloat(reverseBits(lowToHighPermutation(index, xKey(key))));
    }

    Point2f next2D() override {
        const uint64_t key = drawKey(m_dimension, 0), yKey = drawKey(m_dimension, 1);
        m_dimension += 2;
        const uint32_t index = shuffledIndex(key);
        const uint32_t x = lowToHighPermutation(index, xKey(key));
        const uint32_t y =
            lowToHighPermutation(sobolSecondDimensionReversed(index), static_cast<uint32_t>(yKey));
        return Point2f(toUnitFloat(reverseBits(x)), toUnitFloat(reverseBits(y)));
    }

    std::string toString() const override {
        return "sobol sampler (" + std::to_string(m_sampleCount) + " spp)";
    }

  private:
    uint64_t drawKey(uint32_t dimension, uint64_t which) const {
        return mix64(m_streamKey ^ (static_cast<uint64_t>(dimension) << 1 | which));
    }
    // The index shuffle and the first coordinate take the two halves of one draw key.
    static uint32_t shuffleKey(uint64_t key) { return static_cast<uint32_t>(key); }
    static uint32_t xKey(uint64_t key) { return static_cast<uint32_t>(key >> 32); }
    // The index Owen-scrambled as a binary fraction whose top digit is its most significant bit:
    // a bit is flipped as a function of the bits above it, so every aligned block of 2^k indices
    // maps onto an aligned block of 2^k indices (whose Sobol points form a net).
    uint32_t shuffledIndex(uint64_t key) const {
        return reverseBits(lowToHighPermutation(m_reversedIndex, shuffleKey(key)));
    }

    uint64_t m_streamKey = 0;
    uint32_t m_reversedIndex = 0, m_dimension = 0;
};

ALPHORN_REGISTER(Sampler, "sobol", Sobol);

}  // namespace alphorn
