// The worker's bounded cache of bundle blobs, by content hash, evicting the least recently used
// blobs beyond a byte budget. A job's files are hard links into it, so evicting a blob never
// breaks a scene that is loaded, and a blob used by the next job of the same scene is not
// downloaded again.
//
// A blob on disk is trusted only as far as it was verified: its content is hashed again when it
// is first used after the cache is opened (blobs found on disk may have rotted while the worker
// was down, without their size or modification time changing) and whenever its size,
// modification time or inode differ from those it had when it was last verified. A blob whose
// content no longer matches its name is discarded and fetched again, never rendered.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <string>

namespace alphorn::worker {

class BlobCache {
  public:
    BlobCache(std::string directory, uint64_t maxBytes);

    // Path of the blob, fetching it with `fetch(sha256, temporaryPath)` when absent or when the
    // cached copy fails verification. The fetched file's hash is verified before it enters the
    // cache, and it replaces a discarded copy by a rename, so a job directory still linking the
    // old file keeps it unchanged.
    std::string get(const std::string& sha256,
                    const std::function<void(const std::string&, const std::string&)>& fetch);
    // Evicts least recently used blobs until the cache fits its budget, sparing `pinned`.
    void trim(const std::set<std::string>& pinned);
    uint64_t bytes() const;
    // Files hashed since the cache was opened, cached blobs and downloads alike: what
    // verification costs, in files read.
    uint64_t filesHashed() const;

  private:
    // What stat() says of a blob's file; a change means its content may have changed too.
    struct FileStamp {
        uint64_t size = 0;
        uint64_t device = 0;
        uint64_t inode = 0;
        int64_t modifiedSeconds = 0;
        int64_t modifiedNanoseconds = 0;
        bool operator==(const FileStamp&) const = default;
    };
    struct Entry {
        uint64_t size = 0;
        uint64_t lastUse = 0;
        // The file as it was when its content last hashed to its name; none until then.
        std::optional<FileStamp> verified;
    };
    std::string pathOf(const std::string& sha256) const;
    // nullopt when the file is missing.
    static std::optional<FileStamp> stampOf(const std::string& path);
    std::string hashFile(const std::string& path);
    // Whether the cached file of `sha256` can be used as it is, hashing it unless it is
    // unchanged since it was last verified; a damaged file is logged, counted and removed.
    // The stamp of the cached file of `sha256` when it may be used as it is: unchanged since it
    // was last verified, or hashed again and found intact. nullopt when it must be fetched: the
    // file is missing, or damaged (then it is logged, counted and removed).
    std::optional<FileStamp> verifiedStamp(const std::string& sha256, const std::string& path,
                                           const std::optional<FileStamp>& lastVerified);

    std::string m_directory;
    uint64_t m_maxBytes;
    mutable std::mutex m_mutex;
    std::map<std::string, Entry> m_entries;
    uint64_t m_bytes = 0, m_clock = 0;
    std::atomic<uint64_t> m_filesHashed{0};
};

}  // namespace alphorn::worker
