// Structured log lines on stderr, the one format of both farm daemons: "ts=2026-11-22T06:40:01.123Z
// level=info event=unit.merged job=3 unit=17 worker=2". One line per event, key=value, values
// with spaces quoted, so the lines can be grepped by people and parsed by log collectors alike.
#pragma once

#include <initializer_list>
#include <string>
#include <type_traits>
#include <utility>

namespace alphorn::farm {

using LogField = std::pair<std::string, std::string>;

// Where log lines go: a function that takes each finished line (stderr when none is set).
// The coordinator's simulation collects them per seed and prints them only for a failing one.
using LogSink = void (*)(const std::string& line);
void setLogSink(LogSink sink);

// The line logEvent() writes, without its timestamp field (for tests of the format).
std::string formatLogLine(const char* level, const std::string& event,
                          std::initializer_list<LogField> fields);

void logEvent(const char* level, const std::string& event, std::initializer_list<LogField> fields);
inline void logInfo(const std::string& event, std::initializer_list<LogField> fields = {}) {
    logEvent("info", event, fields);
}
inline void logWarning(const std::string& event, std::initializer_list<LogField> fields = {}) {
    logEvent("warn", event, fields);
}
inline void logError(const std::string& event, std::initializer_list<LogField> fields = {}) {
    logEvent("error", event, fields);
}

template <typename T>
LogField field(const std::string& key, const T& value) {
    if constexpr (std::is_convertible_v<T, std::string>)
        return {key, std::string(value)};
    else
        return {key, std::to_string(value)};
}

}  // namespace alphorn::farm
