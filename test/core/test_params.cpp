#include <gtest/gtest.h>

#include "saccade/contract.hpp"

namespace saccade {
namespace {

ParamSpec spec(ParamType type, std::optional<double> min = {}, std::optional<double> max = {},
               std::vector<std::string> choices = {}) {
  ParamSpec s;
  s.name = "p";
  s.type = type;
  s.min = min;
  s.max = max;
  s.choices = std::move(choices);
  return s;
}

TEST(Params, IntegersParseWholeStringsOnly) {
  ParamValue v;
  EXPECT_FALSE(parse_param(spec(ParamType::kInt), "42", v));
  EXPECT_EQ(std::get<int64_t>(v), 42);
  EXPECT_FALSE(parse_param(spec(ParamType::kInt), " -7 ", v));
  EXPECT_EQ(std::get<int64_t>(v), -7);
  for (const char* bad : {"12abc", "", "3.5", "0x10", "99999999999999999999", "1 2"})
    EXPECT_TRUE(parse_param(spec(ParamType::kInt), bad, v)) << bad;
}

TEST(Params, DoublesRejectTrailingGarbageAndNonFinite) {
  ParamValue v;
  EXPECT_FALSE(parse_param(spec(ParamType::kDouble), "2.5e-3", v));
  EXPECT_DOUBLE_EQ(std::get<double>(v), 2.5e-3);
  for (const char* bad : {"3.5x", "inf", "nan", "1e999", ""}) EXPECT_TRUE(parse_param(spec(ParamType::kDouble), bad, v)) << bad;
}

TEST(Params, RangesAreInclusive) {
  ParamValue v;
  auto s = spec(ParamType::kInt, 1, 16);
  EXPECT_FALSE(parse_param(s, "1", v));
  EXPECT_FALSE(parse_param(s, "16", v));
  auto err = parse_param(s, "17", v);
  ASSERT_TRUE(err);
  EXPECT_NE(err->find("out of range [1, 16]"), std::string::npos);
}

TEST(Params, BoolsSizesPointsEnumsFlags) {
  ParamValue v;
  EXPECT_FALSE(parse_param(spec(ParamType::kBool), "yes", v));
  EXPECT_TRUE(std::get<bool>(v));
  EXPECT_TRUE(parse_param(spec(ParamType::kBool), "maybe", v));
  EXPECT_FALSE(parse_param(spec(ParamType::kSize, 0, 1e6), "32x24", v));
  EXPECT_EQ(std::get<cv::Size>(v), cv::Size(32, 24));
  EXPECT_TRUE(parse_param(spec(ParamType::kSize, 0, 1e6), "32x", v));
  EXPECT_TRUE(parse_param(spec(ParamType::kSize, 0, 1e6), "-3x4", v));
  EXPECT_FALSE(parse_param(spec(ParamType::kPoint), "320.5, 240", v));
  EXPECT_EQ(std::get<cv::Point2d>(v), cv::Point2d(320.5, 240));
  EXPECT_TRUE(parse_param(spec(ParamType::kPoint), "320", v));
  auto e = spec(ParamType::kEnum, {}, {}, {"a", "b"});
  EXPECT_FALSE(parse_param(e, "b", v));
  EXPECT_TRUE(parse_param(e, "c", v));
  auto f = spec(ParamType::kFlags, {}, {}, {"x", "y", "z"});
  EXPECT_FALSE(parse_param(f, "z, x,x", v));
  EXPECT_EQ(std::get<std::vector<std::string>>(v), (std::vector<std::string>{"z", "x"}));
  EXPECT_FALSE(parse_param(f, "all", v));
  EXPECT_EQ(std::get<std::vector<std::string>>(v).size(), 3u);
  EXPECT_TRUE(parse_param(f, "x,w", v));
}

TEST(Params, WrongNameOrTypeThrowsInsideThePlugin) {
  Params p;
  p.set("n", int64_t{3});
  EXPECT_EQ(p.get_int("n"), 3);
  EXPECT_THROW(p.get_double("n"), std::logic_error);
  EXPECT_THROW(p.get_int("m"), std::logic_error);
}

}  // namespace
}  // namespace saccade
