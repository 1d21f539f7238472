#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>

#include "saccade/node.hpp"
#include "saccade/stats.hpp"

namespace saccade {
namespace {

TEST(Histogram, PercentilesAreExactSamples) {
  Histogram h;
  // 1 us .. 1 ms in a scrambled order (7919 is prime to 1000).
  for (int i = 0; i < 1000; ++i) h.record((i * 7919 % 1000 + 1) * 1000);
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_EQ(h.max(), 1'000'000);
  EXPECT_EQ(h.percentile(0.5), 500'000) << "nearest rank: the 500th smallest";
  EXPECT_EQ(h.percentile(0.99), 990'000);
  EXPECT_EQ(h.percentile(1.0), 1'000'000);
  EXPECT_EQ(h.percentile(0.0), 1'000) << "the smallest";
  EXPECT_EQ(h.percentile(0.0015), 2'000) << "rank ceil(1.5) = 2";
  EXPECT_DOUBLE_EQ(h.mean(), 500'500.0);
}

TEST(Histogram, OddCountsAndEmpty) {
  Histogram h;
  EXPECT_EQ(h.percentile(0.5), 0);
  for (int64_t v : {7, 3, 5}) h.record(v);
  EXPECT_EQ(h.percentile(0.5), 5) << "the median of three";
  EXPECT_EQ(h.percentile(0.99), 7);
}

TEST(Histogram, PercentilesFollowTheMostRecentWindow) {
  Histogram h;
  const auto window = static_cast<int64_t>(Histogram::kWindow);
  for (int64_t i = 0; i < window; ++i) h.record(1'000'000);  // a slow start, then pushed out
  for (int64_t i = 1; i <= window; ++i) h.record(i);
  EXPECT_EQ(h.count(), 2 * Histogram::kWindow);
  EXPECT_EQ(h.percentile(0.5), window / 2);
  EXPECT_EQ(h.percentile(0.99), static_cast<int64_t>(std::ceil(0.99 * static_cast<double>(window))));
  EXPECT_EQ(h.max(), 1'000'000) << "max and mean are over every sample";
  EXPECT_DOUBLE_EQ(h.mean(), (1e6 * static_cast<double>(window) + static_cast<double>(window) * (window + 1) / 2.0) /
                                 (2.0 * static_cast<double>(window)));
}

TEST(Stats, TableAndJsonNameEveryNode) {
  NodeStats a;
  a.name = "cam";
  a.plugin = "capture.video";
  a.processed = 3;
  auto in = std::make_unique<InputStats>();
  in->name = "image";
  in->dropped = 2;
  a.inputs.push_back(std::move(in));
  std::string table = format_stats_table({&a}, 1.0);
  EXPECT_THAT(table, ::testing::HasSubstr("cam"));
  EXPECT_THAT(table, ::testing::HasSubstr("image=2"));
  std::string json = format_stats_json({&a}, 1.0);
  EXPECT_THAT(json, ::testing::HasSubstr("\"name\": \"cam\""));
  EXPECT_THAT(json, ::testing::HasSubstr("\"dropped\": 2"));
}

TEST(Stats, ANodesOwnCountersAndTimingsAreRegisteredOnceAndReported) {
  NodeStats stats;
  stats.name = "sub";
  stats.plugin = "dds.subscribe";
  Contract contract("counts");
  Params params;
  NodeSlot slot;
  slot.name = "sub";
  slot.contract = &contract;
  slot.params = &params;
  slot.stats = &stats;
  OpenContext ctx(slot);
  std::atomic<uint64_t>& lost = ctx.counter("lost");
  lost.fetch_add(3);
  EXPECT_EQ(&ctx.counter("lost"), &lost) << "the same name is the same counter";
  ctx.counter("unreadable").fetch_add(1);
  ASSERT_EQ(stats.counters.size(), 2u);
  const std::string json = format_stats_json({&stats}, 1.0);
  EXPECT_THAT(json, ::testing::HasSubstr("\"counters\": {\"lost\": 3, \"unreadable\": 1}"));
  const std::string table = format_stats_table({&stats}, 1.0);
  EXPECT_THAT(table, ::testing::HasSubstr("lost:3 unreadable:1"));
  Histogram& delay = ctx.timing("cause_to_effect");
  delay.record(2'000'000);
  EXPECT_EQ(&ctx.timing("cause_to_effect"), &delay);
  const std::string timed = format_stats_json({&stats}, 1.0);
  EXPECT_THAT(timed, ::testing::HasSubstr("\"timings_ns\": {\"cause_to_effect\": {\"count\": 1"));
  EXPECT_THAT(format_stats_table({&stats}, 1.0), ::testing::HasSubstr("cause_to_effect:"));
  slot.stats = nullptr;
  EXPECT_THROW(ctx.counter("lost"), std::logic_error) << "nowhere to count";
  EXPECT_THROW(ctx.timing("cause_to_effect"), std::logic_error);
}

}  // namespace
}  // namespace saccade
