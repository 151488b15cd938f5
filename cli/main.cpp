// `alphorn`: render locally, run statistical test files, and drive a render farm.
#include "cli/commands.h"
#include "cli/farm_client.h"

#include "common/core/error.h"
#include "common/core/properties.h"
#include "common/farm/engine_fingerprint.h"

#include <iostream>

namespace {

// "did you mean" hints for a command line CLI11 refused: a misspelt subcommand, or options the
// chosen subcommand does not have. Empty when nothing looks misspelt.
std::string suggestionsFor(CLI::App& app, int argc, char** argv) {
    if (argc < 2) return "";
    const std::string first = argv[1];
    std::vector<std::string> subcommandNames;
    CLI::App* subcommand = nullptr;
    for (CLI::App* sub : app.get_subcommands([](CLI::App*) { return true; })) {
        subcommandNames.push_back(sub->get_name());
        if (sub->get_name() == first) subcommand = sub;
    }
    if (first.empty() || first[0] == '-') return "";
    if (!subcommand) {
        const std::string intended = alphorn::closestName(first, subcommandNames);
        return intended.empty() ? absl::StrFormat("\"%s\" is not an alphorn command\n", first)
                                : absl::StrFormat(
                                      "\"%s\" is not an alphorn command; did you "
                                      "mean \"%s\"?\n",
                                      first, intended);
    }
    std::vector<std::string> optionNames;
    for (const CLI::Option* option : subcommand->get_options())
        for (const std::string& name : option->get_lnames()) optionNames.push_back("--" + name);
    std::string hints;
    for (int i = 2; i < argc; ++i) {
        std::string word = argv[i];
        if (word == "--") break;
        if (word.rfind("--", 0) != 0) continue;
        word = word.substr(0, word.find('='));
        if (std::find(optionNames.begin(), optionNames.end(), word) != optionNames.end()) continue;
        const std::string intended = alphorn::closestName(word, optionNames);
        hints += intended.empty()
                     ? absl::StrFormat("alphorn %s has no option %s\n", first, word)
                     : absl::StrFormat("alphorn %s has no option %s; did you mean %s?\n", first,
                                       word, intended);
    }
    return hints;
}

}  // namespace

int main(int argc, char** argv) {
    using namespace alphorn::cli;
    CLI::App app{
        "Alphorn: a physically based renderer for fog, stage light and caustics, and a render farm "
        "that gives the same bytes on one machine or many. Scenes are Nori XML files, or pbrt-v4 "
        "files (.pbrt)."};
    app.require_subcommand(1);
    app.set_version_flag("--version", std::string("alphorn ") + ALPHORN_VERSION + " (engine " +
                                          alphorn::farm::engineFingerprint() + ")");

    std::vector<Command> commands;
    commands.push_back(addRenderCommand(app));
    commands.push_back(addSubmitCommand(app));
    commands.push_back(addWatchCommand(app));
    commands.push_back(addStatusCommand(app));
    commands.push_back(addCancelCommand(app));
    commands.push_back(addFetchCommand(app));
    commands.push_back(addWorkersCommand(app));
    for (Command& command : addControlCommands(app)) commands.push_back(std::move(command));
    commands.push_back(addClusterCommand(app));
    commands.push_back(addTestCommand(app));
    alphorn::farm::requireDecimalNumbers(app);

    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        // --help and --version exit 0. CLI11's own codes (105 to 114 by error class) are not
        // part of Alphorn's contract: every usage error exits 1, as documented.
        const std::string hints = suggestionsFor(app, argc, argv);
        if (e.get_exit_code() != 0 &&
            hints.find("is not an alphorn command") != std::string::npos) {
            // CLI11 would say "A subcommand is required": the misspelt one is the news.
            std::cerr << "error: " << hints << "Run with --help for the list of commands.\n";
            return kExitError;
        }
        if (app.exit(e) == 0) return kExitOk;
        std::cerr << hints;
        return kExitError;
    }
    try {
        for (auto& [sub, run] : commands)
            if (sub->parsed()) return run();
    } catch (const std::exception& e) {
        std::cerr << "error: " << e.what() << "\n";
        return kExitError;
    }
    return kExitError;
}
