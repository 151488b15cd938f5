#include "cli/progress.h"

#include <absl/strings/str_format.h>
#include <unistd.h>

#include <cstdio>

namespace alphorn::cli {

std::string formatDuration(double seconds) {
    if (!(seconds >= 0.0) || seconds > 1e7) return "--:--";
    long s = static_cast<long>(seconds + 0.5);
    if (s >= 3600) return absl::StrFormat("%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    return absl::StrFormat("%ld:%02ld", s / 60, s % 60);
}

ProgressLine::ProgressLine(std::string label, uint64_t total)
    : m_label(std::move(label)),
      m_total(total),
      m_tty(isatty(STDERR_FILENO)),
      m_start(std::chrono::steady_clock::now()),
      m_lastPrint(m_start) {}

void ProgressLine::update(uint64_t done, const std::string& extra) {
    double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    double fraction = m_total ? double(done) / double(m_total) : 1.0;
    show(done, extra, elapsed, fraction > 0.0 ? elapsed * (1.0 - fraction) / fraction : -1.0);
}

void ProgressLine::update(uint64_t done, const std::string& extra, double elapsedSeconds,
                          double etaSeconds) {
    m_reportedElapsed = elapsedSeconds;
    show(done, extra, elapsedSeconds, etaSeconds);
}

void ProgressLine::show(uint64_t done, const std::string& extra, double elapsed, double eta) {
    m_done = done;
    auto now = std::chrono::steady_clock::now();
    double fraction = m_total ? double(done) / double(m_total) : 1.0;
    if (m_tty) {
        if (done < m_total && now - m_lastPrint < std::chrono::milliseconds(100)) return;
        const int width = 30;
        int filled = static_cast<int>(fraction * width);
        std::string bar(filled, '#');
        bar.resize(width, '.');
        std::fprintf(stderr, "\r\033[K%s [%s] %llu/%llu  %s elapsed  ETA %s  %s", m_label.c_str(),
                     bar.c_str(), (unsigned long long)done, (unsigned long long)m_total,
                     formatDuration(elapsed).c_str(), formatDuration(eta).c_str(), extra.c_str());
        std::fflush(stderr);
    } else {
        // Plain lines at every tenth of the work, or every 30 s, whichever comes first.
        int decile = static_cast<int>(fraction * 10.0);
        if (decile == m_lastDecile && now - m_lastPrint < std::chrono::seconds(30)) return;
        m_lastDecile = decile;
        std::fprintf(stderr, "%s: %llu/%llu (%.0f%%), %s elapsed, ETA %s %s\n", m_label.c_str(),
                     (unsigned long long)done, (unsigned long long)m_total, 100.0 * fraction,
                     formatDuration(elapsed).c_str(), formatDuration(eta).c_str(), extra.c_str());
    }
    m_lastPrint = now;
}

void ProgressLine::finish(const std::string& outcome) {
    double elapsed =
        m_reportedElapsed >= 0.0
            ? m_reportedElapsed
            : std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    if (m_tty) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "%s: %s, %llu/%llu passes in %s\n", m_label.c_str(), outcome.c_str(),
                 (unsigned long long)m_done, (unsigned long long)m_total,
                 formatDuration(elapsed).c_str());
}

}  // namespace alphorn::cli
