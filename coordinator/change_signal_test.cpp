// The job change signal WatchJob waits on: a waiter wakes on a change, on the end and on close,
// and otherwise returns at its deadline with the version it had.
#include "coordinator/change_signal.h"

#include <gtest/gtest.h>

#include <future>
#include <thread>

namespace alphorn::coordinator {
namespace {

using namespace std::chrono_literals;
using SteadyClock = std::chrono::steady_clock;

// Far enough that a waiter that returns was woken, not stopped by its deadline.
constexpr auto kLongWait = 10s;

TEST(ChangeSignal, AWaiterTimesOutWithTheVersionItSaw) {
    ChangeSignal signal;
    const ChangeSignal::Seen before = signal.current();
    const ChangeSignal::Seen after =
        signal.waitForChange(before.version, SteadyClock::now() + 20ms);
    EXPECT_EQ(after.version, before.version);
    EXPECT_FALSE(after.ended);
    EXPECT_FALSE(after.closed);
    EXPECT_FALSE(signal.waitForEnd(SteadyClock::now() + 20ms).ended);
}

TEST(ChangeSignal, AWaiterWakesOnAChange) {
    ChangeSignal signal;
    const uint64_t seen = signal.current().version;
    auto waiter = std::async(std::launch::async, [&] {
        return signal.waitForChange(seen, SteadyClock::now() + kLongWait);
    });
    std::this_thread::sleep_for(10ms);  // usually inside the wait; either way it must return
    signal.notify(false);
    ASSERT_EQ(waiter.wait_for(kLongWait / 2), std::future_status::ready);
    const ChangeSignal::Seen woken = waiter.get();
    EXPECT_GT(woken.version, seen);
    EXPECT_FALSE(woken.ended);
    // A change before the wait is not lost: the wait returns at once.
    EXPECT_EQ(signal.waitForChange(seen, SteadyClock::now() + kLongWait).version, woken.version);
}

TEST(ChangeSignal, AnEndWakesAWaiterForTheEndButAChangeDoesNot) {
    ChangeSignal signal;
    signal.notify(false);
    EXPECT_FALSE(signal.waitForEnd(SteadyClock::now() + 20ms).ended)
        << "a change that is not the end ended the wait";
    auto waiter = std::async(std::launch::async,
                             [&] { return signal.waitForEnd(SteadyClock::now() + kLongWait); });
    std::this_thread::sleep_for(10ms);
    signal.notify(true);
    ASSERT_EQ(waiter.wait_for(kLongWait / 2), std::future_status::ready);
    EXPECT_TRUE(waiter.get().ended);
    signal.notify(false);  // a retried job runs again
    EXPECT_FALSE(signal.current().ended);
}

TEST(ChangeSignal, CloseWakesEveryWaiterForGood) {
    ChangeSignal signal;
    const uint64_t seen = signal.current().version;
    auto change = std::async(std::launch::async, [&] {
        return signal.waitForChange(seen, SteadyClock::now() + kLongWait);
    });
    auto end = std::async(std::launch::async,
                          [&] { return signal.waitForEnd(SteadyClock::now() + kLongWait); });
    std::this_thread::sleep_for(10ms);
    signal.close();
    ASSERT_EQ(change.wait_for(kLongWait / 2), std::future_status::ready);
    ASSERT_EQ(end.wait_for(kLongWait / 2), std::future_status::ready);
    EXPECT_TRUE(change.get().closed);
    EXPECT_TRUE(end.get().closed);
    EXPECT_TRUE(signal.waitForChange(seen, SteadyClock::now() + kLongWait).closed);
}

}  // namespace
}  // namespace alphorn::coordinator
