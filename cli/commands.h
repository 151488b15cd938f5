// The `alphorn` subcommands. Each add*Command() declares its subcommand and options on the app
// and returns the function that runs it, giving the process exit code.
#pragma once

#include <CLI/CLI.hpp>

#include <functional>
#include <utility>

namespace alphorn::cli {

using Command = std::pair<CLI::App*, std::function<int()>>;

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
Command addTestCommand(CLI::App& app);

}  // namespace alphorn::cli
