#include "coordinator/blob_store.h"

#include "common/core/error.h"
#include "common/farm/files.h"
#include "common/farm/metrics.h"

#include <absl/strings/str_replace.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace alphorn::coordinator {

namespace fs = std::filesystem;

BlobStore::BlobStore(std::string directory, uint64_t maxBlobBytes)
    : m_directory(std::move(directory)), m_maxBlobBytes(maxBlobBytes) {
    fs::create_directories(fs::path(m_directory) / "incoming");
    // Uploads interrupted by a crash leave temporaries behind; they are never valid blobs.
    for (const auto& entry : fs::directory_iterator(fs::path(m_directory) / "incoming"))
        fs::remove(entry.path());
}

std::string BlobStore::pathOf(const std::string& sha256) const {
    if (!farm::isSha256Hex(sha256)) fail("\"%s\" is not a lowercase hex SHA-256", sha256);
    return (fs::path(m_directory) / sha256.substr(0, 2) / sha256).string();
}

bool BlobStore::has(const std::string& sha256) const {
    return farm::isSha256Hex(sha256) && fs::exists(pathOf(sha256));
}

uint64_t BlobStore::size(const std::string& sha256) const {
    std::error_code error;
    uint64_t bytes = fs::file_size(pathOf(sha256), error);
    if (error) fail("blob %s is not stored", sha256);
    return bytes;
}

std::vector<BlobStore::StoredBlob> BlobStore::list() const {
    std::vector<StoredBlob> blobs;
    for (const auto& prefix : fs::directory_iterator(m_directory)) {
        const std::string name = prefix.path().filename().string();
        if (!prefix.is_directory() || name.size() != 2) continue;  // e.g. "incoming"
        for (const auto& file : fs::directory_iterator(prefix.path())) {
            const std::string sha = file.path().filename().string();
            if (!file.is_regular_file() || !farm::isSha256Hex(sha)) continue;
            const auto modified = std::chrono::file_clock::to_sys(file.last_write_time());
            blobs.push_back({sha, file.file_size(),
                             std::chrono::duration<double>(modified.time_since_epoch()).count()});
        }
    }
    return blobs;
}

void BlobStore::remove(const std::string& sha256) {
    std::error_code ignored;
    fs::remove(pathOf(sha256), ignored);
}

BlobStore::Upload::Upload(const BlobStore& store, std::string claimedSha256)
    : m_store(store), m_claimed(std::move(claimedSha256)) {
    if (!farm::isSha256Hex(m_claimed)) fail("\"%s\" is not a lowercase hex SHA-256", m_claimed);
    static std::atomic<uint64_t> counter{0};
    m_temporaryPath =
        (fs::path(store.m_directory) / "incoming" /
         (m_claimed + "." + std::to_string(::getpid()) + "." + std::to_string(++counter)))
            .string();
    m_fd = ::open(m_temporaryPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (m_fd < 0) fail("cannot create a file for blob %s: %s", m_claimed, std::strerror(errno));
}

BlobStore::Upload::~Upload() {
    if (m_fd >= 0) ::close(m_fd);
    if (!m_committed) {
        std::error_code ignored;
        fs::remove(m_temporaryPath, ignored);
    }
}

void BlobStore::Upload::append(std::string_view bytes) {
    m_bytes += bytes.size();
    if (m_bytes > m_store.m_maxBlobBytes)
        fail("blob %s exceeds the limit of %llu bytes", m_claimed,
             static_cast<unsigned long long>(m_store.m_maxBlobBytes));
    if (m_fd < 0) fail("blob %s: the upload failed before", m_claimed);
    m_hasher.update(bytes);
    size_t written = 0;
    while (written < bytes.size()) {
        const ssize_t n = ::write(m_fd, bytes.data() + written, bytes.size() - written);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail("cannot store blob %s: %s", m_claimed, std::strerror(errno));
        written += size_t(n);
    }
}

bool BlobStore::Upload::commit() {
    if (m_fd < 0) fail("blob %s: the upload failed before", m_claimed);
    const std::string actual = m_hasher.finishHex();
    if (actual != m_claimed)
        fail("hash mismatch: the blob was sent as %s but its content hashes to %s", m_claimed,
             actual);
    // The blob counts as stored once this returns (a submission may use it), so its bytes must
    // be on disk.
    struct stat info {};
    const bool synced = ::fsync(m_fd) == 0 && ::fstat(m_fd, &info) == 0;
    const int error = errno;
    const bool closed = ::close(m_fd) == 0;
    m_fd = -1;
    if (!synced || !closed)
        fail("cannot store blob %s: %s", m_claimed, std::strerror(synced ? errno : error));
    if (uint64_t(info.st_size) != m_bytes)
        fail("cannot store blob %s: %u of its %u bytes reached the disk", m_claimed,
             uint64_t(info.st_size), m_bytes);
    const std::string target = m_store.pathOf(m_claimed);
    if (fs::exists(target)) return false;  // the destructor drops the duplicate
    fs::create_directories(fs::path(target).parent_path());
    try {
        farm::publishFileAtomically(m_temporaryPath, target);
    } catch (const Error& e) {
        // The client sees this: name the blob, not the server's directories.
        fail("cannot store blob %s: %s", m_claimed,
             absl::StrReplaceAll(e.what(), {{m_store.m_directory + "/", ""}}));
    }
    m_committed = true;
    farm::CoordinatorMetrics::blobStored(m_bytes);
    return true;
}

}  // namespace alphorn::coordinator
