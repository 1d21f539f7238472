#include <gtest/gtest.h>

#include "saccade/node.hpp"
#include "saccade/stats.hpp"

namespace saccade {
namespace {

TEST(Histogram, PercentilesWithinABucket) {
  Histogram h;
  for (int i = 1; i <= 1000; ++i) h.record(i * 1000);  // 1 us .. 1 ms
  EXPECT_EQ(h.count(), 1000u);
  EXPECT_EQ(h.max(), 1'000'000);
  EXPECT_NEAR(static_cast<double>(h.percentile(0.5)), 500'000.0, 500'000.0 * 0.13);
  EXPECT_NEAR(static_cast<double>(h.percentile(0.99)), 990'000.0, 990'000.0 * 0.13);
  EXPECT_LE(h.percentile(1.0), h.max());
  EXPECT_DOUBLE_EQ(h.mean(), 500'500.0);
}

TEST(Histogram, BucketsAreMonotonic) {
  int last = -1;
  for (int64_t v = 1; v < (int64_t{1} << 40); v = v * 5 / 4 + 1) {
    int b = Histogram::bucket_of(v);
    EXPECT_GE(b, last);
    EXPECT_GE(Histogram::upper_edge(b), v);
    last = b;
  }
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
  EXPECT_NE(table.find("cam"), std::string::npos);
  EXPECT_NE(table.find("image=2"), std::string::npos);
  std::string json = format_stats_json({&a}, 1.0);
  EXPECT_NE(json.find("\"name\": \"cam\""), std::string::npos);
  EXPECT_NE(json.find("\"dropped\": 2"), std::string::npos);
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
  EXPECT_NE(json.find("\"counters\": {\"lost\": 3, \"unreadable\": 1}"), std::string::npos) << json;
  const std::string table = format_stats_table({&stats}, 1.0);
  EXPECT_NE(table.find("lost:3 unreadable:1"), std::string::npos) << table;
  Histogram& delay = ctx.timing("cause_to_effect");
  delay.record(2'000'000);
  EXPECT_EQ(&ctx.timing("cause_to_effect"), &delay);
  const std::string timed = format_stats_json({&stats}, 1.0);
  EXPECT_NE(timed.find("\"timings_ns\": {\"cause_to_effect\": {\"count\": 1"), std::string::npos) << timed;
  EXPECT_NE(format_stats_table({&stats}, 1.0).find("cause_to_effect:"), std::string::npos);
  slot.stats = nullptr;
  EXPECT_THROW(ctx.counter("lost"), std::logic_error) << "nowhere to count";
  EXPECT_THROW(ctx.timing("cause_to_effect"), std::logic_error);
}

}  // namespace
}  // namespace saccade
