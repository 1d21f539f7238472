#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "saccade/contract.hpp"
#include "saccade/node.hpp"
#include "saccade/params.hpp"

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
  EXPECT_TRUE(parse_param(spec(ParamType::kInt), "42", v).ok());
  EXPECT_EQ(std::get<int64_t>(v), 42);
  EXPECT_TRUE(parse_param(spec(ParamType::kInt), " -7 ", v).ok());
  EXPECT_EQ(std::get<int64_t>(v), -7);
  for (const char* bad : {"12abc", "", "3.5", "0x10", "99999999999999999999", "1 2"})
    EXPECT_FALSE(parse_param(spec(ParamType::kInt), bad, v).ok()) << bad;
}

TEST(Params, DoublesRejectTrailingGarbageAndNonFinite) {
  ParamValue v;
  EXPECT_TRUE(parse_param(spec(ParamType::kDouble), "2.5e-3", v).ok());
  EXPECT_DOUBLE_EQ(std::get<double>(v), 2.5e-3);
  for (const char* bad : {"3.5x", "inf", "nan", "1e999", ""})
    EXPECT_FALSE(parse_param(spec(ParamType::kDouble), bad, v).ok()) << bad;
}

TEST(Params, RangesAreInclusive) {
  ParamValue v;
  auto s = spec(ParamType::kInt, 1, 16);
  EXPECT_TRUE(parse_param(s, "1", v).ok());
  EXPECT_TRUE(parse_param(s, "16", v).ok());
  const Status err = parse_param(s, "17", v);
  ASSERT_FALSE(err.ok());
  EXPECT_THAT(err.message(), ::testing::HasSubstr("out of range [1, 16]"));
}

TEST(Params, BoolsSizesPointsEnumsFlags) {
  ParamValue v;
  EXPECT_TRUE(parse_param(spec(ParamType::kBool), "yes", v).ok());
  EXPECT_TRUE(std::get<bool>(v));
  EXPECT_FALSE(parse_param(spec(ParamType::kBool), "maybe", v).ok());
  EXPECT_TRUE(parse_param(spec(ParamType::kSize, 0, 1e6), "32x24", v).ok());
  EXPECT_EQ(std::get<cv::Size>(v), cv::Size(32, 24));
  EXPECT_FALSE(parse_param(spec(ParamType::kSize, 0, 1e6), "32x", v).ok());
  EXPECT_FALSE(parse_param(spec(ParamType::kSize, 0, 1e6), "-3x4", v).ok());
  EXPECT_TRUE(parse_param(spec(ParamType::kPoint), "320.5, 240", v).ok());
  EXPECT_EQ(std::get<cv::Point2d>(v), cv::Point2d(320.5, 240));
  EXPECT_FALSE(parse_param(spec(ParamType::kPoint), "320", v).ok());
  auto e = spec(ParamType::kEnum, {}, {}, {"a", "b"});
  EXPECT_TRUE(parse_param(e, "b", v).ok());
  EXPECT_FALSE(parse_param(e, "c", v).ok());
  auto f = spec(ParamType::kFlags, {}, {}, {"x", "y", "z"});
  EXPECT_TRUE(parse_param(f, "z, x,x", v).ok());
  EXPECT_EQ(std::get<std::vector<std::string>>(v), (std::vector<std::string>{"z", "x"}));
  EXPECT_TRUE(parse_param(f, "all", v).ok());
  EXPECT_EQ(std::get<std::vector<std::string>>(v).size(), 3u);
  EXPECT_FALSE(parse_param(f, "x,w", v).ok());
}

TEST(Params, WrongNameOrTypeThrowsInsideThePlugin) {
  Params p;
  p.set("n", int64_t{3});
  EXPECT_EQ(p.get_int("n"), 3);
  EXPECT_THROW(p.get_double("n"), std::logic_error);
  EXPECT_THROW(p.get_int("m"), std::logic_error);
}

// A configuration struct as an algorithm would have it, with a nested part.
enum class Shape { kRound, kSquare };
struct Inner {
  float rate = 0.1f;
  cv::Size size{12, 10};
};
struct Sample {
  int window = 5;
  double gain = 0.123456789012;  // survives its own text only when written exactly
  bool enabled = true;
  Shape shape = Shape::kSquare;
  bool lock_on_motion = false;
  std::string label = "x";
  Inner inner;
};

void bind_sample(ParamBinder<Sample>& b) {
  b.field("window", {3, 9}, "odd window", &Sample::window)
      .field("gain", {0, 1}, "gain", &Sample::gain)
      .field("enabled", "on or off", &Sample::enabled)
      .field("shape", {{"round", Shape::kRound}, {"square", Shape::kSquare}}, "shape", &Sample::shape)
      .field("lock_on", {{"moving", true}, {"salient", false}}, "a bool with names", &Sample::lock_on_motion)
      .field("label", "text", &Sample::label)
      .field("rate", {0, 1}, "nested float", &Sample::inner, &Inner::rate)
      .field("size", "nested size", &Sample::inner, &Inner::size);
}

TEST(ParamBinder, ContractTakesEveryDefaultFromTheStruct) {
  const Contract c = Contract("sample").params(&bind_sample);
  EXPECT_TRUE(c.problems().empty()) << c.problems().front();
  ASSERT_EQ(c.params().size(), 8u);
  for (const ParamSpec& p : c.params()) EXPECT_TRUE(p.bound) << p.name;
  EXPECT_EQ(c.find_param("window")->default_value, "5");
  EXPECT_EQ(c.find_param("window")->type, ParamType::kInt);
  EXPECT_EQ(*c.find_param("window")->max, 9);
  EXPECT_EQ(c.find_param("gain")->default_value, "0.123456789012");
  EXPECT_EQ(c.find_param("enabled")->default_value, "true");
  EXPECT_EQ(c.find_param("shape")->default_value, "square");
  EXPECT_EQ(c.find_param("shape")->choices, (std::vector<std::string>{"round", "square"}));
  EXPECT_EQ(c.find_param("lock_on")->default_value, "salient");
  EXPECT_EQ(c.find_param("label")->default_value, "x");
  EXPECT_EQ(c.find_param("rate")->type, ParamType::kDouble);
  EXPECT_EQ(c.find_param("rate")->default_value, "0.1") << "a float's default as the float's own text";
  EXPECT_EQ(c.find_param("size")->default_value, "12x10");
}

TEST(ParamBinder, ConfigIsFilledFromTheNodesParameters) {
  const Contract contract = Contract("sample").params(&bind_sample);
  Params params;
  for (const ParamSpec& p : contract.params()) {
    ParamValue v;
    ASSERT_TRUE(parse_param(p, p.default_value, v).ok()) << p.name;
    params.set(p.name, v);
  }
  params.set("window", int64_t{7});
  params.set("shape", std::string("round"));
  params.set("lock_on", std::string("moving"));
  params.set("rate", 0.5);
  params.set("size", cv::Size(4, 3));
  NodeSlot slot;
  slot.params = &params;
  slot.contract = &contract;
  const Sample s = OpenContext(slot).config(&bind_sample);
  EXPECT_EQ(s.window, 7);
  EXPECT_DOUBLE_EQ(s.gain, 0.123456789012);
  EXPECT_TRUE(s.enabled);
  EXPECT_EQ(s.shape, Shape::kRound);
  EXPECT_TRUE(s.lock_on_motion);
  EXPECT_EQ(s.label, "x");
  EXPECT_FLOAT_EQ(s.inner.rate, 0.5f);
  EXPECT_EQ(s.inner.size, cv::Size(4, 3));
}

TEST(ParamBinder, ConfigureSetsAStructByItsNodesParameterNames) {
  const Result<Sample> s = configure(&bind_sample, {{"window", "7"}, {"shape", "round"}, {"size", "4x3"}});
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(s->window, 7);
  EXPECT_EQ(s->shape, Shape::kRound);
  EXPECT_EQ(s->inner.size, cv::Size(4, 3));
  EXPECT_DOUBLE_EQ(s->gain, 0.123456789012) << "the rest at the struct's defaults";
  EXPECT_EQ(s->label, "x");
}

TEST(ParamBinder, ConfigureNamesTheSettingThatDoesNotFit) {
  EXPECT_THAT(configure(&bind_sample, {{"windwo", "7"}}).error(),
              ::testing::AllOf(::testing::HasSubstr("unknown parameter 'windwo'"), ::testing::HasSubstr("window")));
  EXPECT_THAT(configure(&bind_sample, {{"window", "11"}}).error(),
              ::testing::AllOf(::testing::HasSubstr("'window'"), ::testing::HasSubstr("out of range")));
  EXPECT_THAT(configure(&bind_sample, {{"shape", "oval"}}).error(), ::testing::HasSubstr("'shape'"));
  EXPECT_THAT(configure(&bind_sample, {{"window", "5"}, {"window", "7"}}).error(), ::testing::HasSubstr("given twice"));
}

// A tool's --set texts: split at the first '=' (a value may hold more), one
// without any refused by name.
TEST(ParamBinder, SplitSettingsReadsNameEqualsValueTexts) {
  const auto settings = split_settings({"window=7", "label=a=b", "label2="});
  ASSERT_TRUE(settings.ok()) << settings.error();
  ASSERT_EQ(settings->size(), 3u);
  EXPECT_EQ((*settings)[0], (std::pair<std::string, std::string>{"window", "7"}));
  EXPECT_EQ((*settings)[1], (std::pair<std::string, std::string>{"label", "a=b"}));
  EXPECT_EQ((*settings)[2], (std::pair<std::string, std::string>{"label2", ""}));
  const Result<Sample> s = configure(&bind_sample, *split_settings({"window=7"}));
  ASSERT_TRUE(s.ok()) << s.error();
  EXPECT_EQ(s->window, 7);
  EXPECT_THAT(split_settings({"window=7", "window7"}).error(), ::testing::HasSubstr("'window7'"));
}

struct Broken {
  int window = 50;              // outside the range the node declares
  Shape shape = Shape::kRound;  // none of the named choices
};

void bind_broken(ParamBinder<Broken>& b) {
  b.field("window", {3, 9}, "odd window", &Broken::window)
      .field("shape", {{"square", Shape::kSquare}}, "shape", &Broken::shape);
}

TEST(ParamBinder, AStructDefaultTheContractCannotHoldIsAProblem) {
  const Contract c = Contract("broken").params(&bind_broken);
  ASSERT_EQ(c.problems().size(), 2u);
  EXPECT_THAT(c.problems()[0], ::testing::HasSubstr("'window'"));
  EXPECT_THAT(c.problems()[0], ::testing::HasSubstr("out of range"));
  EXPECT_THAT(c.problems()[1], ::testing::HasSubstr("'shape'"));
}

}  // namespace
}  // namespace saccade
