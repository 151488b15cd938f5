#include "common/farm/files.h"

#include "common/core/error.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace alphorn::farm {

std::string readFile(const std::string& path) {
    std::ifstream file(path, std::ios::binary);
    if (!file) fail("%s: cannot open: %s", path, std::strerror(errno));
    std::ostringstream buffer;
    buffer << file.rdbuf();
    if (file.bad()) fail("%s: read error", path);
    return buffer.str();
}

static void fsyncDirectory(const std::filesystem::path& directory) {
    int fd = ::open(directory.empty() ? "." : directory.c_str(), O_RDONLY | O_DIRECTORY);
    if (fd < 0) return;  // best effort: some file systems refuse directory fds
    ::fsync(fd);
    ::close(fd);
}

void writeFileAtomically(const std::string& path, std::string_view contents) {
    const std::filesystem::path target(path);
    const std::string temporary = path + ".tmp." + std::to_string(::getpid());
    int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) fail("%s: cannot create: %s", temporary, std::strerror(errno));
    size_t written = 0;
    while (written < contents.size()) {
        ssize_t n = ::write(fd, contents.data() + written, contents.size() - written);
        if (n < 0) {
            if (errno == EINTR) continue;
            int error = errno;
            ::close(fd);
            ::unlink(temporary.c_str());
            fail("%s: write failed: %s", temporary, std::strerror(error));
        }
        written += static_cast<size_t>(n);
    }
    if (::fsync(fd) != 0 || ::close(fd) != 0) {
        int error = errno;
        ::unlink(temporary.c_str());
        fail("%s: fsync failed: %s", temporary, std::strerror(error));
    }
    if (::rename(temporary.c_str(), path.c_str()) != 0) {
        int error = errno;
        ::unlink(temporary.c_str());
        fail("%s: rename failed: %s", path, std::strerror(error));
    }
    fsyncDirectory(target.parent_path());
}

void publishFileAtomically(const std::string& temporary, const std::string& path) {
    int fd = ::open(temporary.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) fail("%s: cannot open: %s", temporary, std::strerror(errno));
    if (::fsync(fd) != 0) {
        int error = errno;
        ::close(fd);
        fail("%s: fsync failed: %s", temporary, std::strerror(error));
    }
    ::close(fd);
    if (::rename(temporary.c_str(), path.c_str()) != 0)
        fail("%s: rename failed: %s", path, std::strerror(errno));
    fsyncDirectory(std::filesystem::path(path).parent_path());
}

std::string directoryWriteProblem(const std::string& directory) {
    const std::string probe = (std::filesystem::path(directory) / ".write-probe").string();
    errno = 0;
    {
        std::ofstream file(probe, std::ios::binary | std::ios::trunc);
        const std::string bytes(4096, '\0');
        file.write(bytes.data(), std::streamsize(bytes.size()));
        file.flush();
        if (!file) {
            const int error = errno;
            std::error_code ignored;
            std::filesystem::remove(probe, ignored);
            return std::strerror(error ? error : EIO);
        }
    }
    std::error_code ignored;
    std::filesystem::remove(probe, ignored);
    return "";
}

}  // namespace alphorn::farm
