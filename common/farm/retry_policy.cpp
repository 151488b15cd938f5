#include "common/farm/retry_policy.h"

#include "common/core/error.h"

#include <algorithm>

namespace alphorn::farm {

RetryPolicy::RetryPolicy(RetryTimings timings, uint64_t seed) : m_timings(timings), m_random(seed) {
    if (timings.initial.count() <= 0)
        fail("retry policy: the initial delay must be positive (got %d ms)",
             timings.initial.count());
    if (timings.cap < timings.initial)
        fail("retry policy: the cap (%d ms) is below the initial delay (%d ms)",
             timings.cap.count(), timings.initial.count());
}

std::chrono::milliseconds RetryPolicy::currentCeiling() const {
    // Doubling stops at the cap; counting the shifts keeps the product from overflowing.
    int64_t ceiling = m_timings.initial.count();
    for (uint32_t i = 0; i < m_failures && ceiling < m_timings.cap.count(); ++i) ceiling *= 2;
    return std::chrono::milliseconds(std::min<int64_t>(ceiling, m_timings.cap.count()));
}

std::chrono::milliseconds RetryPolicy::nextDelay() {
    const int64_t ceiling = currentCeiling().count();
    ++m_failures;
    // Full jitter: uniform over [0, ceiling], whole milliseconds.
    const uint64_t draw = (uint64_t(m_random()) << 32) | m_random();
    return std::chrono::milliseconds(int64_t(draw % uint64_t(ceiling + 1)));
}

}  // namespace alphorn::farm
