// Images in memory, and their files: float RGB OpenEXR for results, 8-bit sRGB PNG for viewing,
// and PFM for reading the float maps other renderers use.
#pragma once

#include "common/core/color.h"

#include <cstdint>
#include <string>
#include <vector>

namespace alphorn {

// A float RGB image, rows top to bottom.
struct Image {
    int width = 0, height = 0;
    std::vector<float> rgb;  // 3 floats per pixel

    Image() = default;
    Image(int w, int h) : width(w), height(h), rgb(3 * size_t(w) * h, 0.0f) {}
    Color3f get(int x, int y) const {
        const float* p = &rgb[3 * (size_t(y) * width + x)];
        return Color3f(p[0], p[1], p[2]);
    }
    void set(int x, int y, const Color3f& c) {
        float* p = &rgb[3 * (size_t(y) * width + x)];
        p[0] = c.r();
        p[1] = c.g();
        p[2] = c.b();
    }
};

// The most pixels an image file may declare (16384 x 16384; read as float RGB: 3 GiB).
inline constexpr uint64_t kMaxImageFilePixels = uint64_t(1) << 28;
// Refuses, naming the path, an image file whose header declares more than kMaxImageFilePixels
// (a ResourceLimitError: the image is too large, not broken) or more raw bytes (`rawBytes`, in the
// file's own pixel format) than `fileBytes` of compressed data can hold (deflate, the densest
// compression either format uses, stays under 1032:1): a small file that claims a huge image is
// truncated or crafted, and is refused before memory is allocated for it.
void checkDeclaredImageSize(const std::string& path, uint64_t width, uint64_t height,
                            uint64_t rawBytes, uint64_t fileBytes);

// Writes a float RGB EXR (ZIP compression). Throws Error naming the path on failure.
void writeEXR(const std::string& path, const Image& image);
// The bytes writeEXR writes, in memory (for sending an image without touching a disk).
std::string encodeEXR(const Image& image);
// Reads the R, G, B channels of an EXR as float (missing channels are zero).
Image readEXR(const std::string& path);
// Reads a Portable Float Map (PFM: "PF" RGB or "Pf" grey, either byte order; rows are stored
// bottom to top and returned top to bottom, like every other image here). The file must hold
// exactly the pixels its header declares.
Image readPFM(const std::string& path);
// Writes a little-endian RGB PFM (for tests and tools: renders are written as EXR).
void writePFM(const std::string& path, const Image& image);
// Writes an 8-bit sRGB PNG of image * 2^exposure, clamped to [0, 1].
void writePNG(const std::string& path, const Image& image, float exposure = 0.0f);
// The bytes writePNG writes, in memory.
std::string encodePNG(const Image& image, float exposure = 0.0f);
// Reads an 8-bit or 16-bit PNG (grey or RGB, alpha ignored) as linear float RGB.
Image readPNG(const std::string& path);
// The PNG path written beside an EXR: "out/x.exr" -> "out/x.png".
std::string pngPathFor(const std::string& exrPath);

}  // namespace alphorn
