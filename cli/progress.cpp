#include "cli/progress.h"

#include "cli/commands.h"

#include <absl/strings/str_format.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace alphorn::cli {

std::string formatDuration(double seconds) {
    if (!(seconds >= 0.0) || seconds > 1e7) return "--:--";
    long s = static_cast<long>(seconds + 0.5);
    if (s >= 3600) return absl::StrFormat("%ld:%02ld:%02ld", s / 3600, (s / 60) % 60, s % 60);
    return absl::StrFormat("%ld:%02ld", s / 60, s % 60);
}

std::string speedText(double samplesPerSecond, std::optional<double> raysPerSecond) {
    std::string text = absl::StrFormat("%.2f Msamples/s", samplesPerSecond * 1e-6);
    if (raysPerSecond) text += absl::StrFormat("  %.2f Mrays/s", *raysPerSecond * 1e-6);
    return text;
}

std::string errorText(const std::optional<ErrorEstimate>& estimate,
                      std::optional<double> targetError, std::optional<double> projected) {
    std::string text = "err ";
    text += estimate ? absl::StrFormat("%.3g%%", 100.0 * estimate->relativeRmse) : "-";
    // A progressive photon mapper's estimate includes the radius's bias: shown as its part.
    if (estimate && estimate->relativeBias)
        text += absl::StrFormat(" (bias %.3g%%)", 100.0 * *estimate->relativeBias);
    if (targetError) {
        text += absl::StrFormat(" -> %.3g%%", 100.0 * *targetError);
        if (estimate)
            text += absl::StrFormat(" (~%.0f passes)",
                                    projected.value_or(projectedPasses(*estimate, *targetError)));
    }
    return text;
}

std::string errorText(const RenderStatus& status, std::optional<double> targetError) {
    std::string text = errorText(status.estimate, targetError);
    if (status.adaptiveTiles > 0)
        text += absl::StrFormat(" [%u/%u tiles done]", status.adaptiveTilesFinished,
                                status.adaptiveTiles);
    return text;
}

std::string finalEstimateText(const RenderStatus& status, std::optional<double> targetError,
                              uint32_t cap) {
    if (!status.estimate)
        return "error estimate: none (it needs 4 passes, or 2 passes of a film with light)";
    std::string text = absl::StrFormat(
        "error estimate: relative RMSE %.4g at %u passes (from the odd and even passes",
        status.estimate->relativeRmse, status.estimate->passes);
    text += status.estimate->relativeBias
                ? absl::StrFormat("; of it the radius's bias %.4g, from two radii)",
                                  *status.estimate->relativeBias)
                : ")";
    if (targetError) {
        if (status.targetReached)
            text += absl::StrFormat("; target %.4g reached", *targetError);
        else if (status.passesDone >= cap)
            text += absl::StrFormat(
                "; target %.4g not reached within --max-passes %u "
                "(about %.0f passes would reach it)",
                *targetError, cap, projectedPasses(*status.estimate, *targetError));
        if (status.adaptiveTiles > 0)
            text += absl::StrFormat(" (adaptive: %u of %u tiles met it)",
                                    status.adaptiveTilesFinished, status.adaptiveTiles);
    }
    return text;
}

void addTargetErrorOptions(CLI::App& sub, std::optional<double>& targetError,
                           std::optional<uint32_t>& maxPasses, bool& adaptive,
                           const std::vector<CLI::Option*>& fixedPasses) {
    CLI::Option* target =
        sub.add_option("--target-error", targetError,
                       "Stop at the first of 4, 8, 16, ... passes (or --max-passes) whose "
                       "estimated relative RMSE of the luminance is at most E (e.g. 0.02); "
                       "needs --max-passes")
            ->check(kFinite & CLI::Range(1e-6, 1.0));
    CLI::Option* cap = sub.add_option("--max-passes", maxPasses,
                                      "The most passes a --target-error render may take")
                           ->check(CLI::Range(1u, 1u << 20));
    target->needs(cap);
    cap->needs(target);
    sub.add_flag("--adaptive", adaptive,
                 "With --target-error: at each decision point, a 32x32-pixel tile whose own error "
                 "meets the target gets no more passes")
        ->needs(target);
    for (CLI::Option* fixed : fixedPasses) target->excludes(fixed);
}

int terminalColumns() {
    winsize size = {};
    if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &size) == 0 && size.ws_col > 0) return size.ws_col;
    if (const char* columns = std::getenv("COLUMNS")) {
        char* end = nullptr;
        const long value = std::strtol(columns, &end, 10);
        if (end != columns && *end == '\0' && value > 0 && value < 100000) return int(value);
    }
    return 80;
}

std::string fitProgressLine(int columns, const std::string& label, double fraction,
                            const std::string& count, const std::string& elapsed,
                            const std::string& eta, const std::string& extra) {
    const size_t room = size_t(std::max(columns - 1, 1));
    // The parts after the bar, in the order shown, and which to drop first when short of room.
    struct Part {
        std::string text;
        int dropOrder;  // higher: dropped earlier
        bool shown = true;
    };
    std::vector<Part> parts = {{count, 0}, {elapsed + " elapsed", 2}, {"ETA " + eta, 1}};
    if (!extra.empty()) parts.push_back({extra, 3});
    const size_t minimumBar = 10, widestBar = 30;
    auto length = [&](size_t bar) {
        size_t n = label.size() + (bar ? bar + 3 : 0);  // " [" + bar + "]"
        for (const Part& part : parts)
            if (part.shown) n += 2 + part.text.size();
        return n;
    };
    for (int order = 3; order >= 1 && length(minimumBar) > room; --order)
        for (Part& part : parts)
            if (part.dropOrder == order) part.shown = false;
    size_t bar = 0;
    if (length(minimumBar) <= room)
        bar = std::min(widestBar, minimumBar + room - length(minimumBar));
    std::string line = label;
    if (bar) {
        const size_t filled = std::min(bar, size_t(std::max(0.0, fraction) * double(bar)));
        line += " [" + std::string(filled, '#') + std::string(bar - filled, '.') + "]";
    }
    for (const Part& part : parts)
        if (part.shown) line += "  " + part.text;
    if (line.size() > room) line.resize(room);
    return line;
}

ProgressLine::ProgressLine(std::string label, uint64_t total, std::string what)
    : m_label(std::move(label)),
      m_what(std::move(what)),
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
        const std::string line =
            fitProgressLine(terminalColumns(), m_label, fraction,
                            absl::StrFormat("%llu/%llu %s", (unsigned long long)done,
                                            (unsigned long long)m_total, m_what),
                            formatDuration(elapsed), formatDuration(eta), extra);
        std::fprintf(stderr, "\r\033[K%s", line.c_str());
        std::fflush(stderr);
    } else {
        // Plain lines at every tenth of the work, or every 30 s, whichever comes first.
        int decile = static_cast<int>(fraction * 10.0);
        if (decile == m_lastDecile && now - m_lastPrint < std::chrono::seconds(30)) return;
        m_lastDecile = decile;
        std::fprintf(stderr, "%s: %llu/%llu %s (%.0f%%), %s elapsed, ETA %s  %s\n", m_label.c_str(),
                     (unsigned long long)done, (unsigned long long)m_total, m_what.c_str(),
                     100.0 * fraction, formatDuration(elapsed).c_str(), formatDuration(eta).c_str(),
                     extra.c_str());
    }
    m_lastPrint = now;
}

void ProgressLine::finish(const std::string& outcome) {
    double elapsed =
        m_reportedElapsed >= 0.0
            ? m_reportedElapsed
            : std::chrono::duration<double>(std::chrono::steady_clock::now() - m_start).count();
    if (m_tty) std::fprintf(stderr, "\r\033[K");
    std::fprintf(stderr, "%s: %s, %llu/%llu %s in %s\n", m_label.c_str(), outcome.c_str(),
                 (unsigned long long)m_done, (unsigned long long)m_total, m_what.c_str(),
                 formatDuration(elapsed).c_str());
}

}  // namespace alphorn::cli
