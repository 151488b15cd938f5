// A command-line check that refuses NaN and the infinities. CLI::Range alone lets NaN through
// (every comparison with it is false), and a NaN lease time, checkpoint interval or reconnect
// wait was taken as given: leases that never expired, workers never shown alive, a client that
// waited for ever. Header-only: included by the programs' main files, which link CLI11.
#pragma once

#include <CLI/CLI.hpp>

#include <cmath>
#include <string>

namespace alphorn::farm {

inline const CLI::Validator kFinite(
    [](std::string& value) -> std::string {
        double number = 0.0;
        if (!CLI::detail::lexical_cast(value, number) || !std::isfinite(number))
            return "must be a finite number, got " + value;
        return "";
    },
    "FINITE");

}  // namespace alphorn::farm
