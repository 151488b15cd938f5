// The worker registry alone, with a clock moved by hand: the liveness rules `alphorn workers`
// shows (alive, silent, dead, left), what a stopping worker's heartbeats mean, restored workers,
// forgetting silent workers, merge counts and rates, and the units each worker holds.
#include "coordinator/worker_registry.h"

#include <gtest/gtest.h>

namespace alphorn::coordinator {
namespace {

constexpr double kLeaseSeconds = 20;

class WorkerRegistryTest : public ::testing::Test {
  protected:
    WorkerRegistryTest()
        : m_scheduler(m_clock, SchedulerOptions{kLeaseSeconds, 3},
                      LeaseTokens(std::string(32, 'k'), 1), 1000),
          m_registry(m_clock, m_scheduler, kLeaseSeconds) {}

    v1::WorkerState state(uint64_t workerId) {
        return m_registry.info(workerId, *m_registry.find(workerId)).state();
    }
    v1::HeartbeatRequest heartbeat(uint64_t workerId, bool draining, bool exiting, int leases = 0) {
        v1::HeartbeatRequest request;
        request.set_worker_id(workerId);
        request.set_draining(draining);
        request.set_exiting(exiting);
        for (int i = 0; i < leases; ++i) request.add_lease_ids(uint64_t(i) + 1);
        return request;
    }

    ManualClock m_clock;
    LeaseScheduler m_scheduler;
    WorkerRegistry m_registry;
};

TEST_F(WorkerRegistryTest, SilentAfterTwoHeartbeatIntervalsDeadAfterThreeLeasePeriods) {
    EXPECT_DOUBLE_EQ(m_registry.heartbeatIntervalSeconds(), kLeaseSeconds / 4);
    EXPECT_DOUBLE_EQ(m_registry.silentAfterSeconds(), 2 * kLeaseSeconds / 4);
    v1::RegisterRequest registration;
    registration.set_name("w1");
    registration.set_cores(8);
    m_registry.add(7, registration);
    EXPECT_TRUE(m_scheduler.knowsWorker(7));
    EXPECT_EQ(state(7), v1::WORKER_STATE_ALIVE);
    m_clock.advance(m_registry.silentAfterSeconds() - 0.5);
    EXPECT_EQ(state(7), v1::WORKER_STATE_ALIVE);
    m_clock.advance(1);
    EXPECT_EQ(state(7), v1::WORKER_STATE_SILENT);
    EXPECT_EQ(m_registry.list(false).size(), 1u) << "a silent worker is still alive";
    m_clock.advance(3 * kLeaseSeconds);
    EXPECT_EQ(state(7), v1::WORKER_STATE_DEAD);
    EXPECT_TRUE(m_registry.list(false).empty());
    ASSERT_EQ(m_registry.list(true).size(), 1u);
    EXPECT_EQ(m_registry.list(true)[0].name(), "w1");
    EXPECT_EQ(m_registry.list(true)[0].cores(), 8u);
    ASSERT_NE(m_registry.touch(7), nullptr);
    EXPECT_EQ(state(7), v1::WORKER_STATE_ALIVE) << "a call brings a dead worker back";
    EXPECT_EQ(m_registry.touch(8), nullptr) << "an unknown worker was touched";
    EXPECT_EQ(m_registry.name(7), "w1");
    EXPECT_EQ(m_registry.name(8), "");
}

// A worker stopping on SIGTERM heartbeats `draining` while it finishes its leases, then
// `exiting` with none: draining, then left. A late heartbeat of the stopping process, without
// leases, leaves it gone; any other call brings it back.
TEST_F(WorkerRegistryTest, AStoppingWorkerDrainsThenLeaves) {
    m_registry.add(3, v1::RegisterRequest());
    WorkerRegistry::Worker* worker = m_registry.heartbeat(heartbeat(3, true, false, 1));
    ASSERT_NE(worker, nullptr);
    EXPECT_TRUE(worker->exiting);
    v1::WorkerInfo info = m_registry.info(3, *worker);
    EXPECT_TRUE(info.draining());
    EXPECT_TRUE(info.exiting());
    EXPECT_EQ(info.state(), v1::WORKER_STATE_ALIVE);
    m_registry.heartbeat(heartbeat(3, true, true, 1));
    EXPECT_EQ(state(3), v1::WORKER_STATE_ALIVE) << "left while still holding a lease";
    m_registry.heartbeat(heartbeat(3, true, true));
    EXPECT_EQ(state(3), v1::WORKER_STATE_LEFT);
    EXPECT_FALSE(m_registry.list(true)[0].alive());
    m_registry.heartbeat(heartbeat(3, true, false));
    EXPECT_EQ(state(3), v1::WORKER_STATE_LEFT) << "a late heartbeat brought a worker back";
    m_registry.touch(3);
    EXPECT_EQ(state(3), v1::WORKER_STATE_ALIVE);
    EXPECT_EQ(m_registry.heartbeat(heartbeat(4, false, false)), nullptr);
}

TEST_F(WorkerRegistryTest, RestoredWorkersAreDeadUntilTheyCallAndKeepTheirDrain) {
    WorkerRow row;
    row.id = 11;
    row.name = "restored";
    row.draining = true;
    m_registry.restore(row);
    EXPECT_EQ(state(11), v1::WORKER_STATE_DEAD);
    WorkerRegistry::Worker* worker = m_registry.touch(11);
    ASSERT_NE(worker, nullptr);
    EXPECT_EQ(state(11), v1::WORKER_STATE_ALIVE);
    EXPECT_TRUE(m_registry.info(11, *worker).draining());
    EXPECT_FALSE(m_registry.info(11, *worker).exiting());
    EXPECT_TRUE(m_registry.setDraining(*worker, false));
    EXPECT_FALSE(m_registry.setDraining(*worker, false)) << "an unchanged drain counted";
    EXPECT_FALSE(m_registry.info(11, *worker).draining());
}

TEST_F(WorkerRegistryTest, SilentWorkersWithoutLeasesAreForgottenAfterTheKeepTime) {
    const Retention retention(100);
    m_scheduler.addJob(1, 0, farm::JobGrid(TileGrid(8, 8, 4, 1), 1, 1), {}, {}, true);
    m_registry.add(1, v1::RegisterRequest());
    m_registry.add(2, v1::RegisterRequest());
    ASSERT_TRUE(m_scheduler.lease(2).has_value());
    const double start = m_clock.wallSeconds();
    EXPECT_TRUE(m_registry.forgetSilent(retention, start + 99).empty());
    EXPECT_EQ(m_registry.forgetSilent(retention, start + 100), std::vector<uint64_t>{1});
    EXPECT_EQ(m_registry.find(1), nullptr);
    EXPECT_FALSE(m_scheduler.knowsWorker(1)) << "the scheduler still knows a forgotten worker";
    EXPECT_NE(m_registry.find(2), nullptr) << "a worker holding a lease was forgotten";
    EXPECT_TRUE(m_registry.forgetSilent(Retention(0), start + 1e9).empty())
        << "keep time 0 keeps every worker";
}

TEST_F(WorkerRegistryTest, CountsMergesAndListsHeldUnits) {
    m_scheduler.addJob(1, 0, farm::JobGrid(TileGrid(8, 8, 4, 1), 1, 1), {}, {}, true);
    m_registry.add(1, v1::RegisterRequest());
    m_registry.add(2, v1::RegisterRequest());
    const auto first = *m_scheduler.lease(1);
    const auto second = *m_scheduler.lease(2);
    const auto third = *m_scheduler.lease(1);
    const auto held = m_registry.heldUnits();
    ASSERT_EQ(held.size(), 2u);
    ASSERT_EQ(held.at(1).size(), 2u);
    EXPECT_EQ(held.at(1)[0].unitIndex, std::min(first.unitIndex, third.unitIndex));
    EXPECT_EQ(held.at(1)[1].unitIndex, std::max(first.unitIndex, third.unitIndex));
    ASSERT_EQ(held.at(2).size(), 1u);
    EXPECT_EQ(held.at(2)[0].jobId, 1u);
    EXPECT_EQ(held.at(2)[0].unitIndex, second.unitIndex);

    m_registry.recordMerge(1, 1000, 3000, 2.0);
    m_registry.recordMerge(1, 1000, 1000, -1.0);  // a negative render time is not counted
    m_registry.recordMerge(9, 1, 1, 1.0);         // an unknown worker: nothing
    const v1::WorkerInfo info = m_registry.info(1, *m_registry.find(1));
    EXPECT_EQ(info.units_merged(), 2u);
    EXPECT_DOUBLE_EQ(info.samples_per_second(), 1000.0);
    EXPECT_DOUBLE_EQ(info.rays_per_second(), 2000.0);
    EXPECT_EQ(info.leases(), 2u);
    EXPECT_EQ(m_registry.info(2, *m_registry.find(2)).samples_per_second(), 0.0);
}

}  // namespace
}  // namespace alphorn::coordinator
