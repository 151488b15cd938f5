// Structured log lines on stderr, the one format of both farm daemons: "ts=2026-11-22T06:40:01.123Z
// level=info event=unit.merged job=3 unit=17 worker=2". One line per event, key=value, so the
// lines can be grepped by people and parsed by log collectors alike.
//
// Values often hold text from users (job and worker names, scene warnings naming properties and
// files, error messages quoting them), so the formatter alone decides how a value is written and
// no caller can forget: a value of printable ASCII without space, '"', '=' or '\' stays bare;
// every other value is quoted, with '"' and '\' escaped, newline, CR and tab as \n, \r and \t, and
// every other control character, DEL, a byte that is not part of valid UTF-8, and the Unicode
// characters that move or break lines or reorder text on screen (C1 controls, U+2028, U+2029,
// the bidirectional overrides and isolates) as \xNN per byte. A value is cut to
// kMaxLogValueBytes of written text, ending in a marker "...[N bytes cut]" that counts the
// original bytes left out. Events, keys and levels are names: a byte other than a letter, digit,
// '.', '_' or '-' becomes '_', and they are cut to kMaxLogNameBytes. So a line is always exactly
// one event, and no line is longer than its fields' names plus kMaxLogValueBytes and the marker
// per value.
#pragma once

#include <cstddef>
#include <initializer_list>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>

namespace alphorn::farm {

using LogField = std::pair<std::string, std::string>;

// The most bytes of one value's written text (escapes included, quotes and cut marker not).
inline constexpr size_t kMaxLogValueBytes = 1024;
// The most bytes of an event name, key or level.
inline constexpr size_t kMaxLogNameBytes = 64;

// Where log lines go: a function that takes each finished line (stderr when none is set).
// The coordinator's simulation collects them per seed and prints them only for a failing one.
using LogSink = void (*)(const std::string& line);
void setLogSink(LogSink sink);

// The line logEvent() writes, without its timestamp field (for tests of the format).
std::string formatLogLine(const char* level, const std::string& event,
                          std::initializer_list<LogField> fields);
// One value as formatLogLine() writes it: bare, or quoted, escaped and cut as said above.
std::string formatLogValue(std::string_view value);

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

// For the daemons, at the start of main(): what would otherwise reach stderr as free text goes
// through logEvent() too. Warnings (alphorn::warn(): a scene's unused property, a scene without
// an emitter, a token file others can read) become `event=warning message=...` lines, gRPC's and
// protobuf's own messages `event=grpc.log` and `event=protobuf.log` lines.
void routeLibraryOutputToLog();

template <typename T>
LogField field(const std::string& key, const T& value) {
    if constexpr (std::is_convertible_v<T, std::string>)
        return {key, std::string(value)};
    else
        return {key, std::to_string(value)};
}

}  // namespace alphorn::farm
