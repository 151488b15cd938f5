// A job's event log, for `alphorn logs JOB`: submitted, leased, merged, failed (with the worker's
// error text), poisoned, handed back, checkpointed, paused, resumed, priority changed, retried,
// cancelled, finished. Bounded so that a job of a million units cannot fill the coordinator: it
// keeps the first kHeadEvents events (the submission and the job's start) and the most recent
// events, at most kMaxEvents in all; events in between are dropped and counted, and each
// message is cut to kMaxMessageBytes. So one job's log takes at most about 2 MiB, and typically
// (short messages) about 100 KiB. The coordinator stores it with the job (JobStore::saveJobLog).
// Not thread-safe: the coordinator calls it under its lock.
#pragma once

#include "alphorn/v1/farm.pb.h"

#include <cstdint>
#include <deque>
#include <optional>
#include <string>
#include <vector>

namespace alphorn::coordinator {

class EventLog {
  public:
    static constexpr size_t kMaxEvents = 1000;
    static constexpr size_t kHeadEvents = 50;
    static constexpr size_t kMaxMessageBytes = 2000;

    EventLog() = default;
    // A log as stored; an event beyond the bound is dropped as if added one by one.
    explicit EventLog(const v1::JobEventLog& stored);

    // Appends an event at `time` (seconds since the Unix epoch).
    void add(double time, v1::JobEventKind kind, std::string message, uint64_t workerId = 0,
             std::optional<uint32_t> unitIndex = std::nullopt);

    // The kept events with a sequence number above `sequence`, oldest first.
    std::vector<v1::JobEvent> after(uint64_t sequence) const;
    uint64_t dropped() const { return m_dropped; }
    size_t size() const { return m_head.size() + m_tail.size(); }

    // The stored form; changed() says whether anything was added since markSaved().
    v1::JobEventLog record() const;
    bool changed() const { return m_changed; }
    void markSaved() { m_changed = false; }
    void markChanged() { m_changed = true; }  // a save failed: try again

  private:
    void append(v1::JobEvent event);

    std::vector<v1::JobEvent> m_head;  // the first kHeadEvents events
    std::deque<v1::JobEvent> m_tail;   // the most recent ones
    uint64_t m_dropped = 0;
    uint64_t m_nextSequence = 1;
    bool m_changed = false;
};

}  // namespace alphorn::coordinator
