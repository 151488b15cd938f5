// The lease scheduler alone, with a clock moved by hand: priorities and FIFO, deadlines and
// renewal, expiry as a failed attempt, poison units, fencing of results, hand-backs, re-adoption
// by lease tokens of an earlier epoch only, and pass-chunk locality.
#include "coordinator/lease_scheduler.h"

#include <gtest/gtest.h>

namespace alphorn::coordinator {
namespace {

constexpr uint64_t kWorkerA = 1, kWorkerB = 2;

class LeaseSchedulerTest : public ::testing::Test {
  protected:
    LeaseScheduler make(uint64_t epoch = 1, uint32_t maxAttempts = 3) {
        return LeaseScheduler(m_clock, SchedulerOptions{10.0, maxAttempts},
                              LeaseTokens(std::string(32, 'k'), epoch), 1000);
    }
    // 2 x 2 tiles of 4 pixels, 4 passes, 2 passes per unit: 2 chunks of 4 tiles, 8 units.
    static farm::JobGrid grid() { return farm::JobGrid(TileGrid(8, 8, 4, 1), 4, 2); }

    ManualClock m_clock;
};

TEST_F(LeaseSchedulerTest, HighestPriorityFirstThenTheOldestJob) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(5, 0, grid(), {}, {}, true);
    scheduler.addJob(6, 2, grid(), {}, {}, true);
    scheduler.addJob(7, 2, grid(), {}, {}, true);
    for (int i = 0; i < 8; ++i) EXPECT_EQ(scheduler.lease(kWorkerA)->jobId, 6u) << i;
    EXPECT_EQ(scheduler.lease(kWorkerA)->jobId, 7u);
    scheduler.endJob(7);
    EXPECT_EQ(scheduler.lease(kWorkerA)->jobId, 5u);
    EXPECT_FALSE(scheduler.lease(99).has_value()) << "an unknown worker got a lease";
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

TEST_F(LeaseSchedulerTest, ALeaseExpiresAtItsDeadlineUnlessRenewed) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto kept = *scheduler.lease(kWorkerA);
    const auto lost = *scheduler.lease(kWorkerA);
    m_clock.advance(6);
    EXPECT_TRUE(scheduler.renew(kWorkerA, kept.leaseId, nullptr));
    m_clock.advance(4);
    EXPECT_TRUE(scheduler.expireLeases().empty()) << "expired at, not after, its deadline";
    m_clock.advance(0.5);
    const auto expired = scheduler.expireLeases();
    ASSERT_EQ(expired.size(), 1u);
    EXPECT_EQ(expired[0].first.unitIndex, lost.unitIndex);
    EXPECT_EQ(expired[0].first.workerId, kWorkerA);
    EXPECT_EQ(expired[0].second.attempts, 1u);
    EXPECT_FALSE(expired[0].second.poisoned);
    EXPECT_FALSE(scheduler.renew(kWorkerA, lost.leaseId, nullptr)) << "an expired lease renewed";
    EXPECT_TRUE(scheduler.holds(1, kept.unitIndex, kept.leaseId));
    EXPECT_EQ(scheduler.jobLeases(1).attemptsFailed, 1u);
    EXPECT_EQ(scheduler.jobLeases(1).leased, 1u);
    // The unit waits again and is leased again.
    scheduler.addWorker(kWorkerB, true);
    bool leasedAgain = false;
    while (const auto lease = scheduler.lease(kWorkerB))
        leasedAgain |= lease->unitIndex == lost.unitIndex;
    EXPECT_TRUE(leasedAgain);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

TEST_F(LeaseSchedulerTest, APoisonUnitEndsItsJobAndDropsItsLeases) {
    LeaseScheduler scheduler = make(1, 2);
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto other = *scheduler.lease(kWorkerB);
    auto lease = *scheduler.lease(kWorkerA);
    const auto first = scheduler.failAttempt(1, lease.unitIndex, lease.leaseId);
    ASSERT_TRUE(first.has_value());
    EXPECT_FALSE(first->poisoned);
    EXPECT_TRUE(scheduler.running(1));
    // Lease the other units until the failed one comes again.
    for (;;) {
        lease = *scheduler.lease(kWorkerA);
        if (lease.unitIndex == first->unitIndex) break;
    }
    const auto second = scheduler.failAttempt(1, lease.unitIndex, lease.leaseId);
    ASSERT_TRUE(second.has_value());
    EXPECT_TRUE(second->poisoned);
    EXPECT_FALSE(scheduler.running(1));
    EXPECT_FALSE(scheduler.renew(kWorkerB, other.leaseId, nullptr)) << "a failed job's lease";
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value());
    EXPECT_EQ(scheduler.jobLeases(1).leased, 0u);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

TEST_F(LeaseSchedulerTest, ResultsAreFencedAndMergedOnce) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    scheduler.addJob(1, 0, farm::JobGrid(TileGrid(4, 4, 4, 1), 1, 1), {}, {}, true);  // one unit
    const auto slow = *scheduler.lease(kWorkerA);
    m_clock.advance(11);
    ASSERT_EQ(scheduler.expireLeases().size(), 1u);
    // The expired holder's result is taken while the unit waits (the work is the same)...
    EXPECT_TRUE(scheduler.mayMerge(1, 0, slow.leaseId));
    const auto fast = *scheduler.lease(kWorkerB);
    // ...but not once another worker holds the unit.
    EXPECT_FALSE(scheduler.mayMerge(1, 0, slow.leaseId));
    EXPECT_FALSE(scheduler.failAttempt(1, 0, slow.leaseId).has_value())
        << "a failure counted from a worker that no longer holds the unit";
    EXPECT_FALSE(scheduler.handBack(1, 0, slow.leaseId));
    EXPECT_TRUE(scheduler.markMerged(1, 0, fast.leaseId));
    EXPECT_FALSE(scheduler.mayMerge(1, 0, fast.leaseId)) << "a unit merged twice";
    EXPECT_FALSE(scheduler.markMerged(1, 0, slow.leaseId));
    EXPECT_EQ(scheduler.jobLeases(1).leased, 0u);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

TEST_F(LeaseSchedulerTest, AHandBackIsNotAnAttempt) {
    LeaseScheduler scheduler = make(1, 1);
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto lease = *scheduler.lease(kWorkerA);
    EXPECT_TRUE(scheduler.handBack(1, lease.unitIndex, lease.leaseId));
    EXPECT_TRUE(scheduler.running(1));
    EXPECT_EQ(scheduler.jobLeases(1).attemptsFailed, 0u);
    EXPECT_EQ(scheduler.lease(kWorkerA)->unitIndex, lease.unitIndex);
}

TEST_F(LeaseSchedulerTest, OnlyLeasesOfAnEarlierEpochAreReadopted) {
    LeaseScheduler before = make(1);
    before.addWorker(kWorkerA, true);
    before.addJob(1, 0, grid(), {}, {}, true);
    const auto lease = *before.lease(kWorkerA);
    const LeaseScheduler::HeldUnit held{1, lease.unitIndex, lease.token};

    LeaseScheduler same = make(1);
    same.addWorker(kWorkerA, true);
    same.addJob(1, 0, grid(), {}, {}, true);
    EXPECT_FALSE(same.renew(kWorkerA, lease.leaseId, &held)) << "a token of this epoch";

    LeaseScheduler after = make(2);
    after.addWorker(kWorkerA, false);
    after.addWorker(kWorkerB, false);
    after.addJob(1, 0, grid(), {}, {}, true);
    LeaseScheduler::HeldUnit forged = held;
    forged.token.back() ^= 1;
    EXPECT_FALSE(after.renew(kWorkerA, lease.leaseId, &forged));
    LeaseScheduler::HeldUnit otherUnit = held;
    otherUnit.unitIndex ^= 1;
    EXPECT_FALSE(after.renew(kWorkerA, lease.leaseId, &otherUnit));
    EXPECT_FALSE(after.renew(kWorkerB, lease.leaseId, &held)) << "another worker's token";
    EXPECT_FALSE(after.renew(kWorkerA, lease.leaseId, nullptr)) << "no token";
    EXPECT_TRUE(after.renew(kWorkerA, lease.leaseId, &held));
    EXPECT_TRUE(after.holds(1, lease.unitIndex, lease.leaseId));
    EXPECT_EQ(after.jobLeases(1).leased, 1u);
    EXPECT_EQ(after.checkConsistency(), "");
}

TEST_F(LeaseSchedulerTest, WorkersKeepTheirPassChunk) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    const farm::JobGrid chunks = grid();
    scheduler.addJob(1, 0, chunks, {}, {}, true);
    const auto a1 = *scheduler.lease(kWorkerA);
    const auto b1 = *scheduler.lease(kWorkerB);
    EXPECT_NE(chunks.chunkOf(a1.unitIndex), chunks.chunkOf(b1.unitIndex))
        << "the second worker did not get a chunk of its own";
    const auto a2 = *scheduler.lease(kWorkerA);
    const auto b2 = *scheduler.lease(kWorkerB);
    EXPECT_EQ(chunks.chunkOf(a2.unitIndex), chunks.chunkOf(a1.unitIndex));
    EXPECT_EQ(chunks.chunkOf(b2.unitIndex), chunks.chunkOf(b1.unitIndex));
    EXPECT_EQ(scheduler.jobLeases(1).activeWorkers, 2u);
}

TEST_F(LeaseSchedulerTest, RestoredUnitsAndAttemptsAreKept) {
    LeaseScheduler scheduler = make(2, 3);
    scheduler.addWorker(kWorkerA, true);
    std::vector<bool> merged(8, true);
    merged[5] = false;
    std::vector<uint32_t> attempts(8, 0);
    attempts[5] = 2;
    scheduler.addJob(1, 0, grid(), merged, attempts, true);
    EXPECT_EQ(scheduler.jobLeases(1).attemptsFailed, 2u);
    const auto lease = *scheduler.lease(kWorkerA);
    EXPECT_EQ(lease.unitIndex, 5u);
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value());
    EXPECT_TRUE(scheduler.failAttempt(1, 5, lease.leaseId)->poisoned)
        << "the stored attempts did not count";
}

// The decision barrier of a job with a target error: units past the limit are neither leased,
// merged nor re-adopted until it is raised.
TEST_F(LeaseSchedulerTest, NothingPastTheLeaseLimit) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(5, 0, grid(), {}, {}, true);
    scheduler.setLeaseLimit(5, 4);  // the first chunk's 4 tiles
    std::vector<LeaseScheduler::Lease> leases;
    for (int i = 0; i < 4; ++i) {
        auto lease = scheduler.lease(kWorkerA);
        ASSERT_TRUE(lease);
        EXPECT_LT(lease->unitIndex, 4u);
        leases.push_back(*lease);
    }
    EXPECT_FALSE(scheduler.lease(kWorkerA)) << "a unit past the limit was leased";
    EXPECT_FALSE(scheduler.mayMerge(5, 6, 0)) << "a unit past the limit may be merged";
    for (const auto& lease : leases)
        EXPECT_TRUE(scheduler.markMerged(5, lease.unitIndex, lease.leaseId));
    EXPECT_FALSE(scheduler.lease(kWorkerA));
    scheduler.setLeaseLimit(5, 8);
    auto next = scheduler.lease(kWorkerA);
    ASSERT_TRUE(next);
    EXPECT_EQ(next->unitIndex, 4u);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

}  // namespace
}  // namespace alphorn::coordinator
