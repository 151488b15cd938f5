// The log formatter against text that tries to break out of its value: newlines that would
// start a forged event, other control characters, invalid UTF-8, characters that break lines or
// reorder text on screen, huge values, and names that are not names.
#include "common/farm/log.h"
#include "common/core/warning.h"

#include <google/protobuf/stubs/logging.h>
#include <grpc/grpc.h>
#include <grpc/support/log.h>
#include <gtest/gtest.h>

#include <map>
#include <optional>
#include <string>
#include <vector>

namespace alphorn::farm {
namespace {

// The fields of a line as a log collector reads it (key=value, values bare or quoted with the
// formatter's escapes), or nothing when the line does not parse.
std::optional<std::vector<std::pair<std::string, std::string>>> parseLine(const std::string& line) {
    std::vector<std::pair<std::string, std::string>> fields;
    size_t i = 0;
    while (i < line.size()) {
        if (!fields.empty()) {
            if (line[i] != ' ') return std::nullopt;
            ++i;
        }
        const size_t equals = line.find('=', i);
        if (equals == std::string::npos || equals == i) return std::nullopt;
        const std::string key = line.substr(i, equals - i);
        for (const char c : key)
            if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-'))
                return std::nullopt;
        i = equals + 1;
        std::string value;
        if (i < line.size() && line[i] == '"') {
            for (++i;; ++i) {
                if (i >= line.size()) return std::nullopt;
                const char c = line[i];
                if (c == '"') break;
                if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) return std::nullopt;
                if (c != '\\') {
                    value += c;
                    continue;
                }
                if (++i >= line.size()) return std::nullopt;
                const char escaped = line[i];
                if (escaped == 'x') {
                    if (i + 2 >= line.size()) return std::nullopt;
                    value += static_cast<char>(std::stoi(line.substr(i + 1, 2), nullptr, 16));
                    i += 2;
                } else if (escaped == 'n' || escaped == 'r' || escaped == 't') {
                    value += escaped == 'n' ? '\n' : escaped == 'r' ? '\r' : '\t';
                } else if (escaped == '"' || escaped == '\\') {
                    value += escaped;
                } else {
                    return std::nullopt;
                }
            }
            ++i;
        } else {
            const size_t end = line.find(' ', i);
            value = line.substr(i, end == std::string::npos ? std::string::npos : end - i);
            if (value.empty() || value.find_first_of("\"=\\") != std::string::npos)
                return std::nullopt;
            i += value.size();
        }
        fields.emplace_back(key, value);
    }
    return fields;
}

// The value of `key` in a line that must parse, and hold `event=` exactly once.
std::string valueIn(const std::string& line, const std::string& key) {
    const auto fields = parseLine(line);
    EXPECT_TRUE(fields) << line;
    if (!fields) return "";
    int events = 0;
    std::string value;
    for (const auto& [k, v] : *fields) {
        events += k == "event";
        if (k == key) value = v;
    }
    EXPECT_EQ(events, 1) << line;
    return value;
}

const std::string kForged =
    "x\nts=2026-01-01T00:00:00.000Z level=info event=job.ended job=1 state=done";

TEST(Log, AForgedLineStaysInsideItsValue) {
    const std::string line = formatLogLine("warn", "job.refused", {field("name", kForged)});
    EXPECT_EQ(line.find('\n'), std::string::npos) << line;
    EXPECT_EQ(valueIn(line, "name"), kForged);
    EXPECT_EQ(valueIn(line, "event"), "job.refused");
}

TEST(Log, ControlCharactersAreEscaped) {
    EXPECT_EQ(formatLogValue("a\nb\rc\td"), "\"a\\nb\\rc\\td\"");
    EXPECT_EQ(formatLogValue(std::string("nul\0bell\a esc\x1b[2J del\x7f", 22)),
              "\"nul\\x00bell\\x07 esc\\x1b[2J del\\x7f\"");
    EXPECT_EQ(formatLogValue("quote\" backslash\\"), "\"quote\\\" backslash\\\\\"");
    EXPECT_EQ(formatLogValue("a=b"), "\"a=b\"");
    EXPECT_EQ(formatLogValue(""), "\"\"");
}

TEST(Log, PlainValuesStayBare) {
    EXPECT_EQ(formatLogValue("3"), "3");
    EXPECT_EQ(formatLogValue("/var/lib/alphorn:7700"), "/var/lib/alphorn:7700");
    EXPECT_EQ(formatLogValue("unit.merged"), "unit.merged");
}

TEST(Log, ValidUtf8IsKeptAndInvalidBytesAreEscaped) {
    EXPECT_EQ(formatLogValue("漢字 café 🎬"), "\"漢字 café 🎬\"");
    // A stray continuation byte, a lead byte without its continuation, an overlong '/', a
    // surrogate, a code point past U+10FFFF.
    EXPECT_EQ(formatLogValue("\x80|\xc3|\xc0\xaf|\xed\xa0\x80|\xf4\x90\x80\x80"),
              "\"\\x80|\\xc3|\\xc0\\xaf|\\xed\\xa0\\x80|\\xf4\\x90\\x80\\x80\"");
}

TEST(Log, CharactersThatBreakLinesOrReorderTextAreEscaped) {
    EXPECT_EQ(formatLogValue("a\u2028b\u2029c"), "\"a\\xe2\\x80\\xa8b\\xe2\\x80\\xa9c\"");
    EXPECT_EQ(formatLogValue("next\u0085line"), "\"next\\xc2\\x85line\"");
    EXPECT_EQ(formatLogValue("txt.\u202egnp"), "\"txt.\\xe2\\x80\\xaegnp\"");
    EXPECT_EQ(formatLogValue("\u2066isolate\u2069"), "\"\\xe2\\x81\\xa6isolate\\xe2\\x81\\xa9\"");
}

TEST(Log, LongValuesAreCutWithTheCountOfBytesLeftOut) {
    const std::string huge(5 << 20, 'a');
    const std::string written = formatLogValue(huge);
    EXPECT_EQ(written, "\"" + std::string(kMaxLogValueBytes, 'a') + "...[" +
                           std::to_string(huge.size() - kMaxLogValueBytes) + " bytes cut]\"");
    EXPECT_EQ(formatLogValue(std::string(kMaxLogValueBytes, 'a')),
              std::string(kMaxLogValueBytes, 'a'));

    // Neither a character nor an escape is split: 341 whole three-byte characters fit in 1024
    // bytes, and 256 whole four-byte escapes.
    std::string wide;
    for (int i = 0; i < 1000; ++i) wide += "漢";
    std::string kept;
    for (int i = 0; i < 341; ++i) kept += "漢";
    EXPECT_EQ(formatLogValue(wide), "\"" + kept + "...[1977 bytes cut]\"");
    std::string escapes;
    for (int i = 0; i < 256; ++i) escapes += "\\x01";
    EXPECT_EQ(formatLogValue(std::string(300, '\x01')), "\"" + escapes + "...[44 bytes cut]\"");
}

TEST(Log, EventNamesKeysAndLevelsAreNames) {
    EXPECT_EQ(formatLogLine("in fo", "job.sent again\nts=1", {{"bad key=", "v"}, {"", "w"}}),
              "level=in_fo event=job.sent_again_ts_1 bad_key_=v _=w");
    const std::string longName(500, 'k');
    const std::string line = formatLogLine("info", longName, {{longName, "v"}});
    EXPECT_EQ(line, "level=info event=" + std::string(kMaxLogNameBytes, 'k') + " " +
                        std::string(kMaxLogNameBytes, 'k') + "=v");
}

std::vector<std::string> g_lines;
void collect(const std::string& line) {
    g_lines.push_back(line);
}

TEST(Log, WarningsAndLibraryMessagesBecomeEventsInADaemon) {
    g_lines.clear();
    google::protobuf::LogHandler* const protobufDefault = google::protobuf::SetLogHandler(nullptr);
    setLogSink(collect);
    routeLibraryOutputToLog();
    warn("scene.xml:3: property \"%s\" of <integrator type=\"path\"> is not used", kForged);
    grpc_init();  // which sets the severity gRPC logs from (errors), as any channel does
    gpr_log(__FILE__, __LINE__, GPR_LOG_SEVERITY_ERROR, "grpc says %s", "x\ny");
    grpc_shutdown();
    GOOGLE_LOG(ERROR) << "protobuf says\nz";
    // gRPC has no public way back to its own logger; its messages stay events, on stderr.
    setWarningSink(nullptr);
    google::protobuf::SetLogHandler(protobufDefault);
    setLogSink(nullptr);

    std::string all;
    for (const std::string& line : g_lines) all += line;
    ASSERT_EQ(g_lines.size(), 3u) << all;
    for (const std::string& line : g_lines) {
        ASSERT_EQ(line.back(), '\n');
        EXPECT_EQ(line.find('\n'), line.size() - 1) << line;
        EXPECT_EQ(line.rfind("ts=", 0), 0u) << line;
    }
    const std::string warning = g_lines[0].substr(0, g_lines[0].size() - 1);
    EXPECT_EQ(valueIn(warning, "event"), "warning");
    EXPECT_EQ(valueIn(warning, "level"), "warn");
    EXPECT_EQ(valueIn(warning, "message"), "scene.xml:3: property \"" + kForged +
                                               "\" of <integrator type=\"path\"> is not used");
    const std::string grpcLine = g_lines[1].substr(0, g_lines[1].size() - 1);
    EXPECT_EQ(valueIn(grpcLine, "event"), "grpc.log");
    EXPECT_EQ(valueIn(grpcLine, "message"), "grpc says x\ny");
    const std::string protobufLine = g_lines[2].substr(0, g_lines[2].size() - 1);
    EXPECT_EQ(valueIn(protobufLine, "event"), "protobuf.log");
    EXPECT_EQ(valueIn(protobufLine, "message"), "protobuf says\nz");
}

}  // namespace
}  // namespace alphorn::farm
