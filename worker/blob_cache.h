// The worker's bounded cache of bundle blobs, by content hash, evicting the least recently used
// blobs beyond a byte budget. A job's files are hard links into it, so evicting a blob never
// breaks a scene that is loaded, and a blob used by the next job of the same scene is not
// downloaded again.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <set>
#include <string>

namespace alphorn::worker {

class BlobCache {
  public:
    BlobCache(std::string directory, uint64_t maxBytes);

    // Path of the blob, fetching it with `fetch(sha256, temporaryPath)` when absent. The fetched
    // file's hash is verified before it enters the cache.
    std::string get(const std::string& sha256,
                    const std::function<void(const std::string&, const std::string&)>& fetch);
    // Evicts least recently used blobs until the cache fits its budget, sparing `pinned`.
    void trim(const std::set<std::string>& pinned);
    uint64_t bytes() const;

  private:
    struct Entry {
        uint64_t size = 0;
        uint64_t lastUse = 0;
    };
    std::string pathOf(const std::string& sha256) const;

    std::string m_directory;
    uint64_t m_maxBytes;
    mutable std::mutex m_mutex;
    std::map<std::string, Entry> m_entries;
    uint64_t m_bytes = 0, m_clock = 0;
};

}  // namespace alphorn::worker
