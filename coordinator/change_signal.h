// A job's change signal, for WatchJob: a version that the coordinator bumps whenever something
// the job's status shows changes (submitted, leased, merged, failed, discarded, checkpointed,
// paused, given a priority, ended, retried), and waits that return as soon as it moves. It has
// its own small lock, so a watcher never waits on the coordinator's lock, and a change costs
// the coordinator one uncontended lock and a notify. Shared between the job and its watchers:
// a watcher may outlive a deleted job, whose signal is closed.
// The waits take a real-time deadline: they only bound how long a stream stays quiet.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <mutex>

namespace alphorn::coordinator {

class ChangeSignal {
  public:
    using TimePoint = std::chrono::steady_clock::time_point;
    struct Seen {
        uint64_t version = 0;
        bool ended = false;   // the job is done, failed or cancelled (as of `version`)
        bool closed = false;  // the job is gone or the coordinator is stopping: stop watching
    };

    // The job's status changed; `ended` tells whether it has ended now.
    void notify(bool ended);
    // Wakes every waiter for good: the job was deleted or the coordinator is stopping.
    void close();

    Seen current() const;
    // Returns once the version differs from `seenVersion`, the signal is closed, or `until`
    // has passed (then with the version unchanged).
    Seen waitForChange(uint64_t seenVersion, TimePoint until) const;
    // Returns once the job has ended, the signal is closed, or `until` has passed: a watcher
    // that gathers the changes of a short while still hears of the end at once.
    Seen waitForEnd(TimePoint until) const;

  private:
    Seen seenLocked() const { return {m_version, m_ended, m_closed}; }

    mutable std::mutex m_mutex;
    mutable std::condition_variable m_changed;
    uint64_t m_version = 1;
    bool m_ended = false, m_closed = false;
};

}  // namespace alphorn::coordinator
