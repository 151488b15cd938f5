#include "worker/blob_cache.h"

#include "common/core/error.h"
#include "common/farm/log.h"
#include "common/farm/metrics.h"
#include "common/farm/sha256.h"

#include <sys/stat.h>

#include <algorithm>
#include <filesystem>
#include <vector>

namespace alphorn::worker {

namespace fs = std::filesystem;
using farm::field;
using farm::logWarning;

BlobCache::BlobCache(std::string directory, uint64_t maxBytes)
    : m_directory(std::move(directory)), m_maxBytes(maxBytes) {
    fs::create_directories(m_directory);
    // Blobs from an earlier run stay usable; oldest modification first approximates LRU order.
    std::vector<std::pair<fs::file_time_type, fs::path>> found;
    for (const auto& entry : fs::directory_iterator(m_directory)) {
        const std::string name = entry.path().filename().string();
        if (!entry.is_regular_file()) continue;
        if (!farm::isSha256Hex(name)) {
            fs::remove(entry.path());  // an interrupted download
            continue;
        }
        found.emplace_back(entry.last_write_time(), entry.path());
    }
    std::sort(found.begin(), found.end());
    for (const auto& [time, path] : found) {
        // Not verified yet: the disk may have damaged it while no worker watched.
        Entry entry{fs::file_size(path), ++m_clock, std::nullopt};
        m_bytes += entry.size;
        m_entries[path.filename().string()] = entry;
    }
}

std::string BlobCache::pathOf(const std::string& sha256) const {
    if (!farm::isSha256Hex(sha256)) fail("\"%s\" is not a SHA-256", sha256);
    return (fs::path(m_directory) / sha256).string();
}

uint64_t BlobCache::bytes() const {
    std::lock_guard lock(m_mutex);
    return m_bytes;
}

std::optional<BlobCache::FileStamp> BlobCache::stampOf(const std::string& path) {
    struct stat status {};
    if (::stat(path.c_str(), &status) != 0) return std::nullopt;
    return FileStamp{uint64_t(status.st_size), uint64_t(status.st_dev), uint64_t(status.st_ino),
                     int64_t(status.st_mtim.tv_sec), int64_t(status.st_mtim.tv_nsec)};
}

std::string BlobCache::hashFile(const std::string& path) {
    ++m_filesHashed;
    return farm::sha256OfFile(path);
}

uint64_t BlobCache::filesHashed() const {
    return m_filesHashed;
}

std::optional<BlobCache::FileStamp> BlobCache::verifiedStamp(
    const std::string& sha256, const std::string& path,
    const std::optional<FileStamp>& lastVerified) {
    // Taken before hashing: a change made while the file is read shows at its next use.
    const std::optional<FileStamp> stamp = stampOf(path);
    if (!stamp) return std::nullopt;
    if (stamp == lastVerified) return stamp;
    std::string found;
    try {
        found = hashFile(path);
    } catch (const Error& e) {
        found = e.what();  // an unreadable blob is as useless as a damaged one
    }
    if (found == sha256) return stamp;
    // Removed, not overwritten: a job directory may still link this file, and the fetch renames
    // a new file into place.
    std::error_code ignored;
    fs::remove(path, ignored);
    logWarning("blob.corrupt",
               {field("sha256", sha256),
                field("path", (fs::path(m_directory).filename() / sha256).string()),
                field("size", stamp->size), field("found", found), field("action", "refetch")});
    farm::WorkerMetrics::blobCorrupt();
    return std::nullopt;
}

std::string BlobCache::get(
    const std::string& sha256,
    const std::function<void(const std::string&, const std::string&)>& fetch) {
    const std::string path = pathOf(sha256);
    bool cached = false;
    std::optional<FileStamp> lastVerified;
    {
        std::lock_guard lock(m_mutex);
        if (auto it = m_entries.find(sha256); it != m_entries.end()) {
            cached = true;
            lastVerified = it->second.verified;
        }
    }
    // Hashed without the lock held: a large blob takes a while.
    if (cached) {
        const std::optional<FileStamp> stamp = verifiedStamp(sha256, path, lastVerified);
        std::lock_guard lock(m_mutex);
        auto it = m_entries.find(sha256);
        if (it != m_entries.end()) {
            if (stamp) {
                it->second.verified = stamp;
                it->second.lastUse = ++m_clock;
                return path;
            }
            m_bytes -= it->second.size;
            m_entries.erase(it);
        }
    }
    const std::string temporary = path + ".partial";
    fetch(sha256, temporary);
    const std::optional<FileStamp> stamp = stampOf(temporary);
    const std::string actual = hashFile(temporary);
    if (actual != sha256) {
        fs::remove(temporary);
        fail("blob %s arrived corrupt (its content hashes to %s)", sha256, actual);
    }
    if (!stamp) fail("blob %s: the fetched file vanished", sha256);
    // A rename keeps the inode, size and modification time: the temporary file's stamp is the
    // blob's.
    fs::rename(temporary, path);
    std::lock_guard lock(m_mutex);
    Entry& entry = m_entries[sha256];
    m_bytes -= entry.size;
    entry.size = stamp->size;
    entry.lastUse = ++m_clock;
    entry.verified = stamp;
    m_bytes += entry.size;
    return path;
}

void BlobCache::trim(const std::set<std::string>& pinned) {
    std::lock_guard lock(m_mutex);
    while (m_bytes > m_maxBytes) {
        auto victim = m_entries.end();
        for (auto it = m_entries.begin(); it != m_entries.end(); ++it)
            if (!pinned.count(it->first) &&
                (victim == m_entries.end() || it->second.lastUse < victim->second.lastUse))
                victim = it;
        if (victim == m_entries.end()) return;  // everything left is in use
        std::error_code ignored;
        fs::remove(pathOf(victim->first), ignored);
        m_bytes -= victim->second.size;
        m_entries.erase(victim);
    }
}

}  // namespace alphorn::worker
