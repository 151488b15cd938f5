#include "common/farm/directory_lock.h"

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

namespace alphorn::farm {

namespace {

// Who holds the directory, as its lock file says; for the refusal's message.
std::string describeHolder(const std::string& lockPath) {
    const int fd = ::open(lockPath.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) return absl::StrFormat("its lock file %s, which names it, was removed", lockPath);
    char holder[256] = {};
    const ssize_t n = ::pread(fd, holder, sizeof holder - 1, 0);
    ::close(fd);
    return n > 0 ? std::string(absl::StripAsciiWhitespace(holder)) : std::string("unknown");
}

[[noreturn]] void refuseInUse(const std::string& directory, const std::string& lockPath,
                              const DirectoryLockRole& role) {
    fail("the %s %s is in use by another %s (%s); stop that one first or give this one another %s",
         role.directoryKind, directory, role.daemon, describeHolder(lockPath), role.option);
}

}  // namespace

DirectoryLock::DirectoryLock(const std::string& directory, DirectoryLockRole role) {
    std::filesystem::create_directories(directory);
    const std::string path = directory + "/lock";
    m_directoryFd = ::open(directory.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (m_directoryFd < 0)
        fail("%s: cannot open the %s to lock it: %s", directory, role.directoryKind,
             std::strerror(errno));
    if (::flock(m_directoryFd, LOCK_EX | LOCK_NB) != 0) {
        const int error = errno;
        ::close(m_directoryFd);
        m_directoryFd = -1;
        if (error != EWOULDBLOCK)
            fail("%s: cannot lock the %s: %s", directory, role.directoryKind, std::strerror(error));
        refuseInUse(directory, path, role);
    }
    // The directory is ours; a coordinator of an earlier version locks only the file.
    m_fileFd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (m_fileFd < 0) {
        const int error = errno;
        ::close(m_directoryFd);
        fail("%s: cannot open the %s's lock: %s", path, role.directoryKind, std::strerror(error));
    }
    if (::flock(m_fileFd, LOCK_EX | LOCK_NB) != 0) {
        const int error = errno;
        ::close(m_fileFd);
        ::close(m_directoryFd);
        if (error != EWOULDBLOCK)
            fail("%s: cannot lock the %s: %s", path, role.directoryKind, std::strerror(error));
        refuseInUse(directory, path, role);
    }
    // Who holds it, for the message above (informational: the flocks are what exclude).
    char host[128] = {};
    ::gethostname(host, sizeof host - 1);
    const std::time_t now = std::time(nullptr);
    char started[32] = {};
    std::strftime(started, sizeof started, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
    const std::string text =
        absl::StrFormat("pid %d on %s, started %s\n", ::getpid(), host, started);
    if (::ftruncate(m_fileFd, 0) != 0 || ::pwrite(m_fileFd, text.data(), text.size(), 0) < 0) {
        // The lock is held all the same; only the holder's description is missing.
    }
}

DirectoryLock::~DirectoryLock() {
    if (m_fileFd >= 0) ::close(m_fileFd);
    if (m_directoryFd >= 0) ::close(m_directoryFd);
}

}  // namespace alphorn::farm
