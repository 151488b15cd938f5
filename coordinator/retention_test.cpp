// Retention: blobs go only when no remaining job references them and their last use is older
// than the keep time; keep 0 keeps everything. A deleted job's blobs go at once.
#include "coordinator/retention.h"

#include <gtest/gtest.h>

namespace alphorn::coordinator {
namespace {

TEST(Retention, UnusedBlobsAreThoseUnreferencedAndNotUsedWithinTheKeepTime) {
    const Retention retention(100);
    const std::vector<BlobStore::StoredBlob> stored{
        {"old", 1, 0}, {"referenced", 2, 0}, {"recent", 3, 950}, {"touched", 4, 0}};
    const std::set<std::string> referenced{"referenced"};
    const std::unordered_map<std::string, double> touchedAt{{"touched", 920}};
    const auto unused = retention.unusedBlobs(stored, referenced, touchedAt, 1000);
    ASSERT_EQ(unused.size(), 1u);
    EXPECT_EQ(unused[0].sha256, "old");
    EXPECT_TRUE(retention.expired(900, 1000));
    EXPECT_FALSE(retention.expired(900.5, 1000));
    const Retention keepAll(0);
    EXPECT_TRUE(keepAll.unusedBlobs(stored, {}, {}, 1e12).empty());
    EXPECT_FALSE(keepAll.expired(0, 1e12));
}

// A job deleted now takes the blobs only it used, except those a client offered, stored or asked
// for since they were last submitted (a submission under way may use them); the keep time does
// not apply.
TEST(Retention, ADeletedJobTakesTheBlobsOnlyItUsed) {
    const std::set<std::string> jobBlobs{"scene", "shared", "asked-since"};
    const std::set<std::string> referenced{"shared"};
    const std::unordered_map<std::string, double> touchedAt{{"asked-since", 1001}};
    EXPECT_EQ(Retention::deletedJobBlobs(jobBlobs, referenced, touchedAt),
              (std::vector<std::string>{"scene"}));
}

}  // namespace
}  // namespace alphorn::coordinator
