// How farm programs wait between attempts at a call that failed for a transient reason (the
// coordinator restarting, a network blip): exponential backoff with full jitter. The n-th delay
// is drawn uniformly from [0, min(cap, initial * 2^n)], so a restarted coordinator is not hit by
// every worker at once, yet the expected wait stays bounded by the cap. The draws come from a
// seeded generator: a test, or a replay, sees the same delays again.
#pragma once

#include <pcg_random.hpp>

#include <chrono>
#include <cstdint>

namespace alphorn::farm {

struct RetryTimings {
    std::chrono::milliseconds initial{100};  // upper bound of the first delay
    std::chrono::milliseconds cap{1000};     // no delay exceeds this
};

class RetryPolicy {
  public:
    // Throws Error when `initial` is not positive or `cap` is less than `initial`.
    RetryPolicy(RetryTimings timings, uint64_t seed);

    // The delay before the next attempt; counts the attempt.
    std::chrono::milliseconds nextDelay();
    // After a success: the next failure starts again from `initial`.
    void reset() { m_failures = 0; }
    // Failures since the last reset().
    uint32_t failures() const { return m_failures; }
    // The upper bound of the delay nextDelay() will draw next.
    std::chrono::milliseconds currentCeiling() const;

  private:
    RetryTimings m_timings;
    pcg32 m_random;
    uint32_t m_failures = 0;
};

}  // namespace alphorn::farm
