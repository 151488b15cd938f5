// <texture type="perlin3d">: fractal 3D Perlin gradient noise (Perlin 2002, "Improving noise")
// in the texture space placed by `toWorld`:
//
//     n(q) = sum_{o < octaves} persistence^o noise(frequency lacunarity^o q) / sum persistence^o
//     t    = clamp(0.5 + 0.5 n, 0, 1),   value = color0 + (color1 - color0) t
//
// `min`/`max` (floats) are a grey shorthand for color0/color1. The permutation table is
// shuffled from the integer `seed`, so the same seed gives the same noise on every machine.
// The clamp (rarely active: |noise| stays within about 1) makes color0/color1 true bounds.
#include "common/core/rng.h"
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

#include <array>
#include <numeric>

namespace alphorn {

class Perlin3D : public Texture {
  public:
    explicit Perlin3D(const PropertyList& props) : m_mapping(props) {
        const bool grey = props.has("min") || props.has("max");
        if (grey && (props.has("color0") || props.has("color1")))
            props.fail("give either min/max or color0/color1, not both");
        if (grey) {
            m_color0 = Color3f(props.getFloat("min", 0.0f));
            m_color1 = Color3f(props.getFloat("max", 1.0f));
        } else {
            m_color0 = props.getColor("color0", Color3f(0.0f));
            m_color1 = props.getColor("color1", Color3f(1.0f));
        }
        if (!m_color0.allFinite() || !m_color1.allFinite()) props.fail("colours must be finite");
        m_frequency = props.getPositiveFloat("frequency", 1.0f);
        m_octaves = props.getPositiveInteger("octaves", 4);
        if (m_octaves > 16) props.fail("octaves must be at most 16, got %d", m_octaves);
        m_persistence = props.getPositiveFloat("persistence", 0.5f);
        m_lacunarity = props.getPositiveFloat("lacunarity", 2.0f);
        const int seed = props.getInteger("seed", 0);

        std::array<int, 256> p;
        std::iota(p.begin(), p.end(), 0);
        Rng rng(static_cast<uint64_t>(static_cast<uint32_t>(seed)), 0, 0x9e3779b9,
                StreamPurpose::Test);
        for (int i = 255; i > 0; --i)
            std::swap(p[i], p[rng.nextUInt(static_cast<uint32_t>(i + 1))]);
        for (int i = 0; i < 512; ++i) m_perm[i] = p[i & 255];
        float amplitude = 1.0f;
        m_amplitudeSum = 0.0f;
        for (int o = 0; o < m_octaves; ++o, amplitude *= m_persistence) m_amplitudeSum += amplitude;
    }

    Color3f eval(const Point2f&, const Point3f& p) const override {
        const Point3f q = m_mapping.map(p);
        float sum = 0.0f, amplitude = 1.0f, frequency = m_frequency;
        for (int o = 0; o < m_octaves; ++o) {
            sum += amplitude * noise(q.x() * frequency, q.y() * frequency, q.z() * frequency);
            amplitude *= m_persistence;
            frequency *= m_lacunarity;
        }
        const float t = clamp(0.5f + 0.5f * sum / m_amplitudeSum, 0.0f, 1.0f);
        const Color3f value = m_color0 + (m_color1 - m_color0) * t;
        return value.max(lowerBound()).min(upperBound());
    }
    bool is3D() const override { return true; }
    Color3f lowerBound() const override { return m_color0.min(m_color1); }
    Color3f upperBound() const override { return m_color0.max(m_color1); }
    std::string toString() const override { return "perlin3d"; }

    // Improved noise, roughly in [-1, 1], zero at integer lattice points.
    float noise(float x, float y, float z) const {
        // Far outside any scene (or NaN) the lattice arithmetic below would overflow.
        if (!(std::abs(x) < 1e7f && std::abs(y) < 1e7f && std::abs(z) < 1e7f)) return 0.0f;
        const float fx = std::floor(x), fy = std::floor(y), fz = std::floor(z);
        const int X = static_cast<int>(static_cast<int64_t>(fx) & 255);
        const int Y = static_cast<int>(static_cast<int64_t>(fy) & 255);
        const int Z = static_cast<int>(static_cast<int64_t>(fz) & 255);
        x -= fx;
        y -= fy;
        z -= fz;
        const float u = fade(x), v = fade(y), w = fade(z);
        const int A = m_perm[X] + Y, AA = m_perm[A] + Z, AB = m_perm[A + 1] + Z;
        const int B = m_perm[X + 1] + Y, BA = m_perm[B] + Z, BB = m_perm[B + 1] + Z;
        return lerp(
            w,
            lerp(v, lerp(u, grad(m_perm[AA], x, y, z), grad(m_perm[BA], x - 1, y, z)),
                 lerp(u, grad(m_perm[AB], x, y - 1, z), grad(m_perm[BB], x - 1, y - 1, z))),
            lerp(v,
                 lerp(u, grad(m_perm[AA + 1], x, y, z - 1), grad(m_perm[BA + 1], x - 1, y, z - 1)),
                 lerp(u, grad(m_perm[AB + 1], x, y - 1, z - 1),
                      grad(m_perm[BB + 1], x - 1, y - 1, z - 1))));
    }

  private:
    static float fade(float t) { return t * t * t * (t * (t * 6.0f - 15.0f) + 10.0f); }
    // The 12 cube-edge gradients of improved noise (4 repeated to make 16).
    static float grad(int hash, float x, float y, float z) {
        const int h = hash & 15;
        const float u = h < 8 ? x : y;
        const float v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
        return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
    }

    SpaceMapping m_mapping;
    Color3f m_color0, m_color1;
    float m_frequency, m_persistence, m_lacunarity, m_amplitudeSum;
    int m_octaves;
    std::array<int, 512> m_perm;
};

ALPHORN_REGISTER(Texture, "perlin3d", Perlin3D);

}  // namespace alphorn
