// Command-line checks of numbers, shared by the CLI and the daemons. Header-only: included by the
// programs' main files, which link CLI11.
#pragma once

#include <CLI/CLI.hpp>

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <optional>
#include <string>

namespace alphorn::farm {

// Refuses NaN and the infinities. CLI::Range alone lets NaN through (every comparison with it is
// false), and a NaN lease time, checkpoint interval or reconnect wait was taken as given: leases
// that never expired, workers never shown alive, a client that waited for ever.
inline const CLI::Validator kFinite(
    [](std::string& value) -> std::string {
        double number = 0.0;
        if (!CLI::detail::lexical_cast(value, number) || !std::isfinite(number))
            return "must be a finite number, got " + value;
        return "";
    },
    "FINITE");

// The name of kDecimalSize, by which requireDecimalNumbers() knows an option that takes units.
inline const std::string kSizeValidatorName = "decimal size";

namespace detail {

// "-0017" as "-17": the text when it is an optional '-' and decimal digits, without leading
// zeros; nullopt otherwise.
inline std::optional<std::string> plainDecimal(const std::string& text) {
    const size_t sign = !text.empty() && text[0] == '-' ? 1 : 0;
    if (sign == text.size() || text.find_first_not_of("0123456789", sign) != std::string::npos)
        return std::nullopt;
    const size_t first = text.find_first_not_of('0', sign);
    if (first == std::string::npos) return std::string("0");
    return text.substr(0, sign) + text.substr(first);
}

}  // namespace detail

// Checks a memory size given to CLI::AsSizeValue: decimal digits and an optional unit. That
// reads "-1" as 2^64 - 1 bytes (a --max-memory of -1 switched the memory check off without a
// word, and "-5GB" was refused with an overflow of 18446744073709551611), and its number as
// C does: "0x10GB" was 16 GB and "010GB" 8 GB. Leading zeros are dropped, so 010GB is 10 GB.
inline const CLI::Validator kDecimalSize(
    [](std::string& value) -> std::string {
        const size_t begin = value.find_first_not_of(" \t");
        const size_t unit = value.find_first_not_of("0123456789", begin);
        const size_t end = unit == std::string::npos ? value.size() : unit;
        const std::optional<std::string> number =
            begin == std::string::npos ? std::nullopt
                                       : detail::plainDecimal(value.substr(begin, end - begin));
        const size_t rest = value.find_first_not_of(" \t", end);
        bool unitIsWord = true;
        for (size_t i = rest; i != std::string::npos && i < value.size(); ++i)
            if (!std::isalpha(static_cast<unsigned char>(value[i])) && value[i] != ' ' &&
                value[i] != '\t')
                unitIsWord = false;
        if (!number || !unitIsWord)
            return "a size is a number of bytes in decimal digits, optionally with a unit (e.g. "
                   "8GB), got " +
                   value;
        value = *number + value.substr(end);
        return "";
    },
    "",  // no word in --help: AsSizeValue describes the option
    kSizeValidatorName);

// Integer options take decimal digits only, as scene files do. CLI11 reads them with
// strtoll(text, 0): "--spp 0x10" was 16 passes, "017" octal 15, " 5" 5, and an unsigned "-1"
// 2^64 - 1. A leading '-' is read here and refused for unsigned options by the range check
// below (or by the option's own check, whose message is more specific); leading zeros are
// dropped, so "017" is 17, as in a scene file.
inline const CLI::Validator kDecimalInteger(
    [](std::string& value) -> std::string {
        const std::optional<std::string> decimal = detail::plainDecimal(value);
        if (!decimal)
            return "expected an integer in decimal digits (e.g. 16; no 0x, exponent, + or "
                   "spaces), got " +
                   value;
        value = *decimal;
        return "";
    },
    "");

// After the option's own checks: values beyond 64 bits, which CLI11 saturates without a word,
// and negative values of an unsigned option, which it wraps. Narrower types are range-checked
// by CLI11 when it converts.
inline const CLI::Validator kInt64(
    [](std::string& value) -> std::string {
        int64_t number = 0;
        const auto [end, error] =
            std::from_chars(value.data(), value.data() + value.size(), number);
        if (error != std::errc() || end != value.data() + value.size())
            return "expected an integer from -9223372036854775808 to 9223372036854775807, got " +
                   value;
        return "";
    },
    "");
inline const CLI::Validator kUint64(
    [](std::string& value) -> std::string {
        uint64_t number = 0;
        const auto [end, error] =
            std::from_chars(value.data(), value.data() + value.size(), number);
        if (!value.empty() && value[0] == '-')
            return "expected a whole number (0 or more), got " + value;
        if (error != std::errc() || end != value.data() + value.size())
            return "expected a whole number up to 18446744073709551615, got " + value;
        return "";
    },
    "");

// Floating-point options likewise take decimal notation only: an optional '-', digits with an
// optional fraction, an optional exponent ("0.25", "-1.5", "2e-3"). CLI11 reads them with
// strtold, which also took " 2", "+2" and "0x1p2" (4); "nan" and "inf" are refused as kFinite
// refuses them.
inline const CLI::Validator kDecimalFloat(
    [](std::string& value) -> std::string {
        size_t i = !value.empty() && value[0] == '-' ? 1 : 0;
        std::string word = value.substr(i);
        for (char& c : word) c = char(std::tolower(static_cast<unsigned char>(c)));
        if (word == "nan" || word == "inf" || word == "infinity")
            return "must be a finite number, got " + value;  // kFinite's words
        const auto digits = [&] {
            const size_t begin = i;
            while (i < value.size() && std::isdigit(static_cast<unsigned char>(value[i]))) ++i;
            return i - begin;
        };
        size_t mantissa = digits();
        if (i < value.size() && value[i] == '.') {
            ++i;
            mantissa += digits();
        }
        bool ok = mantissa > 0;
        if (ok && i < value.size() && (value[i] == 'e' || value[i] == 'E')) {
            ++i;
            if (i < value.size() && (value[i] == '+' || value[i] == '-')) ++i;
            ok = digits() > 0;
        }
        if (!ok || i != value.size())
            return "expected a decimal number (e.g. 0.25, -1.5 or 2e-3; no 0x, + or spaces), "
                   "got " +
                   value;
        return "";
    },
    "");

// Applies kDecimalInteger (first) and the 64-bit range check (last) to every integer option of
// the app and its subcommands, and kDecimalFloat (first) to every floating-point one, present
// and future values alike: call it once, after every option is declared. Integer options are
// those CLI11 names INT or UINT, floating-point ones FLOAT; options read with units
// (kDecimalSize) have their own check.
inline void requireDecimalNumbers(CLI::App& app) {
    for (CLI::Option* option : app.get_options()) {
        const std::string type = option->get_type_name();
        const std::string base = type.substr(0, type.find(':'));
        if (base == "FLOAT") {
            option->transform(kDecimalFloat);
            continue;
        }
        if (base != "INT" && base != "UINT") continue;
        try {
            option->get_validator(kSizeValidatorName);
            continue;
        } catch (const CLI::OptionNotFound&) {
        }
        option->transform(kDecimalInteger);
        option->check(base == "INT" ? kInt64 : kUint64);
    }
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; }))
        requireDecimalNumbers(*sub);
}

}  // namespace alphorn::farm
