// `alphorn test FILE.xml...`: runs Nori-format statistical test files (<test type="ttest"> and
// <test type="chi2test">) and prints every test case with its statistics. The exit code is 0
// only when every case of every file passes.
#include "cli/commands.h"

#include "common/scene/parser.h"
#include "common/stats/test_object.h"

#include <absl/strings/str_format.h>
#include <tbb/global_control.h>

#include <chrono>
#include <iostream>

namespace alphorn::cli {

namespace {
struct TestOptions {
    std::vector<std::string> files;
    int threads = 0;
};

// Returns true when every case in the file passed; prints why not otherwise.
bool runFile(const std::string& file) {
    std::cout << "== " << file << "\n";
    const auto start = std::chrono::steady_clock::now();
    std::shared_ptr<Object> root;
    try {
        root = parseSceneFile(file).root;
    } catch (const Error& e) {
        std::cerr << "error: " << e.what() << "\n";
        return false;
    }
    auto* test = dynamic_cast<StatisticalTest*>(root.get());
    if (!test) {
        std::cerr << absl::StrFormat("error: %s: the root element is <%s>, not a <test>\n", file,
                                     kindTag(root->kind()));
        return false;
    }
    StatisticalTest::Summary summary;
    try {
        summary = test->run(std::cout);
    } catch (const Error& e) {
        std::cerr << "error: " << e.what() << "\n";
        return false;
    }
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (summary.total == 0) {
        std::cout << absl::StrFormat("FAILED %s: the file contains no test cases\n", file);
        return false;
    }
    std::cout << absl::StrFormat("%s %s: %d/%d passed (%.1f s)\n",
                                 summary.allPassed() ? "PASSED" : "FAILED", file, summary.passed,
                                 summary.total, seconds);
    return summary.allPassed();
}

int runTests(const TestOptions& options) {
    std::unique_ptr<tbb::global_control> threadLimit;
    if (options.threads > 0)
        threadLimit = std::make_unique<tbb::global_control>(
            tbb::global_control::max_allowed_parallelism, options.threads);
    std::vector<std::string> failed;
    for (const std::string& file : options.files)
        if (!runFile(file)) failed.push_back(file);
    std::cout.flush();
    if (failed.empty()) {
        std::cerr << absl::StrFormat("all %d test files passed\n", options.files.size());
        return 0;
    }
    std::cerr << absl::StrFormat("error: %d of %d test files failed:\n", failed.size(),
                                 options.files.size());
    for (const std::string& file : failed) std::cerr << "  " << file << "\n";
    return 1;
}
}  // namespace

Command addTestCommand(CLI::App& app) {
    auto options = std::make_shared<TestOptions>();
    CLI::App* sub = app.add_subcommand(
        "test", "Run Nori-format statistical test files (ttest, chi2test); exit 0 if all pass.");
    // No ExistingFile check: a missing file is reported by the parser and counted as a failure,
    // so the other files still run.
    sub->add_option("files", options->files, "Test files (<test type=\"ttest\"> or \"chi2test\")")
        ->required();
    sub->add_option("--threads", options->threads,
                    "Worker threads (default: all cores); the "
                    "results do not depend on it")
        ->check(CLI::Range(0, 1024));
    return {sub, [options] { return runTests(*options); }};
}

}  // namespace alphorn::cli
