// The Knaus–Zwicker radius schedule of progressive photon mapping ("Progressive Photon Mapping:
// A Probabilistic Approach", 2011). Pass N (counted from 1) gathers photons within r(N), where
//
//     r²(N + 1) = r²(N) · (N + α) / (N + 1),   so   r²(N) = r²(1) · Γ(N + α) / (Γ(1 + α) Γ(N + 1)).
//
// This header is the ONE place the schedule is computed: the local renderer and the farm
// workers reach it through the photon mapper's preparePass(), and the coordinator's progress
// report can include it as it is (header-only, no engine dependency). Because r(N) depends only
// on (r(1), α, N), any worker can render any pass in any order.
//
// Precision: the product form drifts by a relative ~N·ε in float (1% by 10⁶ passes), and even
// the closed form taken as exp(lgamma(N + α) − lgamma(N + 1)) loses ~5·10⁻⁸ at N = 10⁷ because it
// subtracts two numbers near 1.5·10⁸. Boost's tgamma_delta_ratio evaluates the ratio of the two
// gamma functions directly (Lanczos), to ~10⁻¹⁵ relative for every N; radius_schedule_test.cpp
// checks it against a long-double product up to N = 10⁷.
#pragma once

#include <boost/math/special_functions/gamma.hpp>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace alphorn {

namespace detail {
// Plain double arithmetic inside Boost (no silent promotion to long double, whose x87
// transcendental instructions are not guaranteed to agree across CPU vendors); errors throw.
using RadiusSchedulePolicy =
    boost::math::policies::policy<boost::math::policies::promote_double<false>>;
}  // namespace detail

// True when α is a valid Knaus–Zwicker parameter: the schedule needs 0 < α < 1 (α = 1 never
// shrinks the radius, α ≤ 0 shrinks it so fast that the variance grows without bound).
inline bool isValidRadiusAlpha(double alpha) {
    return alpha > 0.0 && alpha < 1.0;
}

// r²(N) / r²(1) for pass N ≥ 1 (N = 1 is the first pass and gives exactly 1).
inline double progressiveRadiusSquaredRatio(uint64_t n, double alpha) {
    if (n == 0) throw std::invalid_argument("progressive radius: passes are counted from 1");
    if (!isValidRadiusAlpha(alpha))
        throw std::invalid_argument("progressive radius: alpha must be in (0, 1), got " +
                                    std::to_string(alpha));
    if (n == 1) return 1.0;
    const detail::RadiusSchedulePolicy policy;
    // tgamma_delta_ratio(z, d) = Γ(z) / Γ(z + d): here Γ(N + α) / Γ(N + 1).
    return boost::math::tgamma_delta_ratio(static_cast<double>(n) + alpha, 1.0 - alpha, policy) /
           boost::math::tgamma(1.0 + alpha, policy);
}

// The gather radius of the pass with 0-based index `pass` (the renderer's numbering), starting
// from `initialRadius` at pass 0.
inline double progressiveRadius(double initialRadius, double alpha, uint64_t pass) {
    return initialRadius * std::sqrt(progressiveRadiusSquaredRatio(pass + 1, alpha));
}

// The radius a progress report shows after `passesDone` complete passes: that of the last
// complete pass (the smallest in the image so far), or pass 0's before any is complete.
inline double reportedProgressiveRadius(double initialRadius, double alpha, uint64_t passesDone) {
    return progressiveRadius(initialRadius, alpha, passesDone > 0 ? passesDone - 1 : 0);
}

}  // namespace alphorn
