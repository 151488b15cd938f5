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
    // The closing line, e.g. "job 3: done, 64/64 passes in 1:02"; outcome says how it ended.
    void finish(const std::string& outcome = "done");

  private:
    std::string m_label;
    uint64_t m_total, m_done = 0;
    bool m_tty;
    std::chrono::steady_clock::time_point m_start, m_lastPrint;
    int m_lastDecile = -1;
};

std::string formatDuration(double seconds);

}  // namespace alphorn::cli
