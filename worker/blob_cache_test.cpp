// The worker's blob cache verifies what it hands out: a blob damaged on disk, whether its size
// and modification time give it away or not, is discarded and fetched again (logged and
// counted), a re-fetched blob never writes through a hard link a job directory holds, the byte
// count stays right, and an intact blob is hashed once and never fetched again.
#include "worker/blob_cache.h"

#include "common/farm/log.h"
#include "common/farm/metrics.h"
#include "common/farm/sha256.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <vector>

namespace alphorn::worker {
namespace {

namespace fs = std::filesystem;

const std::string kMesh =
    "# a quad\n"
    "v -1.000000 0.000000 -1.000000\n"
    "v 1.000000 0.000000 -1.000000\n"
    "v 1.000000 0.000000 1.000000\n"
    "v -1.000000 0.000000 1.000000\n"
    "f 1 2 3 4\n";
const std::string kOtherMesh = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

std::string readFile(const fs::path& path) {
    std::ifstream file(path, std::ios::binary);
    std::ostringstream bytes;
    bytes << file.rdbuf();
    return bytes.str();
}

void writeFile(const fs::path& path, const std::string& bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
}

// Overwrites bytes of the file in place, as a failing disk or an editor would: the inode and
// every hard link to it see the change.
void overwriteInPlace(const fs::path& path, size_t offset, const std::string& bytes) {
    std::fstream file(path, std::ios::binary | std::ios::in | std::ios::out);
    file.seekp(std::streamoff(offset));
    file << bytes;
}

timespec modificationTime(const fs::path& path) {
    struct stat status {};
    EXPECT_EQ(::stat(path.c_str(), &status), 0);
    return status.st_mtim;
}

void setModificationTime(const fs::path& path, timespec time) {
    const timespec times[2] = {time, time};
    ASSERT_EQ(::utimensat(AT_FDCWD, path.c_str(), times, 0), 0);
}

std::vector<std::string>& loggedLines() {
    static std::vector<std::string> lines;
    return lines;
}
std::mutex g_logMutex;

void collectLogLine(const std::string& line) {
    std::lock_guard lock(g_logMutex);
    loggedLines().push_back(line);
}

double corruptBlobsCounted() {
    std::istringstream lines(farm::metricsText({farm::WorkerMetrics::registry()}));
    const std::string series = "alphorn_worker_blobs_corrupt_total ";
    for (std::string line; std::getline(lines, line);)
        if (line.rfind(series, 0) == 0) return std::stod(line.substr(series.size()));
    return -1;
}

class BlobCacheTest : public ::testing::Test {
  protected:
    void SetUp() override {
        char pattern[] = "/tmp/alphorn-blob-cache-test-XXXXXX";
        ASSERT_NE(::mkdtemp(pattern), nullptr);
        root = pattern;
        blobs = root / "blobs";
        fs::create_directories(blobs);
        {
            std::lock_guard lock(g_logMutex);
            loggedLines().clear();
        }
        farm::setLogSink(collectLogLine);
        corruptBefore = corruptBlobsCounted();
    }
    void TearDown() override {
        farm::setLogSink(nullptr);
        fs::remove_all(root);
    }

    // Fetches like the coordinator would: the true content of every blob, counting calls.
    std::string get(BlobCache& cache, const std::string& content) {
        return cache.get(farm::sha256Hex(content),
                         [&](const std::string& sha256, const std::string& temporary) {
                             EXPECT_EQ(sha256, farm::sha256Hex(content));
                             ++fetches;
                             writeFile(temporary, content);
                         });
    }

    std::vector<std::string> corruptLines() const {
        std::lock_guard lock(g_logMutex);
        std::vector<std::string> found;
        for (const std::string& line : loggedLines())
            if (line.find("event=blob.corrupt") != std::string::npos) found.push_back(line);
        return found;
    }

    fs::path root, blobs;
    int fetches = 0;
    double corruptBefore = 0;
};

TEST_F(BlobCacheTest, BlobDamagedAtRestIsFetchedAgainAtFirstUseThoughSizeAndTimeAreKept) {
    const std::string sha256 = farm::sha256Hex(kMesh);
    const fs::path blob = blobs / sha256;
    writeFile(blob, kMesh);
    // A job directory of the earlier run still links the blob.
    fs::create_directories(root / "jobs");
    fs::create_hard_link(blob, root / "jobs" / "quad.obj");
    const timespec written = modificationTime(blob);
    overwriteInPlace(blob, 9, "v -3");
    setModificationTime(blob, written);  // a damaged disk need not touch the modification time
    const std::string damaged = readFile(blob);
    ASSERT_NE(damaged, kMesh);
    ASSERT_EQ(damaged.size(), kMesh.size());

    BlobCache cache(blobs.string(), 1 << 20);
    const std::string path = get(cache, kMesh);
    EXPECT_EQ(path, blob.string());
    EXPECT_EQ(fetches, 1);
    EXPECT_EQ(readFile(path), kMesh);
    EXPECT_EQ(cache.filesHashed(), 2u);  // the damaged copy, then the download
    EXPECT_EQ(cache.bytes(), kMesh.size());
    // The new copy was renamed into place: the job directory's link keeps the file it had.
    EXPECT_EQ(readFile(root / "jobs" / "quad.obj"), damaged);
    EXPECT_EQ(corruptBlobsCounted() - corruptBefore, 1);
    const std::vector<std::string> lines = corruptLines();
    ASSERT_EQ(lines.size(), 1u);
    EXPECT_NE(lines[0].find("level=warn"), std::string::npos) << lines[0];
    EXPECT_NE(lines[0].find("sha256=" + sha256), std::string::npos) << lines[0];
    EXPECT_NE(lines[0].find("path=blobs/" + sha256), std::string::npos) << lines[0];
    EXPECT_NE(lines[0].find("size=" + std::to_string(kMesh.size())), std::string::npos) << lines[0];
    EXPECT_NE(lines[0].find("action=refetch"), std::string::npos) << lines[0];

    // Verified now: used again, it is neither hashed nor fetched.
    get(cache, kMesh);
    EXPECT_EQ(fetches, 1);
    EXPECT_EQ(cache.filesHashed(), 2u);
}

TEST_F(BlobCacheTest, BlobChangedAfterVerificationWithANewTimeIsFetchedAgain) {
    BlobCache cache(blobs.string(), 1 << 20);
    const std::string path = get(cache, kMesh);
    get(cache, kMesh);
    EXPECT_EQ(fetches, 1);
    EXPECT_EQ(cache.filesHashed(), 1u);

    overwriteInPlace(path, 9, "v -3");
    timespec later = modificationTime(path);
    later.tv_sec += 5;  // beyond any timestamp granularity
    setModificationTime(path, later);
    get(cache, kMesh);
    EXPECT_EQ(fetches, 2);
    EXPECT_EQ(readFile(path), kMesh);
    EXPECT_EQ(cache.filesHashed(), 3u);  // download, the changed copy, download again
    EXPECT_EQ(cache.bytes(), kMesh.size());
    EXPECT_EQ(corruptBlobsCounted() - corruptBefore, 1);
    EXPECT_EQ(corruptLines().size(), 1u);
}

TEST_F(BlobCacheTest, IntactBlobIsHashedOnceAndNeverFetched) {
    writeFile(blobs / farm::sha256Hex(kMesh), kMesh);
    BlobCache cache(blobs.string(), 1 << 20);
    for (int use = 0; use < 3; ++use) EXPECT_EQ(readFile(get(cache, kMesh)), kMesh);
    EXPECT_EQ(fetches, 0);
    EXPECT_EQ(cache.filesHashed(), 1u);
    EXPECT_EQ(cache.bytes(), kMesh.size());
    EXPECT_EQ(corruptBlobsCounted() - corruptBefore, 0);
    EXPECT_TRUE(corruptLines().empty());
}

TEST_F(BlobCacheTest, TouchedButIntactBlobIsHashedAgainNotFetched) {
    BlobCache cache(blobs.string(), 1 << 20);
    const std::string path = get(cache, kMesh);
    timespec later = modificationTime(path);
    later.tv_sec += 5;
    setModificationTime(path, later);
    get(cache, kMesh);
    get(cache, kMesh);
    EXPECT_EQ(fetches, 1);
    EXPECT_EQ(cache.filesHashed(), 2u);
    EXPECT_EQ(corruptBlobsCounted() - corruptBefore, 0);
}

TEST_F(BlobCacheTest, ReplacedBlobKeepsTheByteCountAndCountsAsJustUsed) {
    // A blob cut short at rest beside an intact one, under a budget that holds only the first.
    const fs::path shortened = blobs / farm::sha256Hex(kMesh);
    const fs::path other = blobs / farm::sha256Hex(kOtherMesh);
    writeFile(shortened, kMesh.substr(0, 10));
    writeFile(other, kOtherMesh);
    BlobCache cache(blobs.string(), kMesh.size());
    EXPECT_EQ(cache.bytes(), 10 + kOtherMesh.size());

    get(cache, kOtherMesh);
    get(cache, kMesh);
    EXPECT_EQ(fetches, 1);
    EXPECT_EQ(readFile(shortened), kMesh);
    EXPECT_EQ(cache.bytes(), kMesh.size() + kOtherMesh.size());
    // The least recently used blob goes, not the one just fetched again; the count is exact, so
    // nothing more is evicted.
    cache.trim({});
    EXPECT_EQ(cache.bytes(), kMesh.size());
    EXPECT_TRUE(fs::exists(shortened));
    EXPECT_FALSE(fs::exists(other));
}

TEST_F(BlobCacheTest, MissingBlobIsFetchedWithoutCallingItCorrupt) {
    BlobCache cache(blobs.string(), 1 << 20);
    const std::string path = get(cache, kMesh);
    fs::remove(path);
    EXPECT_EQ(readFile(get(cache, kMesh)), kMesh);
    EXPECT_EQ(fetches, 2);
    EXPECT_EQ(cache.bytes(), kMesh.size());
    EXPECT_EQ(corruptBlobsCounted() - corruptBefore, 0);
}

}  // namespace
}  // namespace alphorn::worker
