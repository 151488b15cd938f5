// Command-line checks of numbers, shared by the CLI and the daemons. Header-only: included by the
// programs' main files, which link CLI11.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
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

// Checks a memory size given to CLI::AsSizeValue, which reads "-1" as 2^64 - 1 bytes: a
// --max-memory of -1 switched the memory check off without a word (a render then tried to
// allocate a 32 GiB film), and "-5GB" was refused with an overflow of 18446744073709551611.
inline const CLI::Validator kNotNegativeSize(
    [](std::string& value) -> std::string {
        const size_t first = value.find_first_not_of(" \t");
        if (first != std::string::npos && value[first] == '-')
            return "a size is a number of bytes, optionally with a unit (e.g. 8GB), got " + value;
        return "";
    },
    "");  // no word in --help: AsSizeValue describes the option

}  // namespace alphorn::farm
