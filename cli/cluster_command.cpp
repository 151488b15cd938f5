// `alphorn cluster --workers N`: a one-machine farm. Starts an alphorn-coordinator and N
// alphorn-workers on loopback with a temporary state directory and freshly generated tokens,
// prints how to reach it, and stops them on Ctrl-C / SIGTERM. With --render SCENE -o OUT.exr it
// renders one job through that farm and exits with submit's exit code.
#include "cli/commands.h"
#include "cli/farm_client.h"

#include "common/core/error.h"
#include "common/farm/files.h"
#include "common/farm/rpc.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_format.h>
#include <absl/strings/str_split.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <thread>

namespace alphorn::cli {

namespace fs = std::filesystem;

namespace {

struct ClusterOptions {
    int workers = 2;
    int threads = 0;
    std::string stateDir;
    bool keep = false;
    SubmitOptions submit;
    bool json = false;
};

// The daemons are installed beside `alphorn`; in a build tree they sit in sibling folders.
std::string findExecutable(const std::string& name) {
    const fs::path self = fs::read_symlink("/proc/self/exe").parent_path();
    for (const fs::path& candidate : {self / name, self.parent_path() / "coordinator" / name,
                                      self.parent_path() / "worker" / name})
        if (fs::exists(candidate)) return candidate.string();
    if (const char* path = std::getenv("PATH"))
        for (absl::string_view directory : absl::StrSplit(path, ':'))
            if (fs::exists(fs::path(std::string(directory)) / name))
                return (fs::path(std::string(directory)) / name).string();
    fail("cannot find %s next to %s or on PATH", name, self.string());
}

pid_t spawn(const std::vector<std::string>& arguments, const std::string& logPath) {
    pid_t pid = ::fork();
    if (pid < 0) fail("fork failed: %s", std::strerror(errno));
    if (pid == 0) {
        sigset_t none;
        sigemptyset(&none);
        pthread_sigmask(SIG_SETMASK, &none, nullptr);
        // Die with the cluster, even if it is killed with SIGKILL.
        ::prctl(PR_SET_PDEATHSIG, SIGTERM);
        int log = ::open(logPath.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        if (log >= 0) {
            ::dup2(log, STDERR_FILENO);
            ::dup2(log, STDOUT_FILENO);
            ::close(log);
        }
        std::vector<char*> argv;
        for (const auto& argument : arguments) argv.push_back(const_cast<char*>(argument.c_str()));
        argv.push_back(nullptr);
        ::execv(argv[0], argv.data());
        ::_exit(127);
    }
    return pid;
}

void stopProcesses(const std::vector<pid_t>& pids) {
    for (pid_t pid : pids) ::kill(pid, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(15);
    for (pid_t pid : pids) {
        while (::waitpid(pid, nullptr, WNOHANG) == 0) {
            if (std::chrono::steady_clock::now() > deadline) {
                ::kill(pid, SIGKILL);
                ::waitpid(pid, nullptr, 0);
                break;
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(20));
        }
    }
}

int runCluster(ClusterOptions options) {
    sigset_t signals;
    sigemptyset(&signals);
    sigaddset(&signals, SIGTERM);
    sigaddset(&signals, SIGINT);
    pthread_sigmask(SIG_BLOCK, &signals, nullptr);

    const bool temporary = options.stateDir.empty();
    std::string root = options.stateDir;
    if (temporary) {
        char pattern[] = "/tmp/alphorn-cluster-XXXXXX";
        if (!::mkdtemp(pattern))
            fail("cannot create a temporary directory: %s", std::strerror(errno));
        root = pattern;
    }
    fs::create_directories(root);
    const std::string clientToken = root + "/client.token", workerToken = root + "/worker.token";
    farm::writeFileAtomically(clientToken, farm::generateToken() + "\n");
    farm::writeFileAtomically(workerToken, farm::generateToken() + "\n");
    fs::permissions(clientToken, fs::perms::owner_read | fs::perms::owner_write);
    fs::permissions(workerToken, fs::perms::owner_read | fs::perms::owner_write);
    const std::string portFile = root + "/coordinator.port";
    fs::remove(portFile);

    std::vector<pid_t> workers;
    pid_t coordinator = spawn({findExecutable("alphorn-coordinator"), "--listen", "127.0.0.1:0",
                               "--state-dir", root + "/state", "--client-token-file", clientToken,
                               "--worker-token-file", workerToken, "--port-file", portFile},
                              root + "/coordinator.log");
    auto shutdown = [&] {
        stopProcesses(workers);
        stopProcesses({coordinator});
        if (temporary && !options.keep) {
            std::error_code ignored;
            fs::remove_all(root, ignored);
        }
    };
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (!fs::exists(portFile)) {
        if (::waitpid(coordinator, nullptr, WNOHANG) != 0 ||
            std::chrono::steady_clock::now() > deadline) {
            const std::string log = farm::readFile(root + "/coordinator.log");
            shutdown();
            fail("the coordinator did not start:\n%s", log);
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    const std::string address =
        "127.0.0.1:" + std::string(absl::StripAsciiWhitespace(farm::readFile(portFile)));
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    const int threads =
        options.threads > 0 ? options.threads : std::max(1, cores / options.workers);
    const std::string workerBinary = findExecutable("alphorn-worker");
    for (int i = 0; i < options.workers; ++i)
        workers.push_back(
            spawn({workerBinary, "--coordinator", address, "--token-file", workerToken,
                   "--cache-dir", absl::StrFormat("%s/worker-%d", root, i), "--threads",
                   std::to_string(threads), "--name", absl::StrFormat("local-%d", i)},
                  absl::StrFormat("%s/worker-%d.log", root, i)));
    std::cerr << absl::StrFormat(
        "cluster: coordinator on %s, %d workers x %d threads; logs in %s\n", address,
        options.workers, threads, root);

    if (!options.submit.scene.empty()) {
        // Stop the farm if the user interrupts the render.
        std::thread([&] {
            int signal = 0;
            sigwait(&signals, &signal);
            shutdown();
            std::_Exit(130);
        }).detach();
        int code = kExitError;
        try {
            FarmConnectionOptions connection;
            connection.coordinator = address;
            connection.tokenFile = clientToken;
            FarmClient client(connection);
            code = runSubmit(client, options.submit, options.json);
        } catch (const std::exception& e) {
            std::cerr << "error: " << e.what() << "\n";
        }
        shutdown();
        return code;
    }

    std::cout << "ALPHORN_COORDINATOR=" << address << "\n"
              << "ALPHORN_TOKEN_FILE=" << clientToken << "\n"
              << std::flush;
    std::cerr << "cluster: running; Ctrl-C stops it\n";
    int signal = 0;
    sigwait(&signals, &signal);
    std::cerr << "cluster: stopping\n";
    shutdown();
    return kExitOk;
}

}  // namespace

Command addClusterCommand(CLI::App& app) {
    auto options = std::make_shared<ClusterOptions>();
    CLI::App* sub = app.add_subcommand("cluster",
                                       "Run a one-machine farm (a coordinator and N workers on "
                                       "loopback); optionally render through it.");
    sub->add_option("--workers", options->workers, "Number of workers")->check(CLI::Range(1, 256));
    sub->add_option("--threads", options->threads, "Threads per worker (default: cores / workers)");
    sub->add_option("--state-dir", options->stateDir,
                    "Keep state, tokens and logs here (default: a temporary directory)");
    sub->add_flag("--keep", options->keep, "Keep the temporary directory on exit");
    sub->add_option("--render", options->submit.scene,
                    "Render this scene through the cluster, then stop")
        ->check(CLI::ExistingFile);
    sub->add_option("-o,--output", options->submit.output,
                    "With --render: output EXR (default: out/SCENE.exr)")
        ->check(kExrOutputPath);
    sub->add_option("--passes,--spp", options->submit.passes,
                    "With --render: passes (default: the scene's sampleCount)")
        ->check(kPositiveCount);
    sub->add_option("--seed", options->submit.seed, "With --render: random seed");
    sub->add_option("--tile", options->submit.tile, "With --render: tile size");
    sub->add_flag("--json", options->json, "With --render: print the final job status as JSON");
    return {sub, [options] {
                ClusterOptions run = *options;
                if (!run.submit.scene.empty() && run.submit.output.empty())
                    run.submit.output =
                        (fs::path("out") /
                         fs::path(run.submit.scene).filename().replace_extension(".exr"))
                            .string();
                return runCluster(run);
            }};
}

}  // namespace alphorn::cli
