#include "coordinator/event_log.h"

namespace alphorn::coordinator {

EventLog::EventLog(const v1::JobEventLog& stored) {
    for (const v1::JobEvent& event : stored.events()) append(event);
    m_dropped += stored.dropped();
    m_nextSequence = std::max(m_nextSequence, stored.next_sequence());
    m_changed = false;
}

void EventLog::add(double time, v1::JobEventKind kind, std::string message, uint64_t workerId,
                   std::optional<uint32_t> unitIndex) {
    v1::JobEvent event;
    event.set_sequence(m_nextSequence);
    event.set_time_unix_seconds(time);
    event.set_kind(kind);
    event.set_worker_id(workerId);
    if (unitIndex) {
        event.set_has_unit(true);
        event.set_unit_index(*unitIndex);
    }
    if (message.size() > kMaxMessageBytes) {
        // Cut at a character boundary: UTF-8 continuation bytes are 10xxxxxx.
        size_t cut = kMaxMessageBytes;
        while (cut > 0 && (static_cast<unsigned char>(message[cut]) & 0xC0) == 0x80) --cut;
        message = message.substr(0, cut) + " [cut]";
    }
    event.set_message(std::move(message));
    append(std::move(event));
}

void EventLog::append(v1::JobEvent event) {
    m_nextSequence = std::max(m_nextSequence, event.sequence() + 1);
    m_changed = true;
    if (m_head.size() < kHeadEvents) {
        m_head.push_back(std::move(event));
        return;
    }
    m_tail.push_back(std::move(event));
    if (m_head.size() + m_tail.size() > kMaxEvents) {
        m_tail.pop_front();
        ++m_dropped;
    }
}

std::vector<v1::JobEvent> EventLog::after(uint64_t sequence) const {
    std::vector<v1::JobEvent> result;
    for (const v1::JobEvent& event : m_head)
        if (event.sequence() > sequence) result.push_back(event);
    for (const v1::JobEvent& event : m_tail)
        if (event.sequence() > sequence) result.push_back(event);
    return result;
}

v1::JobEventLog EventLog::record() const {
    v1::JobEventLog stored;
    for (const v1::JobEvent& event : after(0)) *stored.add_events() = event;
    stored.set_dropped(m_dropped);
    stored.set_next_sequence(m_nextSequence);
    return stored;
}

}  // namespace alphorn::coordinator
