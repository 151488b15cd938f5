// <texture type="bitmap">: an image file looked up by uv with bilinear interpolation.
//   filename  an OpenEXR (.exr, linear RGB) or PNG (.png, sRGB-decoded to linear) file,
//             relative to the scene file
//   wrapMode  "repeat" (default), "clamp" or "mirror": what lies outside [0, 1]^2
//   raw       PNG only: true reads the stored values as data (byte / 255, no sRGB decoding),
//             as normal maps need; default false
//   uscale vscale uoffset voffset   the uv mapping
// u runs left to right across the image and v bottom to top (v = 0 is the last row), so an
// image appears upright on a quad whose uv has v pointing up. Texel centres lie at
// ((i + 0.5) / width, 1 - (j + 0.5) / height).
#include "common/core/image.h"
#include "common/texture/mapping.h"
#include "common/texture/texture.h"

#include <absl/strings/ascii.h>

#include <filesystem>

namespace alphorn {

class BitmapTexture : public Texture {
  public:
    enum class Wrap { Repeat, Clamp, Mirror };

    explicit BitmapTexture(const PropertyList& props) : m_mapping(props) {
        m_path = props.resolvePath(props.getString("filename"));
        const std::string wrap = props.getString("wrapMode", "repeat");
        if (wrap == "repeat")
            m_wrap = Wrap::Repeat;
        else if (wrap == "clamp")
            m_wrap = Wrap::Clamp;
        else if (wrap == "mirror")
            m_wrap = Wrap::Mirror;
        else
            props.fail("wrapMode must be repeat, clamp or mirror, got \"%s\"", wrap);
        const bool raw = props.getBoolean("raw", false);

        failUnlessExists(props, m_path);
        const std::string extension =
            absl::AsciiStrToLower(std::filesystem::path(m_path).extension().string());
        try {
            if (extension == ".exr") {
                if (raw) props.fail("raw only applies to PNG files (EXR is already linear data)");
                m_image = readEXR(m_path);
            } else if (extension == ".png") {
                m_image = readPNG(m_path);
                // readPNG decodes sRGB; re-encoding and rounding recovers the stored bytes.
                if (raw)
                    for (float& v : m_image.rgb)
                        v = std::round(Color3f(v).toSRGB().r() * 255.0f) / 255.0f;
            } else {
                props.fail("unsupported texture file \"%s\" (expected .exr or .png)", m_path);
            }
        } catch (const Error& e) {
            props.rethrowHere(e);
        }
        if (m_image.width <= 0 || m_image.height <= 0)
            props.fail("the texture \"%s\" is empty", m_path);
        m_lower = Color3f(Infinity);
        m_upper = Color3f(-Infinity);
        for (size_t i = 0; i < m_image.rgb.size(); ++i) {
            const float v = m_image.rgb[i];
            if (!std::isfinite(v)) props.fail("the texture \"%s\" has non-finite values", m_path);
            m_lower[i % 3] = std::min(m_lower[i % 3], v);
            m_upper[i % 3] = std::max(m_upper[i % 3], v);
        }
    }

    static void failUnlessExists(const PropertyList& props, const std::string& path) {
        if (!std::filesystem::is_regular_file(path))
            props.fail("the texture file \"%s\" does not exist", path);
    }

    Color3f eval(const Point2f& uvIn, const Point3f&) const override {
        const Point2f uv = m_mapping.map(uvIn);
        // The clamp keeps absurd uvs out of the integer conversion below; NaN passes through it
        // and is caught next.
        const float x = clamp(uv.x() * m_image.width - 0.5f, -1e9f, 1e9f);
        const float y = clamp((1.0f - uv.y()) * m_image.height - 0.5f, -1e9f, 1e9f);
        if (std::isnan(x) || std::isnan(y)) return m_lower;
        const float fx = std::floor(x), fy = std::floor(y);
        const float tx = x - fx, ty = y - fy;
        const int64_t x0 = static_cast<int64_t>(fx), y0 = static_cast<int64_t>(fy);
        const Color3f value = (1.0f - ty) * ((1.0f - tx) * texel(x0, y0) + tx * texel(x0 + 1, y0)) +
                              ty * ((1.0f - tx) * texel(x0, y0 + 1) + tx * texel(x0 + 1, y0 + 1));
        // Weights sum to one, but rounding could step an ulp outside the texel range.
        return value.max(m_lower).min(m_upper);
    }

    bool is3D() const override { return false; }
    Color3f lowerBound() const override { return m_lower; }
    Color3f upperBound() const override { return m_upper; }
    std::string toString() const override { return "bitmap \"" + m_path + "\""; }

  private:
    static int64_t wrapIndex(int64_t i, int64_t n, Wrap wrap) {
        switch (wrap) {
            case Wrap::Repeat:
                return ((i % n) + n) % n;
            case Wrap::Clamp:
                return std::clamp<int64_t>(i, 0, n - 1);
            case Wrap::Mirror: {
                const int64_t period = 2 * n;
                const int64_t j = ((i % period) + period) % period;
                return j < n ? j : period - 1 - j;
            }
        }
        return 0;
    }
    Color3f texel(int64_t x, int64_t y) const {
        return m_image.get(static_cast<int>(wrapIndex(x, m_image.width, m_wrap)),
                           static_cast<int>(wrapIndex(y, m_image.height, m_wrap)));
    }

    UVMapping m_mapping;
    std::string m_path;
    Wrap m_wrap = Wrap::Repeat;
    Image m_image;
    Color3f m_lower, m_upper;
};

ALPHORN_REGISTER(Texture, "bitmap", BitmapTexture);

// The file a bitmap texture reads, for listing a scene's files: found, not decoded.
void listBitmapFile(const PropertyList& props) {
    BitmapTexture::failUnlessExists(props, props.resolvePath(props.getString("filename")));
}
ALPHORN_REGISTER_FILES(Texture, "bitmap", listBitmapFile);

}  // namespace alphorn
