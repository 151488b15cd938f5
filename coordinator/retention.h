// Retention: what the coordinator may forget. An ended job is kept for `keep` seconds after it
// ended; a blob goes when no remaining job references it and nobody stored, offered or asked for
// it within `keep` seconds (so an upload for a job about to be submitted is not collected); a
// worker is forgotten when it holds no lease and has not called for `keep` seconds. keep 0
// keeps everything. A job deleted by a client (`alphorn delete`) goes at once, with the blobs only
// it used (deletedJobBlobs). Pure functions of their arguments.
#pragma once

#include "coordinator/blob_store.h"

#include <set>
#include <string>
#include <unordered_map>
#include <vector>

namespace alphorn::coordinator {

class Retention {
  public:
    explicit Retention(double keepSeconds) : m_keep(keepSeconds) {}

    bool keepsEverything() const { return !(m_keep > 0); }
    // `endedAt`: wall clock when the job or the worker's last contact was.
    bool expired(double endedAt, double now) const {
        return !keepsEverything() && endedAt + m_keep <= now;
    }
    // The stored blobs to delete; `touchedAt` maps a blob to its last use (wall clock).
    std::vector<BlobStore::StoredBlob> unusedBlobs(
        const std::vector<BlobStore::StoredBlob>& stored, const std::set<std::string>& referenced,
        const std::unordered_map<std::string, double>& touchedAt, double now) const;

    // The blobs to delete with a job deleted now: those of `jobBlobs` that no remaining job
    // references and that nobody offered, stored or asked for since the last submission that
    // used them (`touchedAt` holds only such uses: a submission consumes the touches of its
    // blobs), so an upload for a submission under way keeps them. The keep time does not apply.
    static std::vector<std::string> deletedJobBlobs(
        const std::set<std::string>& jobBlobs, const std::set<std::string>& referenced,
        const std::unordered_map<std::string, double>& touchedAt);

  private:
    double m_keep;
};

}  // namespace alphorn::coordinator
