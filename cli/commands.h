// The `alphorn` subcommands. Each add*Command() declares its subcommand and options on the app
// and returns the function that runs it, giving the process exit code.
#pragma once

#include "common/farm/number_options.h"

#include <CLI/CLI.hpp>

#include <charconv>

#include <functional>
#include <utility>

namespace alphorn::cli {

using Command = std::pair<CLI::App*, std::function<int()>>;

// Checks an -o path: it names the EXR, and the PNG is written beside it with the same stem, so
// it must end in ".exr" (an "x.png" would have the PNG written over the EXR).
inline const CLI::Validator kExrOutputPath(
    [](std::string& path) -> std::string {
        const std::string extension = ".exr";
        if (path.size() > extension.size() &&
            CLI::detail::to_lower(path.substr(path.size() - extension.size())) == extension)
            return "";
        return "-o names the EXR file (a PNG is written beside it): \"" + path +
               "\" does not end in .exr";
    },
    "PATH.exr");

// Checks a count such as --passes: 0 is refused rather than read as "the default".
inline const CLI::Validator kPositiveCount(
    [](std::string& value) -> std::string {
        return value.find_first_not_of("0") == std::string::npos
                   ? "must be at least 1, got " + value
                   : "";
    },
    "N>=1");

// Checks a seed: a decimal integer from 0 to 2^64 - 1 (CLI11 alone wraps "-1" and saturates
// values beyond 2^64 - 1, so several spellings would give one image).
inline const CLI::Validator kSeed(
    [](std::string& value) -> std::string {
        uint64_t seed = 0;
        const auto [end, error] = std::from_chars(value.data(), value.data() + value.size(), seed);
        if (value.empty() || error != std::errc() || end != value.data() + value.size())
            return "a seed is an integer from 0 to 18446744073709551615, got " + value;
        return "";
    },
    "SEED");

// Checks a real number: NaN and infinities are refused.
using farm::kFinite;

Command addRenderCommand(CLI::App& app);
// The render farm client (cli/farm_commands.cpp) and the one-machine farm
// (cli/cluster_command.cpp).
Command addSubmitCommand(CLI::App& app);
Command addWatchCommand(CLI::App& app);
Command addStatusCommand(CLI::App& app);
Command addCancelCommand(CLI::App& app);
Command addFetchCommand(CLI::App& app);
Command addWorkersCommand(CLI::App& app);
Command addClusterCommand(CLI::App& app);
// Statistical test files (cli/test_command.cpp).
Command addTestCommand(CLI::App& app);

}  // namespace alphorn::cli
