// RGB colour (linear, Rec. 709 primaries), as in Nori.
#pragma once

#include "common/core/common.h"

namespace alphorn {

struct Color3f : public Eigen::Array3f {
    using Base = Eigen::Array3f;

    Color3f(float value = 0.0f) : Base(value, value, value) {}
    Color3f(float r, float g, float b) : Base(r, g, b) {}
    template <typename Derived>
    Color3f(const Eigen::ArrayBase<Derived>& p) : Base(p) {}
    template <typename Derived>
    Color3f& operator=(const Eigen::ArrayBase<Derived>& p) {
        this->Base::operator=(p);
        return *this;
    }

    float& r() { return x(); }
    float r() const { return x(); }
    float& g() { return y(); }
    float g() const { return y(); }
    float& b() { return z(); }
    float b() const { return z(); }

    // Luminance Y with the Rec. 709 weights used by Nori's statistical tests.
    float luminance() const { return 0.212671f * r() + 0.715160f * g() + 0.072169f * b(); }
    bool isValid() const {
        for (int i = 0; i < 3; ++i)
            if (!std::isfinite(coeff(i)) || coeff(i) < 0.0f) return false;
        return true;
    }
    bool isBlack() const { return r() == 0.0f && g() == 0.0f && b() == 0.0f; }
    Color3f toSRGB() const;
    Color3f toLinearRGB() const;
    std::string toString() const;
};

}  // namespace alphorn
