// The coordinator's only source of time. Every part that needs the time is given a Clock, so a
// test can drive leases, deadlines, checkpoints and retention with a clock it moves by hand.
#pragma once

#include <chrono>

namespace alphorn::coordinator {

class Clock {
  public:
    virtual ~Clock() = default;
    // Monotonic seconds from an arbitrary origin: lease deadlines, rates, intervals.
    virtual double monotonicSeconds() const = 0;
    // Seconds since the Unix epoch: what is stored (job creation and end, retention).
    virtual double wallSeconds() const = 0;
};

class SystemClock final : public Clock {
  public:
    double monotonicSeconds() const override {
        return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
            .count();
    }
    double wallSeconds() const override {
        return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
            .count();
    }
};

// A clock that moves only when told to (tests and the simulation).
class ManualClock final : public Clock {
  public:
    explicit ManualClock(double wallStart = 1.7e9) : m_wallStart(wallStart) {}
    double monotonicSeconds() const override { return m_seconds; }
    double wallSeconds() const override { return m_wallStart + m_seconds; }
    void advance(double seconds) { m_seconds += seconds; }

  private:
    double m_wallStart;
    double m_seconds = 0;
};

}  // namespace alphorn::coordinator
