// The lease scheduler alone, with a clock moved by hand: priorities and FIFO, deadlines and
// renewal, expiry as a failed attempt, poison units (tried on another worker first), fencing of
// results, hand-backs, re-adoption by lease tokens of an earlier epoch only, pass-chunk
// locality, engine fingerprints, audits and quarantine, and a stalled process forgiven.
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
    // The failed unit goes to the other worker (while it is alive): lease until it comes.
    for (;;) {
        lease = *scheduler.lease(kWorkerB);
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

// A worker of another build is leased nothing of the job, and told why; one of the job's build is.
TEST_F(LeaseSchedulerTest, OnlyWorkersOfTheJobsFingerprintAreLeasedItsUnits) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true, "1111111111111111");
    scheduler.addWorker(kWorkerB, true, "2222222222222222");
    scheduler.addJob(1, 0, grid(), {}, {}, true, "2222222222222222");
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value()) << "a worker of another build got a unit";
    const std::string reason = scheduler.idleReason(kWorkerA);
    EXPECT_NE(reason.find("job 1 needs workers of engine fingerprint 2222222222222222"),
              std::string::npos)
        << reason;
    EXPECT_NE(reason.find("1111111111111111"), std::string::npos) << reason;
    const auto lease = scheduler.lease(kWorkerB);
    ASSERT_TRUE(lease.has_value());
    EXPECT_EQ(scheduler.idleReason(kWorkerB), "");
    // A job of A's build is A's.
    scheduler.addJob(2, 0, grid(), {}, {}, true, "1111111111111111");
    EXPECT_EQ(scheduler.lease(kWorkerA)->jobId, 2u);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

// A unit that failed on a worker goes to another while one is alive; with none alive, back to it.
TEST_F(LeaseSchedulerTest, AFailedUnitGoesToAnotherWorkerFirst) {
    LeaseScheduler scheduler = make(1, 5);
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    scheduler.addJob(1, 0, farm::JobGrid(TileGrid(4, 4, 4, 1), 2, 1), {}, {}, true);  // 2 units
    const auto failed = *scheduler.lease(kWorkerA);
    ASSERT_TRUE(scheduler.failAttempt(1, failed.unitIndex, failed.leaseId).has_value());
    // A, restarted after an OOM kill, asks again: it gets the other unit, not the one that failed.
    const auto next = scheduler.lease(kWorkerA);
    ASSERT_TRUE(next.has_value());
    EXPECT_NE(next->unitIndex, failed.unitIndex);
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value())
        << "the worker the unit failed on got it again while another worker is alive";
    // Restarted after an OOM kill, A registers anew on the same host: still not its unit.
    scheduler.addWorker(kWorkerA + 10, true, "", false, "worker 1");
    EXPECT_FALSE(scheduler.lease(kWorkerA + 10).has_value())
        << "a restart of the worker the unit failed on got it again";
    EXPECT_EQ(scheduler.lease(kWorkerB)->unitIndex, failed.unitIndex);
    scheduler.forgetWorker(kWorkerA + 10);
    // Once B fails it too and goes silent, A is the only worker left: it gets the unit again.
    const auto again = scheduler.unitsLeasedTo(kWorkerB);
    ASSERT_EQ(again.size(), 1u);
    ASSERT_TRUE(
        scheduler.failAttempt(1, failed.unitIndex, scheduler.unit(1, failed.unitIndex).leaseId)
            .has_value());
    m_clock.advance(11);
    scheduler.touchWorker(kWorkerA);
    EXPECT_EQ(scheduler.lease(kWorkerA)->unitIndex, failed.unitIndex);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

// A process that stood still longer than a lease charges nobody when it runs again.
TEST_F(LeaseSchedulerTest, AStallIsForgiven) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto lease = *scheduler.lease(kWorkerA);
    m_clock.advance(60);
    scheduler.forgiveStall(60);
    EXPECT_TRUE(scheduler.expireLeases().empty()) << "a lease expired by the process's own stall";
    EXPECT_LT(scheduler.secondsSinceSeen(kWorkerA), 1.0);
    EXPECT_TRUE(scheduler.renew(kWorkerA, lease.leaseId, nullptr));
    m_clock.advance(11);
    EXPECT_EQ(scheduler.expireLeases().size(), 1u) << "silence after the stall still counts";
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

// A worker's first result of a job waits for another worker's render of the same unit; until it
// passes, the worker gets no other unit of the job, and the audit goes first to the other one.
TEST_F(LeaseSchedulerTest, AFirstResultIsAuditedByAnotherWorker) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto first = *scheduler.lease(kWorkerA);
    ASSERT_TRUE(scheduler.wantsAudit(1, first.unitIndex, kWorkerA));
    ASSERT_TRUE(scheduler.holdForAudit(1, first.unitIndex, first.leaseId, kWorkerA));
    EXPECT_EQ(scheduler.heldResults(1, first.unitIndex), std::vector<uint64_t>{kWorkerA});
    EXPECT_EQ(scheduler.checkConsistency(), "");
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value()) << "a worker on probation got more units";
    const auto audit = *scheduler.lease(kWorkerB);
    EXPECT_EQ(audit.unitIndex, first.unitIndex) << "the audit did not go first";
    EXPECT_TRUE(scheduler.auditsWithoutAuditor().empty());
    ASSERT_TRUE(scheduler.markMerged(1, audit.unitIndex, audit.leaseId));
    scheduler.passProbation(kWorkerA, 1);
    scheduler.passProbation(kWorkerB, 1);
    EXPECT_TRUE(scheduler.heldResults(1, first.unitIndex).empty());
    EXPECT_TRUE(scheduler.lease(kWorkerA).has_value());
    // Trusted now: only the audit fraction's draw picks its units (0.01 here).
    int audited = 0;
    for (uint32_t unit = 0; unit < 1000; ++unit) audited += scheduler.wantsAudit(1, unit, kWorkerA);
    EXPECT_GT(audited, 0);
    EXPECT_LT(audited, 40);
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

// With nobody else alive, a result cannot be audited: it is not held. A held one whose other
// workers left is reported stranded.
TEST_F(LeaseSchedulerTest, NoAuditWithoutAnotherLiveWorker) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto alone = *scheduler.lease(kWorkerA);
    EXPECT_FALSE(scheduler.wantsAudit(1, alone.unitIndex, kWorkerA));
    scheduler.addWorker(kWorkerB, true, "another build");
    EXPECT_FALSE(scheduler.wantsAudit(1, alone.unitIndex, kWorkerA))
        << "a worker of another build cannot audit";
    scheduler.addWorker(3, true);
    ASSERT_TRUE(scheduler.wantsAudit(1, alone.unitIndex, kWorkerA));
    ASSERT_TRUE(scheduler.holdForAudit(1, alone.unitIndex, alone.leaseId, kWorkerA));
    EXPECT_TRUE(scheduler.auditsWithoutAuditor().empty());
    m_clock.advance(11);
    scheduler.touchWorker(kWorkerA);
    const auto stranded = scheduler.auditsWithoutAuditor();
    ASSERT_EQ(stranded.size(), 1u);
    EXPECT_EQ(stranded[0], std::make_pair(uint64_t(1), alone.unitIndex));
    EXPECT_EQ(scheduler.checkConsistency(), "");
}

// A quarantined worker is leased nothing; its leases go back, its held results are forgotten.
TEST_F(LeaseSchedulerTest, AQuarantinedWorkerGetsNothingAndLosesItsHeldResults) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addWorker(kWorkerB, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    scheduler.addJob(2, 0, grid(), {}, {}, true);
    const auto held = *scheduler.lease(kWorkerA);
    ASSERT_TRUE(scheduler.holdForAudit(held.jobId, held.unitIndex, held.leaseId, kWorkerA));
    const auto out = *scheduler.lease(kWorkerA);  // a unit of the other job
    EXPECT_NE(out.jobId, held.jobId);
    const auto unheld = scheduler.quarantineWorker(kWorkerA);
    EXPECT_EQ(unheld, (std::vector<std::pair<uint64_t, uint32_t>>{{held.jobId, held.unitIndex}}));
    EXPECT_TRUE(scheduler.quarantined(kWorkerA));
    EXPECT_EQ(scheduler.leaseCount(kWorkerA), 0u);
    EXPECT_FALSE(scheduler.lease(kWorkerA).has_value());
    EXPECT_NE(scheduler.idleReason(kWorkerA).find("quarantined"), std::string::npos);
    EXPECT_TRUE(scheduler.heldResults(held.jobId, held.unitIndex).empty());
    EXPECT_EQ(scheduler.checkConsistency(), "");
    // Both units wait again, for B.
    std::set<std::pair<uint64_t, uint32_t>> leased;
    while (const auto lease = scheduler.lease(kWorkerB))
        leased.insert({lease->jobId, lease->unitIndex});
    EXPECT_TRUE(leased.count({held.jobId, held.unitIndex}));
    EXPECT_TRUE(leased.count({out.jobId, out.unitIndex}));
}

// A restarted job has every unit pending again and no lease out.
TEST_F(LeaseSchedulerTest, ARestartedJobStartsAfresh) {
    LeaseScheduler scheduler = make();
    scheduler.addWorker(kWorkerA, true);
    scheduler.addJob(1, 0, grid(), {}, {}, true);
    const auto merged = *scheduler.lease(kWorkerA);
    ASSERT_TRUE(scheduler.markMerged(1, merged.unitIndex, merged.leaseId));
    const auto out = *scheduler.lease(kWorkerA);
    scheduler.restartJob(1);
    EXPECT_EQ(scheduler.leaseCount(kWorkerA), 0u);
    EXPECT_FALSE(scheduler.renew(kWorkerA, out.leaseId, nullptr)) << "a lease survived the restart";
    EXPECT_EQ(scheduler.checkConsistency(), "");
    int leases = 0;
    while (scheduler.lease(kWorkerA)) ++leases;
    EXPECT_EQ(leases, 8);
}

}  // namespace
}  // namespace alphorn::coordinator
