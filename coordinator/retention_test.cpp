// Retention: blobs go only when no remaining job references them and their last use is older
// than the keep time; keep 0 keeps everything.
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

}  // namespace
}  // namespace alphorn::coordinator
