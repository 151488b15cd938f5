// Unit tests of the farm plumbing both daemons share: the retry policy, typed refusals and the
// structured log format, the chunks of a stream.
#include "common/core/error.h"
#include "common/farm/chunks.h"
#include "common/farm/error_reason.h"
#include "common/farm/log.h"
#include "common/farm/retry_policy.h"
#include "common/stats/chi_square.h"

#include <gtest/gtest.h>

#include <sstream>
#include <vector>

namespace alphorn::farm {
namespace {

using std::chrono::milliseconds;

TEST(RetryPolicy, CeilingDoublesToTheCapAndResets) {
    RetryPolicy policy({milliseconds(100), milliseconds(1000)}, 1);
    const std::vector<int64_t> ceilings = {100, 200, 400, 800, 1000, 1000, 1000};
    for (int64_t expected : ceilings) {
        EXPECT_EQ(policy.currentCeiling().count(), expected);
        const milliseconds delay = policy.nextDelay();
        EXPECT_GE(delay.count(), 0);
        EXPECT_LE(delay.count(), expected);
    }
    EXPECT_EQ(policy.failures(), ceilings.size());
    policy.reset();
    EXPECT_EQ(policy.failures(), 0u);
    EXPECT_EQ(policy.currentCeiling().count(), 100);
    // Many failures never overflow the doubling.
    for (int i = 0; i < 200; ++i) EXPECT_LE(policy.nextDelay().count(), 1000);
}

TEST(RetryPolicy, SameSeedSameDelays) {
    RetryPolicy a({milliseconds(10), milliseconds(10000)}, 42),
        b({milliseconds(10), milliseconds(10000)}, 42),
        c({milliseconds(10), milliseconds(10000)}, 43);
    std::vector<int64_t> first, second, third;
    for (int i = 0; i < 12; ++i) {
        first.push_back(a.nextDelay().count());
        second.push_back(b.nextDelay().count());
        third.push_back(c.nextDelay().count());
    }
    EXPECT_EQ(first, second);
    EXPECT_NE(first, third);
}

TEST(RetryPolicy, FullJitterIsUniformOverTheCeiling) {
    // At the cap every delay is uniform over [0, 100] ms: bin the draws below 100 into ten bins
    // of 10 ms and test them against equal expected counts (fixed seed).
    RetryPolicy policy({milliseconds(100), milliseconds(100)}, 7);
    std::vector<double> observed(10, 0.0), expected(10, 0.0);
    const int draws = 20000;
    int top = 0;
    for (int i = 0; i < draws; ++i) {
        const int64_t delay = policy.nextDelay().count();
        ASSERT_LE(delay, 100);
        if (delay == 100) {
            ++top;
            continue;
        }
        observed[size_t(delay / 10)] += 1;
    }
    for (double& e : expected) e = double(draws - top) / 10.0;
    const stats::Chi2Result result =
        stats::chi2Test(observed, expected, double(draws - top), 5.0, 0.01);
    EXPECT_TRUE(result.passed) << result.message;
    EXPECT_GT(top, 0) << "the ceiling itself is never drawn";
}

TEST(RetryPolicy, RefusesBadTimings) {
    EXPECT_THROW(RetryPolicy({milliseconds(0), milliseconds(10)}, 1), Error);
    EXPECT_THROW(RetryPolicy({milliseconds(100), milliseconds(10)}, 1), Error);
}

TEST(ErrorReason, RoundTripsThroughStatusDetails) {
    const grpc::Status status =
        statusWithReason(grpc::StatusCode::NOT_FOUND, "unknown worker 3: register again",
                         v1::ERROR_REASON_UNKNOWN_WORKER);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND);
    EXPECT_EQ(status.error_message(), "unknown worker 3: register again");
    EXPECT_EQ(reasonOf(status), v1::ERROR_REASON_UNKNOWN_WORKER);
    EXPECT_EQ(reasonOf(statusWithReason(grpc::StatusCode::NOT_FOUND, "no job 2",
                                        v1::ERROR_REASON_UNKNOWN_JOB)),
              v1::ERROR_REASON_UNKNOWN_JOB);
    // Without details, or with details that are not ours, there is no reason.
    EXPECT_EQ(reasonOf(grpc::Status(grpc::StatusCode::NOT_FOUND, "unknown worker 3")),
              v1::ERROR_REASON_UNSPECIFIED);
    EXPECT_EQ(reasonOf(grpc::Status(grpc::StatusCode::NOT_FOUND, "x", "\xff\xff garbage")),
              v1::ERROR_REASON_UNSPECIFIED);
    EXPECT_TRUE(isTransient(grpc::Status(grpc::StatusCode::UNAVAILABLE, "")));
    EXPECT_FALSE(isTransient(status));
}

TEST(Log, KeyValueLinesQuoteWhatNeedsIt) {
    EXPECT_EQ(formatLogLine("info", "unit.rendered", {field("job", 3), field("unit", 17u)}),
              "level=info event=unit.rendered job=3 unit=17");
    EXPECT_EQ(formatLogLine("warn", "unit.failed",
                            {field("error", "scene.xml:3: no \"x\""), field("empty", "")}),
              "level=warn event=unit.failed error=\"scene.xml:3: no \\\"x\\\"\" empty=\"\"");
}

// The chunks of a string and of a stream of the same bytes, as (data, first, last) triples.
struct Chunk {
    std::string data;
    bool first, last;
    bool operator==(const Chunk&) const = default;
};

static std::vector<Chunk> chunksOf(const std::string& bytes, size_t chunkBytes, bool asStream) {
    std::vector<Chunk> chunks;
    const ChunkSink sink = [&](std::string_view data, bool first, bool last) {
        chunks.push_back({std::string(data), first, last});
        return true;
    };
    if (asStream) {
        std::istringstream in(bytes);
        EXPECT_TRUE(sendChunks(in, sink, chunkBytes));
    } else {
        EXPECT_TRUE(sendChunks(bytes, sink, chunkBytes));
    }
    return chunks;
}

TEST(Chunks, CutIntoPiecesThatJoinToTheBytesWithFirstAndLastMarked) {
    for (bool asStream : {false, true}) {
        for (size_t size : {0, 1, 6, 7, 8, 21}) {
            const std::string bytes = std::string("abcdefghijklmnopqrstuvwxyz").substr(0, size);
            const std::vector<Chunk> chunks = chunksOf(bytes, 7, asStream);
            SCOPED_TRACE(testing::Message() << "size " << size << " stream " << asStream);
            // ceil(size / 7) chunks, one (empty) for no bytes: no empty chunk after a full one.
            ASSERT_EQ(chunks.size(), std::max<size_t>(1, (size + 6) / 7));
            std::string joined;
            for (size_t i = 0; i < chunks.size(); ++i) {
                EXPECT_EQ(chunks[i].first, i == 0);
                EXPECT_EQ(chunks[i].last, i + 1 == chunks.size());
                EXPECT_LE(chunks[i].data.size(), 7u);
                joined += chunks[i].data;
            }
            EXPECT_EQ(joined, bytes);
        }
    }
}

TEST(Chunks, StopWhenTheSinkRefuses) {
    for (bool asStream : {false, true}) {
        int calls = 0;
        const ChunkSink sink = [&](std::string_view, bool, bool) { return ++calls < 2; };
        std::istringstream in(std::string(50, 'x'));
        const bool finished =
            asStream ? sendChunks(in, sink, 7) : sendChunks(std::string(50, 'x'), sink, 7);
        EXPECT_FALSE(finished);
        EXPECT_EQ(calls, 2);
    }
}

}  // namespace
}  // namespace alphorn::farm
