// Content-addressed blob storage on disk: blobs/<first two hex digits>/<sha256>. A blob is
// written to a temporary file while its hash is computed and becomes visible (by rename) only
// when the content matches its name, so a stored blob is always what its name says.
#pragma once

#include "common/farm/sha256.h"

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace alphorn::coordinator {

class BlobStore {
  public:
    BlobStore(std::string directory, uint64_t maxBlobBytes);

    bool has(const std::string& sha256) const;
    // Size of a stored blob; throws Error when absent.
    uint64_t size(const std::string& sha256) const;
    std::string pathOf(const std::string& sha256) const;
    uint64_t maxBlobBytes() const { return m_maxBlobBytes; }

    struct StoredBlob {
        std::string sha256;
        uint64_t size = 0;
        double storedAt = 0;  // seconds since the epoch (the file's modification time)
    };
    // Every stored blob, read from the directory (uploads in progress are not listed).
    std::vector<StoredBlob> list() const;
    // Deletes a stored blob; absent is not an error.
    void remove(const std::string& sha256);

    // One upload in progress. Throws Error on too many bytes or a failed write (a full disk);
    // commit() throws on a hash mismatch or when the bytes did not all reach the disk, so a
    // blob is published only after a complete write, fsync and close.
    class Upload {
      public:
        Upload(const BlobStore& store, std::string claimedSha256);
        ~Upload();
        void append(std::string_view bytes);
        // Verifies the hash and moves the blob into place. Returns false if it was already there.
        bool commit();

      private:
        const BlobStore& m_store;
        std::string m_claimed, m_temporaryPath;
        int m_fd = -1;
        farm::Sha256 m_hasher;
        uint64_t m_bytes = 0;
        bool m_committed = false;
    };

  private:
    std::string m_directory;
    uint64_t m_maxBlobBytes;
};

}  // namespace alphorn::coordinator
