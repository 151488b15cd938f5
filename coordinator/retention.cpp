#include "coordinator/retention.h"

#include <algorithm>

namespace alphorn::coordinator {

std::vector<BlobStore::StoredBlob> Retention::unusedBlobs(
    const std::vector<BlobStore::StoredBlob>& stored, const std::set<std::string>& referenced,
    const std::unordered_map<std::string, double>& touchedAt, double now) const {
    std::vector<BlobStore::StoredBlob> unused;
    if (keepsEverything()) return unused;
    for (const BlobStore::StoredBlob& blob : stored) {
        double lastUse = blob.storedAt;
        if (auto it = touchedAt.find(blob.sha256); it != touchedAt.end())
            lastUse = std::max(lastUse, it->second);
        if (!referenced.count(blob.sha256) && expired(lastUse, now)) unused.push_back(blob);
    }
    return unused;
}

std::vector<std::string> Retention::deletedJobBlobs(
    const std::set<std::string>& jobBlobs, const std::set<std::string>& referenced,
    const std::unordered_map<std::string, double>& touchedAt) {
    std::vector<std::string> result;
    for (const std::string& sha : jobBlobs)
        if (!referenced.count(sha) && !touchedAt.count(sha)) result.push_back(sha);
    return result;
}

}  // namespace alphorn::coordinator
