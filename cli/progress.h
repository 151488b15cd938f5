// A progress line for long work: a live bar with elapsed time, ETA and throughput on a terminal,
// and plain, occasional log lines otherwise (CI logs, pipes).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

namespace alphorn::cli {

class ProgressLine {
  public:
    ProgressLine(std::string label, uint64_t total);
    // done: units of work finished so far; extra: free text (e.g. "3.2 Mrays/s").
    void update(uint64_t done, const std::string& extra = "");
    // The same with the elapsed time and ETA measured elsewhere: a farm job's come from the
    // coordinator, which has watched it since it was submitted (a negative ETA shows as
    // unknown). finish() then reports the last elapsed time given here.
    void update(uint64_t done, const std::string& extra, double elapsedSeconds, double etaSeconds);
    // The closing line, e.g. "job 3: done, 64/64 passes in 1:02"; outcome says how it ended.
    void finish(const std::string& outcome = "done");

  private:
    void show(uint64_t done, const std::string& extra, double elapsed, double eta);

    std::string m_label;
    uint64_t m_total, m_done = 0;
    bool m_tty;
    std::chrono::steady_clock::time_point m_start, m_lastPrint;
    int m_lastDecile = -1;
    double m_reportedElapsed = -1.0;  // from update(..., elapsed, eta); negative: measure here
};

std::string formatDuration(double seconds);

}  // namespace alphorn::cli
