// `alphorn`: render locally, run statistical test files, and drive a render farm.
#include "cli/commands.h"

#include "common/core/error.h"

#include <iostream>

int main(int argc, char** argv) {
    CLI::App app{
        "Alphorn: a physically based renderer for fog, stage light and caustics, and a render farm "
        "that gives the same bytes on one machine or many. Scenes use the Nori XML format."};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("alphorn ") + ALPHORN_VERSION);

    std::vector<alphorn::cli::Command> commands;
    commands.push_back(alphorn::cli::addRenderCommand(app));
    commands.push_back(alphorn::cli::addSubmitCommand(app));
    commands.push_back(alphorn::cli::addWatchCommand(app));
    commands.push_back(alphorn::cli::addStatusCommand(app));
    commands.push_back(alphorn::cli::addCancelCommand(app));
    commands.push_back(alphorn::cli::addFetchCommand(app));
    commands.push_back(alphorn::cli::addWorkersCommand(app));
    commands.push_back(alphorn::cli::addClusterCommand(app));
    commands.push_back(alphorn::cli::addTestCommand(app));

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0; every usage error exits 1, as documented.
        return app.exit(e) == 0 ? 0 : 1;
    }
    try {
        for (auto& [sub, run] : commands)
            if (sub->parsed()) return run();
    } catch (const alphorn::Error& e) {
        std::cerr << "error: " << e.what() << "\n";
        return 1;
    } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        return 1;
    }
    return 2;
}
