#include "common/core/color.h"

#include <absl/strings/str_format.h>

namespace alphorn {

static float srgbEncode(float v) {
    return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

static float srgbDecode(float v) {
    return v <= 0.04045f ? v * (1.0f / 12.92f) : std::pow((v + 0.055f) * (1.0f / 1.055f), 2.4f);
}

Color3f Color3f::toSRGB() const {
    return Color3f(srgbEncode(r()), srgbEncode(g()), srgbEncode(b()));
}

Color3f Color3f::toLinearRGB() const {
    return Color3f(srgbDecode(r()), srgbDecode(g()), srgbDecode(b()));
}

std::string Color3f::toString() const {
    return absl::StrFormat("[%g, %g, %g]", r(), g(), b());
}

}  // namespace alphorn
