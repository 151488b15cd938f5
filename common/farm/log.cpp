#include "common/farm/log.h"

#include "common/core/warning.h"
#include "common/farm/utf8_text.h"

#include <google/protobuf/stubs/logging.h>
#include <grpc/support/log.h>

#include <absl/strings/str_format.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>

namespace alphorn::farm {

namespace {

// A byte a bare value may hold: printable ASCII that does not end or quote a value.
bool bareByte(unsigned char byte) {
    return byte > 0x20 && byte < 0x7f && byte != '"' && byte != '=' && byte != '\\';
}

// Characters that are valid UTF-8 but break a line or change how the text around them looks:
// the C1 controls (U+0085 is a line break to some readers), the line and paragraph separators,
// and the marks, overrides and isolates of bidirectional text (which can make a shown line read
// differently from its bytes).
bool invisibleOrLineBreaking(char32_t c) {
    return (c >= 0x80 && c <= 0x9f) || c == 0x061c || c == 0x200e || c == 0x200f ||
           (c >= 0x2028 && c <= 0x202e) || (c >= 0x2066 && c <= 0x2069);
}

void appendHexEscapes(std::string& out, std::string_view bytes) {
    for (const char byte : bytes)
        out += absl::StrFormat("\\x%02x", static_cast<unsigned char>(byte));
}

// The written form of one character of a quoted value.
std::string escapedCharacter(std::string_view text, const Utf8Character& character) {
    const std::string_view bytes = text.substr(0, character.bytes);
    std::string out;
    if (!character.valid || invisibleOrLineBreaking(character.codePoint)) {
        appendHexEscapes(out, bytes);
        return out;
    }
    switch (character.codePoint) {
        case '"':
            return "\\\"";
        case '\\':
            return "\\\\";
        case '\n':
            return "\\n";
        case '\r':
            return "\\r";
        case '\t':
            return "\\t";
        default:
            break;
    }
    if (character.codePoint < 0x20 || character.codePoint == 0x7f)
        appendHexEscapes(out, bytes);
    else
        out = bytes;
    return out;
}

// An event name, key or level: letters, digits, '.', '_' and '-', at most kMaxLogNameBytes.
std::string logName(std::string_view name) {
    std::string out(name.substr(0, kMaxLogNameBytes));
    for (char& c : out) {
        const unsigned char byte = static_cast<unsigned char>(c);
        const bool allowed = (byte >= 'a' && byte <= 'z') || (byte >= 'A' && byte <= 'Z') ||
                             (byte >= '0' && byte <= '9') || c == '.' || c == '_' || c == '-';
        if (!allowed) c = '_';
    }
    return out.empty() ? "_" : out;
}

const char* levelOf(gpr_log_severity severity) {
    switch (severity) {
        case GPR_LOG_SEVERITY_DEBUG:
            return "debug";
        case GPR_LOG_SEVERITY_INFO:
            return "info";
        case GPR_LOG_SEVERITY_ERROR:
            return "error";
    }
    return "info";
}

const char* levelOf(google::protobuf::LogLevel level) {
    switch (level) {
        case google::protobuf::LOGLEVEL_INFO:
            return "info";
        case google::protobuf::LOGLEVEL_WARNING:
            return "warn";
        default:
            return "error";
    }
}

}  // namespace

std::string formatLogValue(std::string_view value) {
    bool bare = !value.empty() && value.size() <= kMaxLogValueBytes;
    for (size_t i = 0; bare && i < value.size(); ++i)
        bare = bareByte(static_cast<unsigned char>(value[i]));
    if (bare) return std::string(value);
    std::string quoted = "\"";
    for (size_t offset = 0; offset < value.size();) {
        const Utf8Character character = decodeUtf8(value, offset);
        const std::string written = escapedCharacter(value.substr(offset), character);
        if (quoted.size() - 1 + written.size() > kMaxLogValueBytes) {
            quoted += absl::StrFormat("...[%u bytes cut]", value.size() - offset);
            break;
        }
        quoted += written;
        offset += character.bytes;
    }
    return quoted + "\"";
}

static std::atomic<LogSink> g_sink{nullptr};

void setLogSink(LogSink sink) {
    g_sink = sink;
}

std::string formatLogLine(const char* level, const std::string& event,
                          std::initializer_list<LogField> fields) {
    std::string line = "level=" + logName(level) + " event=" + logName(event);
    for (const auto& [key, value] : fields)
        line += " " + logName(key) + "=" + formatLogValue(value);
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

void routeLibraryOutputToLog() {
    setWarningSink(
        [](const std::string& message) { logWarning("warning", {field("message", message)}); });
    gpr_set_log_function([](gpr_log_func_args* args) {
        logEvent(levelOf(args->severity), "grpc.log",
                 {field("file", args->file ? args->file : ""), field("line", args->line),
                  field("message", args->message ? args->message : "")});
    });
    google::protobuf::SetLogHandler([](google::protobuf::LogLevel level, const char* file, int line,
                                       const std::string& message) {
        logEvent(levelOf(level), "protobuf.log",
                 {field("file", file ? file : ""), field("line", line), field("message", message)});
    });
}

}  // namespace alphorn::farm
