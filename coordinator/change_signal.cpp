#include "coordinator/change_signal.h"

namespace alphorn::coordinator {

void ChangeSignal::notify(bool ended) {
    {
        std::lock_guard lock(m_mutex);
        ++m_version;
        m_ended = ended;
    }
    m_changed.notify_all();
}

void ChangeSignal::close() {
    {
        std::lock_guard lock(m_mutex);
        m_closed = true;
    }
    m_changed.notify_all();
}

ChangeSignal::Seen ChangeSignal::current() const {
    std::lock_guard lock(m_mutex);
    return seenLocked();
}

ChangeSignal::Seen ChangeSignal::waitForChange(uint64_t seenVersion, TimePoint until) const {
    std::unique_lock lock(m_mutex);
    m_changed.wait_until(lock, until, [&] { return m_closed || m_version != seenVersion; });
    return seenLocked();
}

ChangeSignal::Seen ChangeSignal::waitForEnd(TimePoint until) const {
    std::unique_lock lock(m_mutex);
    m_changed.wait_until(lock, until, [&] { return m_closed || m_ended; });
    return seenLocked();
}

}  // namespace alphorn::coordinator
