// `alphorn cluster --workers N`: a one-machine farm. Starts an alphorn-coordinator and N
// alphorn-workers on loopback with a temporary state directory and freshly generated tokens,
// prints how to reach it, and stops them on Ctrl-C / SIGTERM. With --render SCENE -o OUT.exr it
// renders one job through that farm and exits with submit's exit code.
#include "cli/commands.h"
#include "cli/farm_client.h"
#include "cli/progress.h"

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

#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <mutex>
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

// How a child ended, from its wait status: "exited with code 1", "was killed by signal 9 (Killed)".
std::string describeExit(int status) {
    return WIFSIGNALED(status) ? absl::StrFormat("was killed by signal %d (%s)", WTERMSIG(status),
                                                 strsignal(WTERMSIG(status)))
                               : absl::StrFormat("exited with code %d", WEXITSTATUS(status));
}

// How often a daemon of the cluster is started again before it is given up.
constexpr int kMaxRestarts = 10;

// The workers of a cluster: started, watched, restarted when one dies, stopped at the end.
class WorkerPool {
  public:
    WorkerPool(std::vector<std::string> arguments, std::string root, int count)
        : m_arguments(std::move(arguments)), m_root(std::move(root)) {
        for (int i = 0; i < count; ++i) m_workers.push_back({i, start(i), 0});
    }

    // Reaps workers that exited (so none stays <defunct>), says so on stderr and starts them
    // again, unless one keeps dying (kMaxRestarts): then it is reported and left stopped.
    void restartDead() {
        std::lock_guard lock(m_mutex);
        if (m_stopping) return;
        for (Worker& worker : m_workers) {
            if (worker.pid <= 0) continue;
            int status = 0;
            if (::waitpid(worker.pid, &status, WNOHANG) != worker.pid) continue;
            const std::string how = describeExit(status);
            const std::string log = logPath(worker.index);
            if (++worker.restarts > kMaxRestarts) {
                std::cerr << absl::StrFormat(
                    "cluster: worker local-%d (pid %d) %s; it died %d times, not restarting it "
                    "(log: %s)\n",
                    worker.index, worker.pid, how, worker.restarts, log);
                worker.pid = -1;
                continue;
            }
            const pid_t previous = worker.pid;
            worker.pid = start(worker.index);
            std::cerr << absl::StrFormat(
                "cluster: worker local-%d (pid %d) %s; restarted it as pid %d (log: %s)\n",
                worker.index, previous, how, worker.pid, log);
        }
    }

    // True once every worker died too often to be started again: the farm can render nothing.
    bool allGivenUp() {
        std::lock_guard lock(m_mutex);
        for (const Worker& worker : m_workers)
            if (worker.pid > 0) return false;
        return !m_workers.empty();
    }

    void stop() {
        std::vector<pid_t> pids;
        {
            std::lock_guard lock(m_mutex);
            m_stopping = true;
            for (const Worker& worker : m_workers)
                if (worker.pid > 0) pids.push_back(worker.pid);
        }
        stopProcesses(pids);
    }

  private:
    struct Worker {
        int index;
        pid_t pid;
        int restarts;
    };
    std::string logPath(int index) const {
        return absl::StrFormat("%s/worker-%d.log", m_root, index);
    }
    pid_t start(int index) const {
        std::vector<std::string> arguments = m_arguments;
        for (const std::string& argument :
             {std::string("--cache-dir"), absl::StrFormat("%s/worker-%d", m_root, index),
              std::string("--name"), absl::StrFormat("local-%d", index)})
            arguments.push_back(argument);
        return spawn(arguments, logPath(index));
    }

    std::vector<std::string> m_arguments;
    std::string m_root;
    std::mutex m_mutex;
    std::vector<Worker> m_workers;
    bool m_stopping = false;
};

// The logs stay where the cluster said they are; the state, tokens and worker caches of a
// temporary directory go (all of it with --keep stays).
void removeAllButLogs(const std::string& root) {
    std::error_code ignored;
    for (const fs::directory_entry& entry : fs::directory_iterator(root, ignored))
        if (entry.path().extension() != ".log") fs::remove_all(entry.path(), ignored);
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

    std::unique_ptr<WorkerPool> workers;
    std::vector<std::string> coordinatorArguments = {findExecutable("alphorn-coordinator"),
                                                     "--listen",
                                                     "127.0.0.1:0",
                                                     "--state-dir",
                                                     root + "/state",
                                                     "--client-token-file",
                                                     clientToken,
                                                     "--worker-token-file",
                                                     workerToken,
                                                     "--port-file",
                                                     portFile};
    const std::string coordinatorLog = root + "/coordinator.log";
    pid_t coordinator = spawn(coordinatorArguments, coordinatorLog);  // -1 once given up
    std::atomic<bool> stopped{false};
    std::mutex shutdownMutex;
    auto shutdown = [&] {
        std::lock_guard lock(shutdownMutex);
        if (stopped.exchange(true)) return;
        if (workers) workers->stop();
        if (coordinator > 0) stopProcesses({coordinator});
        if (temporary && !options.keep) removeAllButLogs(root);
        std::cerr << "cluster: logs kept in " << root << "\n";
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
    // A coordinator that dies (the OOM killer, a stray kill) is started again on the same port
    // and state: it resumes the jobs from their checkpoints, and the workers and a waiting
    // `--render` reconnect. Before, the cluster went on "running" with no coordinator.
    coordinatorArguments[2] = address;
    int coordinatorRestarts = 0;
    auto restartCoordinator = [&] {
        std::lock_guard lock(shutdownMutex);
        int status = 0;
        if (stopped.load() || coordinator <= 0 ||
            ::waitpid(coordinator, &status, WNOHANG) != coordinator)
            return true;
        if (++coordinatorRestarts > kMaxRestarts) {
            std::cerr << absl::StrFormat(
                "cluster: error: the coordinator (pid %d) %s; it died %d times, not restarting "
                "it (log: %s); stopping the farm\n",
                coordinator, describeExit(status), coordinatorRestarts, coordinatorLog);
            coordinator = -1;
            return false;
        }
        const pid_t previous = coordinator;
        coordinator = spawn(coordinatorArguments, coordinatorLog);
        std::cerr << absl::StrFormat(
            "cluster: coordinator (pid %d) %s; restarted it as pid %d on %s (log: %s)\n", previous,
            describeExit(status), coordinator, address, coordinatorLog);
        return true;
    };
    const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    const int threads =
        options.threads > 0 ? options.threads : std::max(1, cores / options.workers);
    workers = std::make_unique<WorkerPool>(
        std::vector<std::string>{findExecutable("alphorn-worker"), "--coordinator", address,
                                 "--token-file", workerToken, "--threads", std::to_string(threads)},
        root, options.workers);
    std::cerr << absl::StrFormat(
        "cluster: coordinator on %s, %d workers x %d threads; logs in %s (kept on exit%s)\n",
        address, options.workers, threads, root,
        temporary && !options.keep ? "; the state and caches are removed, --keep keeps them" : "");
    // Restarts a worker that dies (a crash, the OOM killer, a stray kill) and says so.
    // With no worker left a job never ends and `--render` waited for ever: stop the farm, exit 1.
    std::thread watchdog([&] {
        while (!stopped.load()) {
            if (!restartCoordinator()) {
                shutdown();
                std::_Exit(kExitError);
            }
            workers->restartDead();
            if (workers->allGivenUp() && !stopped.load()) {
                std::cerr << absl::StrFormat(
                    "cluster: error: no worker is left (each one died too often to be started "
                    "again; see their logs in %s); stopping the farm\n",
                    root);
                shutdown();
                std::_Exit(kExitError);
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
        }
    });
    struct AtExit {
        std::function<void()> run;
        ~AtExit() { run(); }
    } stopAtExit{[&] {
        shutdown();
        watchdog.join();
    }};

    if (!options.submit.scene.empty()) {
        // Stop the farm if the user interrupts the render: 130 for Ctrl-C (SIGINT), 143 for
        // SIGTERM, 128 + the signal as shells report a process the signal ended.
        std::thread([&] {
            int signal = 0;
            sigwait(&signals, &signal);
            shutdown();
            std::_Exit(signal == SIGINT ? kExitInterrupted : 128 + signal);
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
    sub->add_option("--threads", options->threads, "Threads per worker (default: cores / workers)")
        ->check(CLI::Range(0, 1024));
    sub->add_option("--state-dir", options->stateDir,
                    "Keep state, tokens and logs here (default: a temporary directory)");
    sub->add_flag("--keep", options->keep, "Keep the temporary directory on exit");
    sub->add_option("--render", options->submit.scene,
                    "Render this scene through the cluster, then stop")
        ->check(CLI::ExistingFile);
    sub->add_option("-o,--output", options->submit.output,
                    "With --render: output EXR (default: out/SCENE.exr)")
        ->check(kExrOutputPath);
    auto* passes = sub->add_option("--passes,--spp", options->submit.passes,
                                   "With --render: passes (default: the scene's sampleCount)")
                       ->check(kPositiveCount);
    addTargetErrorOptions(*sub, options->submit.targetError, options->submit.maxPasses,
                          options->submit.adaptive, {passes});
    sub->add_option("--seed", options->submit.seed, "With --render: random seed")->check(kSeed);
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
