#include "coordinator/state_lock.h"

#include "common/core/error.h"

#include <absl/strings/ascii.h>
#include <absl/strings/str_format.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>

namespace alphorn::coordinator {

StateDirectoryLock::StateDirectoryLock(const std::string& directory) {
    std::filesystem::create_directories(directory);
    const std::string path = directory + "/lock";
    m_fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (m_fd < 0)
        fail("%s: cannot open the state directory's lock: %s", path, std::strerror(errno));
    if (::flock(m_fd, LOCK_EX | LOCK_NB) != 0) {
        const int error = errno;
        char holder[256] = {};
        const ssize_t n = ::pread(m_fd, holder, sizeof holder - 1, 0);
        ::close(m_fd);
        m_fd = -1;
        if (error != EWOULDBLOCK)
            fail("%s: cannot lock the state directory: %s", path, std::strerror(error));
        fail(
            "the state directory %s is in use by another coordinator (%s); stop that one first "
            "or give this one another --state-dir",
            directory,
            n > 0 ? std::string(absl::StripAsciiWhitespace(holder)) : std::string("unknown"));
    }
    // Who holds it, for the message above (informational: the flock is what excludes).
    char host[128] = {};
    ::gethostname(host, sizeof host - 1);
    const std::time_t now = std::time(nullptr);
    char started[32] = {};
    std::strftime(started, sizeof started, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const std::string text =
        absl::StrFormat("pid %d on %s, started %s\n", ::getpid(), host, started);
    if (::ftruncate(m_fd, 0) != 0 || ::pwrite(m_fd, text.data(), text.size(), 0) < 0) {
        // The lock is held all the same; only the holder's description is missing.
    }
}

StateDirectoryLock::~StateDirectoryLock() {
    if (m_fd >= 0) ::close(m_fd);
}

}  // namespace alphorn::coordinator
