// The `alphorn` subcommands. Each add*Command() declares its subcommand and options on the app
// and returns the function that runs it, giving the process exit code.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <utility>

namespace alphorn::cli {

using Command = std::pair<CLI::App*, std::function<int()>>;

Command addRenderCommand(CLI::App& app);

}  // namespace alphorn::cli
