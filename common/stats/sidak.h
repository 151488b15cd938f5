// Šidák correction for m independent hypothesis tests: testing each at
// alpha' = 1 - (1 - alpha)^(1/m) keeps the chance of any false rejection at alpha.
#pragma once

#include <cmath>

namespace alphorn::stats {

inline double sidakAlpha(double alpha, int testCount) {
    if (testCount <= 1) return alpha;
    // expm1/log1p keep alpha' accurate for tiny alpha, where 1 - (1 - alpha) loses digits.
    return -std::expm1(std::log1p(-alpha) / testCount);
}

}  // namespace alphorn::stats
