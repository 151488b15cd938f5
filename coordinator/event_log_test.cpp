// The job event log: sequence numbers, the bound (first events and the most recent ones kept,
// the rest counted as dropped), cut messages, and a stored log read back.
#include "coordinator/event_log.h"

#include <gtest/gtest.h>

namespace alphorn::coordinator {
namespace {

TEST(EventLog, NumbersEventsAndReturnsThoseAfterASequence) {
    EventLog log;
    log.add(100, v1::JOB_EVENT_SUBMITTED, "cbox");
    log.add(101, v1::JOB_EVENT_LEASED, "lease 9", 4, 17);
    log.add(102, v1::JOB_EVENT_FAILED, "worker 4: out of memory", 4, 17);
    const auto all = log.after(0);
    ASSERT_EQ(all.size(), 3u);
    EXPECT_EQ(all[0].sequence(), 1u);
    EXPECT_EQ(all[0].kind(), v1::JOB_EVENT_SUBMITTED);
    EXPECT_FALSE(all[0].has_unit());
    EXPECT_EQ(all[1].worker_id(), 4u);
    EXPECT_TRUE(all[1].has_unit());
    EXPECT_EQ(all[1].unit_index(), 17u);
    EXPECT_EQ(all[2].message(), "worker 4: out of memory");
    EXPECT_DOUBLE_EQ(all[2].time_unix_seconds(), 102);
    const auto later = log.after(2);
    ASSERT_EQ(later.size(), 1u);
    EXPECT_EQ(later[0].sequence(), 3u);
}

TEST(EventLog, KeepsTheFirstAndTheMostRecentEventsWithinItsBound) {
    EventLog log;
    const size_t total = EventLog::kMaxEvents * 3 + 7;
    for (size_t i = 0; i < total; ++i) log.add(double(i), v1::JOB_EVENT_MERGED, "", 1, uint32_t(i));
    EXPECT_EQ(log.size(), EventLog::kMaxEvents);
    EXPECT_EQ(log.dropped(), total - EventLog::kMaxEvents);
    const auto kept = log.after(0);
    ASSERT_EQ(kept.size(), EventLog::kMaxEvents);
    // The head: events 1..kHeadEvents; then the newest ones, contiguous up to the last.
    for (size_t i = 0; i < EventLog::kHeadEvents; ++i) EXPECT_EQ(kept[i].sequence(), i + 1);
    EXPECT_EQ(kept.back().sequence(), total);
    for (size_t i = EventLog::kHeadEvents + 1; i < kept.size(); ++i)
        EXPECT_EQ(kept[i].sequence(), kept[i - 1].sequence() + 1);
    EXPECT_EQ(kept[EventLog::kHeadEvents].sequence(),
              total - (EventLog::kMaxEvents - EventLog::kHeadEvents) + 1);
}

TEST(EventLog, CutsLongMessages) {
    EventLog log;
    log.add(0, v1::JOB_EVENT_FAILED, std::string(EventLog::kMaxMessageBytes * 5, 'x'));
    const std::string message = log.after(0).at(0).message();
    EXPECT_LE(message.size(), EventLog::kMaxMessageBytes + 10);
    EXPECT_NE(message.find("[cut]"), std::string::npos);
}

TEST(EventLog, AStoredLogReadsBackTheSameAndGoesOnNumbering) {
    EventLog log;
    for (int i = 0; i < 1200; ++i) log.add(i, v1::JOB_EVENT_LEASED, "", 2, uint32_t(i));
    EXPECT_TRUE(log.changed());
    log.markSaved();
    EXPECT_FALSE(log.changed());
    const v1::JobEventLog stored = log.record();
    EventLog back(stored);
    EXPECT_FALSE(back.changed());
    EXPECT_EQ(back.dropped(), log.dropped());
    EXPECT_EQ(back.record().SerializeAsString(), stored.SerializeAsString());
    back.add(5000, v1::JOB_EVENT_FINISHED, "done");
    EXPECT_TRUE(back.changed());
    EXPECT_EQ(back.after(1200).at(0).sequence(), 1201u);
    EXPECT_EQ(back.size(), EventLog::kMaxEvents);
}

}  // namespace
}  // namespace alphorn::coordinator
