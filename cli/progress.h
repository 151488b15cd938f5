// A progress line for long work: a live bar with elapsed time, ETA and throughput on a terminal,
// fitted to its width, and plain, occasional log lines otherwise (CI logs, pipes).
#pragma once

#include "common/render/local_render.h"

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>

namespace alphorn::cli {

class ProgressLine {
  public:
    // `what` names the counted work in messages: "passes", "units".
    ProgressLine(std::string label, uint64_t total, std::string what = "passes");
    // done: units of work finished so far; extra: free text (e.g. "3.2 Msamples/s").
    void update(uint64_t done, const std::string& extra = "");
    // The same with the elapsed time and ETA measured elsewhere: a farm job's come from the
    // coordinator, which has watched it since it was submitted (a negative ETA shows as
    // unknown). finish() then reports the last elapsed time given here.
    void update(uint64_t done, const std::string& extra, double elapsedSeconds, double etaSeconds);
    // The closing line, e.g. "job 3: done, 64/64 passes in 1:02"; outcome says how it ended.
    void finish(const std::string& outcome = "done");

  private:
    void show(uint64_t done, const std::string& extra, double elapsed, double eta);

    std::string m_label, m_what;
    uint64_t m_total, m_done = 0;
    bool m_tty;
    std::chrono::steady_clock::time_point m_start, m_lastPrint;
    int m_lastDecile = -1;
    double m_reportedElapsed = -1.0;  // from update(..., elapsed, eta); negative: measure here
};

std::string formatDuration(double seconds);

// Throughput in the one unit every command shows: "1.23 Msamples/s  4.56 Mrays/s" (a sample is
// one camera path through one pixel in one pass). Without a ray rate (not known) only samples.
std::string speedText(double samplesPerSecond, std::optional<double> raysPerSecond);

// The error estimate in a progress line: "err 3.1%" (at the last decision point), with the
// target "err 3.1% -> 2%" and the projected passes to reach it; "err -" before the first.
// `projected`: the projected passes when known already (a farm job's status), else computed.
std::string errorText(const std::optional<ErrorEstimate>& estimate,
                      std::optional<double> targetError,
                      std::optional<double> projected = std::nullopt);
std::string errorText(const RenderStatus& status, std::optional<double> targetError);
// The closing line of a render about its error: the estimate at the last decision point, and
// whether the target was reached or the cap stopped it.
std::string finalEstimateText(const RenderStatus& status, std::optional<double> targetError,
                              uint32_t cap);

// --target-error E, --max-passes N and --adaptive (render, submit, cluster): a target needs the
// cap and excludes the options that fix the number of passes (`fixedPasses`); --adaptive needs
// a target.
void addTargetErrorOptions(CLI::App& sub, std::optional<double>& targetError,
                           std::optional<uint32_t>& maxPasses, bool& adaptive,
                           const std::vector<CLI::Option*>& fixedPasses);

// The columns of the terminal on stderr (TIOCGWINSZ), else $COLUMNS, else 80.
int terminalColumns();

// One live progress line that fits in `columns` characters (the last column stays free, so no
// terminal wraps it): the parts that do not fit are left out, least important first (extra,
// elapsed time, ETA), the bar shrinks or goes, and what still does not fit is cut.
std::string fitProgressLine(int columns, const std::string& label, double fraction,
                            const std::string& count, const std::string& elapsed,
                            const std::string& eta, const std::string& extra);

}  // namespace alphorn::cli
