// Image files: float RGB OpenEXR for results, 8-bit sRGB PNG for viewing.
#pragma once

#include "common/render/film.h"

namespace alphorn {

// Writes a float RGB EXR (ZIP compression). Throws Error naming the path on failure.
void writeEXR(const std::string& path, const Image& image);
// Reads the R, G, B channels of an EXR as float (missing channels are zero).
Image readEXR(const std::string& path);
// Writes an 8-bit sRGB PNG of image * 2^exposure, clamped to [0, 1].
void writePNG(const std::string& path, const Image& image, float exposure = 0.0f);
// Reads an 8-bit or 16-bit PNG (grey or RGB, alpha ignored) as linear float RGB.
Image readPNG(const std::string& path);
// The PNG path written beside an EXR: "out/x.exr" -> "out/x.png".
std::string pngPathFor(const std::string& exrPath);

}  // namespace alphorn
