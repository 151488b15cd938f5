#include "coordinator/blob_store.h"

#include "common/core/error.h"
#include "common/farm/files.h"

#include <unistd.h>

#include <atomic>
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
    m_file.open(m_temporaryPath, std::ios::binary | std::ios::trunc);
    if (!m_file) fail("cannot create %s", m_temporaryPath);
}

BlobStore::Upload::~Upload() {
    if (!m_committed) {
        m_file.close();
        std::error_code ignored;
        fs::remove(m_temporaryPath, ignored);
    }
}

void BlobStore::Upload::append(std::string_view bytes) {
    m_bytes += bytes.size();
    if (m_bytes > m_store.m_maxBlobBytes)
        fail("blob %s exceeds the limit of %llu bytes", m_claimed,
             static_cast<unsigned long long>(m_store.m_maxBlobBytes));
    m_hasher.update(bytes);
    m_file.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!m_file) fail("cannot write %s", m_temporaryPath);
}

bool BlobStore::Upload::commit() {
    m_file.flush();
    m_file.close();
    const std::string actual = m_hasher.finishHex();
    if (actual != m_claimed)
        fail("hash mismatch: the blob was sent as %s but its content hashes to %s", m_claimed,
             actual);
    const std::string target = m_store.pathOf(m_claimed);
    if (fs::exists(target)) return false;  // fs::remove in the destructor drops the duplicate
    fs::create_directories(fs::path(target).parent_path());
    // The database records the blob as stored once this returns, so its bytes must be on disk.
    farm::publishFileAtomically(m_temporaryPath, target);
    m_committed = true;
    return true;
}

}  // namespace alphorn::coordinator
