#include "common/farm/log.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>

namespace alphorn::farm {

static std::string quoteIfNeeded(const std::string& value) {
    if (!value.empty() && value.find_first_of(" \"=\n\t") == std::string::npos) return value;
    std::string quoted = "\"";
    for (char c : value) {
        if (c == '"' || c == '\\') quoted.push_back('\\');
        if (c == '\n') {
            quoted += "\\n";
            continue;
        }
        quoted.push_back(c);
    }
    return quoted + "\"";
}

static std::atomic<LogSink> g_sink{nullptr};

void setLogSink(LogSink sink) {
    g_sink = sink;
}

std::string formatLogLine(const char* level, const std::string& event,
                          std::initializer_list<LogField> fields) {
    std::string line = std::string("level=") + level + " event=" + event;
    for (const auto& [key, value] : fields) line += " " + key + "=" + quoteIfNeeded(value);
    return line;
}

void logEvent(const char* level, const std::string& event, std::initializer_list<LogField> fields) {
    using namespace std::chrono;
    const auto now = system_clock::now();
    const std::time_t seconds = system_clock::to_time_t(now);
    const int millis =
        static_cast<int>(duration_cast<milliseconds>(now.time_since_epoch()).count() % 1000);
    std::tm utc{};
    gmtime_r(&seconds, &utc);
    char stamp[64];
    std::snprintf(stamp, sizeof stamp, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", utc.tm_year + 1900,
                  utc.tm_mon + 1, utc.tm_mday, utc.tm_hour, utc.tm_min, utc.tm_sec, millis);
    const std::string line =
        std::string("ts=") + stamp + " " + formatLogLine(level, event, fields) + "\n";
    if (LogSink sink = g_sink) {
        sink(line);
        return;
    }
    static std::mutex mutex;
    std::lock_guard lock(mutex);
    std::fputs(line.c_str(), stderr);
    std::fflush(stderr);
}

}  // namespace alphorn::farm
