// Pixel reconstruction filters (Nori's). A sample at image position x contributes to every pixel
// whose centre lies within radius(); the 2D weight is weight(dx) * weight(dy), the filter
// tabulated as Nori's and pbrt's films tabulate it. eval's magnitude is at most 1 (every filter
// here peaks at 1 or below): the film rounds the taps of most samples through 64-bit integers
// (film.cpp) and relies on it.
#pragma once

#include "common/core/object.h"

#include <algorithm>
#include <array>
#include <cmath>

namespace alphorn {

class ReconstructionFilter : public Object {
  public:
    ObjectKind kind() const override { return ObjectKind::Filter; }
    float radius() const { return m_radius; }
    virtual float eval(float x) const = 0;
    // The filter as the film weighs taps: eval at the centre of the table's bin that holds |x|,
    // for |x| <= radius(). Every sample evaluates the filter at 8 or more offsets, and exp or a
    // cubic there cost about 4% of a Cornell box render; the bins are radius / 256 wide (1/128
    // of a pixel for the default gaussian), far below a pixel's size.
    float weight(float x) const {
        const int bin = static_cast<int>(std::abs(x) * m_binsPerUnit);
        return m_table[std::min(bin, kTableSize - 1)];
    }

    static constexpr float kMinRadius = 0.5f;
    static constexpr float kMaxRadius = 7.0f;

    static constexpr int kTableSize = 256;

  protected:
    static float validatedRadius(const PropertyList& props, float defaultRadius);
    // Fills weight()'s table from eval; every filter's constructor ends with it (eval then
    // dispatches to that filter).
    void tabulate();
    float m_radius = 0.5f;

  private:
    std::array<float, kTableSize> m_table{};
    float m_binsPerUnit = 0.0f;
};

}  // namespace alphorn
