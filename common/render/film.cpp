#include "common/render/film.h"

#include "common/core/error.h"

#include <cstring>

namespace alphorn {

FilmBlock::FilmBlock(int x0, int y0, int width, int height)
    : m_x0(x0),
      m_y0(y0),
      m_width(width),
      m_height(height),
      m_pixels(static_cast<size_t>(width) * height) {}

void FilmBlock::clear() {
    std::fill(m_pixels.begin(), m_pixels.end(), PixelSum{});
    invalidSamples = 0;
}

void FilmBlock::add(const FilmBlock& other) {
    int xBegin = std::max(m_x0, other.m_x0),
        xEnd = std::min(m_x0 + m_width, other.m_x0 + other.m_width);
    int yBegin = std::max(m_y0, other.m_y0),
        yEnd = std::min(m_y0 + m_height, other.m_y0 + other.m_height);
    for (int y = yBegin; y < yEnd; ++y)
        for (int x = xBegin; x < xEnd; ++x) at(x, y) += other.at(x, y);
    invalidSamples += other.invalidSamples;
}

static_assert(sizeof(PixelSum) == 64, "PixelSum must be four packed 128-bit integers");

std::string FilmBlock::serialize() const {
    // x86-64 and aarch64 are little-endian; the bytes are the in-memory integers.
    std::string bytes(m_pixels.size() * sizeof(PixelSum), '\0');
    if (!m_pixels.empty()) std::memcpy(bytes.data(), m_pixels.data(), bytes.size());
    return bytes;
}

void FilmBlock::deserialize(const std::string& bytes) {
    if (bytes.size() != m_pixels.size() * sizeof(PixelSum))
        fail("film data has %zu bytes, expected %zu for a %dx%d block", bytes.size(),
             m_pixels.size() * sizeof(PixelSum), m_width, m_height);
    if (!bytes.empty()) std::memcpy(m_pixels.data(), bytes.data(), bytes.size());
}

Image resolveImage(const FilmBlock& film, int width, int height) {
    Image image(width, height);
    for (int y = 0; y < height; ++y) {
        for (int x = 0; x < width; ++x) {
            if (!film.contains(x, y)) continue;
            const PixelSum& s = film.at(x, y);
            if (s.weight == 0) continue;
            double w = fromFixedPoint(s.weight);
            image.set(x, y,
                      Color3f(static_cast<float>(fromFixedPoint(s.rgb[0]) / w),
                              static_cast<float>(fromFixedPoint(s.rgb[1]) / w),
                              static_cast<float>(fromFixedPoint(s.rgb[2]) / w)));
        }
    }
    return image;
}

}  // namespace alphorn
