#include "worker/blob_cache.h"

#include "common/core/error.h"
#include "common/farm/sha256.h"

#include <filesystem>
#include <vector>

namespace alphorn::worker {

namespace fs = std::filesystem;

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
        Entry entry{fs::file_size(path), ++m_clock};
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

std::string BlobCache::get(
    const std::string& sha256,
    const std::function<void(const std::string&, const std::string&)>& fetch) {
    const std::string path = pathOf(sha256);
    {
        std::lock_guard lock(m_mutex);
        if (auto it = m_entries.find(sha256); it != m_entries.end() && fs::exists(path)) {
            it->second.lastUse = ++m_clock;
            return path;
        }
    }
    const std::string temporary = path + ".partial";
    fetch(sha256, temporary);
    const std::string actual = farm::sha256OfFile(temporary);
    if (actual != sha256) {
        fs::remove(temporary);
        fail("blob %s arrived corrupt (its content hashes to %s)", sha256, actual);
    }
    fs::rename(temporary, path);
    std::lock_guard lock(m_mutex);
    Entry& entry = m_entries[sha256];
    m_bytes -= entry.size;
    entry.size = fs::file_size(path);
    entry.lastUse = ++m_clock;
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
