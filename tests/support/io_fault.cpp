// A preloaded library that makes one directory's disk fail on demand, for tests of what a daemon
// does when its state directory turns read-only or starts returning I/O errors mid-job (a disk
// remounted read-only after an error, a dying disk). The kernel cannot do this to a directory a
// process holds open for writing without a device-mapper error target, which test machines
// often lack; failing the C library's calls is the next best thing. The daemon itself is the
// real binary.
//
//   ALPHORN_IO_FAULT_DIR     the directory whose files fail (an absolute path)
//   ALPHORN_IO_FAULT_SWITCH  a file: while it exists, every call that would change a file under
//                            the directory fails; its first word, EROFS, ENOSPC (a full disk)
//                            or EIO (the default),
//                            is the error
//
// Calls that only read keep working, as they do on a read-only file system. Files opened before
// the switch fail their writes, fsyncs and truncations too, as on a file system forced
// read-only. Paths are compared as given (relative ones against the working directory), without
// resolving symbolic links.
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/uio.h>
#include <unistd.h>

static const char* faultDirectory() {
    static const char* directory = nullptr;
    if (!directory) {
        const char* value = getenv("ALPHORN_IO_FAULT_DIR");
        directory = value && *value ? value : "";
    }
    return directory;
}

// The error to fail with while the switch file exists, 0 otherwise.
static int activeError() {
    const char* path = getenv("ALPHORN_IO_FAULT_SWITCH");
    if (!path || !*path || !*faultDirectory()) return 0;
    using OpenFunction = int (*)(const char*, int, ...);
    static const auto realOpen = reinterpret_cast<OpenFunction>(dlsym(RTLD_NEXT, "open"));
    const int fd = realOpen(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0) return 0;
    char word[16] = {0};
    using ReadFunction = ssize_t (*)(int, void*, size_t);
    static const auto realRead = reinterpret_cast<ReadFunction>(dlsym(RTLD_NEXT, "read"));
    const ssize_t length = realRead(fd, word, sizeof word - 1);
    close(fd);
    if (length >= 5 && strncmp(word, "EROFS", 5) == 0) return EROFS;
    if (length >= 6 && strncmp(word, "ENOSPC", 6) == 0) return ENOSPC;
    return EIO;
}

static int underDirectory(const char* path) {
    const char* directory = faultDirectory();
    const size_t length = strlen(directory);
    if (!path || !length) return 0;
    char absolute[4096];
    if (path[0] != '/') {
        char cwd[2048];
        if (!getcwd(cwd, sizeof cwd)) return 0;
        snprintf(absolute, sizeof absolute, "%s/%s", cwd, path);
        path = absolute;
    }
    return strncmp(path, directory, length) == 0 && (path[length] == '/' || path[length] == '\0');
}

static int fdUnderDirectory(int fd) {
    char link[64], target[4096];
    snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
    const ssize_t length = readlink(link, target, sizeof target - 1);
    if (length <= 0) return 0;
    target[length] = '\0';
    return underDirectory(target);
}

// Fails the call (returns nonzero, errno set) when faults are on and `path` is under the
// directory. A call that goes ahead finds errno as its caller left it.
static int failPath(const char* path) {
    const int callersErrno = errno;
    const int error = underDirectory(path) ? activeError() : 0;
    errno = error ? error : callersErrno;
    return error;
}

static int failFd(int fd) {
    const int callersErrno = errno;
    const int error = fdUnderDirectory(fd) ? activeError() : 0;
    errno = error ? error : callersErrno;
    return error;
}

static int writes(int flags) {
    return (flags & (O_WRONLY | O_RDWR | O_CREAT | O_TRUNC | O_APPEND)) != 0;
}

// The C library's own `name`, the next definition after this library's.
template <typename Function>
Function nextDefinition(Function, const char* name) {
    return reinterpret_cast<Function>(dlsym(RTLD_NEXT, name));
}
#define REAL(name) static const auto real = nextDefinition(&::name, #name)

// The mode argument of an open that creates a file.
#define MODE_ARGUMENT(flags)                           \
    mode_t mode = 0;                                   \
    if ((flags) & (O_CREAT | O_TMPFILE)) {             \
        va_list args;                                  \
        va_start(args, flags);                         \
        mode = static_cast<mode_t>(va_arg(args, int)); \
        va_end(args);                                  \
    }

extern "C" {

int open(const char* path, int flags, ...) {
    REAL(open);
    MODE_ARGUMENT(flags);
    if (writes(flags) && failPath(path)) return -1;
    return real(path, flags, mode);
}

int open64(const char* path, int flags, ...) {
    REAL(open64);
    MODE_ARGUMENT(flags);
    if (writes(flags) && failPath(path)) return -1;
    return real(path, flags, mode);
}

// A path relative to an open directory fails when the directory is under the faulty one.
static int failAt(int dirfd, const char* path) {
    return dirfd == AT_FDCWD || path[0] == '/' ? failPath(path) : failFd(dirfd);
}

int openat(int dirfd, const char* path, int flags, ...) {
    REAL(openat);
    MODE_ARGUMENT(flags);
    if (writes(flags) && failAt(dirfd, path)) return -1;
    return real(dirfd, path, flags, mode);
}

int openat64(int dirfd, const char* path, int flags, ...) {
    REAL(openat64);
    MODE_ARGUMENT(flags);
    if (writes(flags) && failAt(dirfd, path)) return -1;
    return real(dirfd, path, flags, mode);
}

FILE* fopen(const char* path, const char* mode) {
    REAL(fopen);
    if (strpbrk(mode, "wa+") && failPath(path)) return nullptr;
    return real(path, mode);
}

FILE* fopen64(const char* path, const char* mode) {
    REAL(fopen64);
    if (strpbrk(mode, "wa+") && failPath(path)) return nullptr;
    return real(path, mode);
}

// Writes to standard output and error (logs) are never checked: they are not the directory's.
ssize_t write(int fd, const void* buffer, size_t count) {
    REAL(write);
    if (fd > 2 && failFd(fd)) return -1;
    return real(fd, buffer, count);
}

ssize_t writev(int fd, const struct iovec* iov, int count) {
    REAL(writev);
    if (fd > 2 && failFd(fd)) return -1;
    return real(fd, iov, count);
}

ssize_t pwrite(int fd, const void* buffer, size_t count, off_t offset) {
    REAL(pwrite);
    if (failFd(fd)) return -1;
    return real(fd, buffer, count, offset);
}

ssize_t pwrite64(int fd, const void* buffer, size_t count, off64_t offset) {
    REAL(pwrite64);
    if (failFd(fd)) return -1;
    return real(fd, buffer, count, offset);
}

size_t fwrite(const void* buffer, size_t size, size_t count, FILE* stream) {
    REAL(fwrite);
    const int fd = fileno(stream);
    if (fd > 2 && failFd(fd)) return 0;
    return real(buffer, size, count, stream);
}

int fsync(int fd) {
    REAL(fsync);
    if (failFd(fd)) return -1;
    return real(fd);
}

int fdatasync(int fd) {
    REAL(fdatasync);
    if (failFd(fd)) return -1;
    return real(fd);
}

int ftruncate(int fd, off_t length) {
    REAL(ftruncate);
    if (failFd(fd)) return -1;
    return real(fd, length);
}

int ftruncate64(int fd, off64_t length) {
    REAL(ftruncate64);
    if (failFd(fd)) return -1;
    return real(fd, length);
}

int posix_fallocate(int fd, off_t offset, off_t length) {
    REAL(posix_fallocate);
    if (failFd(fd)) return errno;
    return real(fd, offset, length);
}

int fallocate(int fd, int mode, off_t offset, off_t length) {
    REAL(fallocate);
    if (failFd(fd)) return -1;
    return real(fd, mode, offset, length);
}

int unlink(const char* path) {
    REAL(unlink);
    if (failPath(path)) return -1;
    return real(path);
}

int rmdir(const char* path) {
    REAL(rmdir);
    if (failPath(path)) return -1;
    return real(path);
}

int remove(const char* path) {
    REAL(remove);
    if (failPath(path)) return -1;
    return real(path);
}

int mkdir(const char* path, mode_t mode) {
    REAL(mkdir);
    if (failPath(path)) return -1;
    return real(path, mode);
}

int rename(const char* from, const char* to) {
    REAL(rename);
    if (failPath(from) || failPath(to)) return -1;
    return real(from, to);
}

int link(const char* from, const char* to) {
    REAL(link);
    if (failPath(from) || failPath(to)) return -1;
    return real(from, to);
}

int symlink(const char* target, const char* path) {
    REAL(symlink);
    if (failPath(path)) return -1;
    return real(target, path);
}

int renameat(int fromDir, const char* from, int toDir, const char* to) {
    REAL(renameat);
    if (failAt(fromDir, from) || failAt(toDir, to)) return -1;
    return real(fromDir, from, toDir, to);
}

int renameat2(int fromDir, const char* from, int toDir, const char* to, unsigned flags) {
    REAL(renameat2);
    if (failAt(fromDir, from) || failAt(toDir, to)) return -1;
    return real(fromDir, from, toDir, to, flags);
}

int mkdirat(int dirfd, const char* path, mode_t mode) {
    REAL(mkdirat);
    if (failAt(dirfd, path)) return -1;
    return real(dirfd, path, mode);
}

int linkat(int fromDir, const char* from, int toDir, const char* to, int flags) {
    REAL(linkat);
    if (failAt(fromDir, from) || failAt(toDir, to)) return -1;
    return real(fromDir, from, toDir, to, flags);
}

int unlinkat(int dirfd, const char* path, int flags) {
    REAL(unlinkat);
    if (failAt(dirfd, path)) return -1;
    return real(dirfd, path, flags);
}

}  // extern "C"
