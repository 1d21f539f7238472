// Messages as JSON through the fields each type names once, read back by a
// real JSON parser (nlohmann/json, test-only), and the JSON lines sink.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include <nlohmann/json.hpp>

#include "saccade/schema.hpp"
#include "saccade/testing.hpp"

namespace saccade {
namespace {

using nlohmann::json;

template <class... T>
std::vector<MessagePtr> one_of_each(TypeList<T...>) {
  return {std::make_shared<T>()...};
}

json parse_json(const Message& m) {
  std::string text;
  append_json(text, m);
  return json::parse(text);  // throws (and fails the test) on anything but one JSON value
}

TEST(Schema, ARegionIsWrittenFieldByFieldWithItsStamp) {
  Region r;
  r.frame_id = 12;
  r.timestamp_ns = 1'700'000'000'123'456'789;
  r.origin_ns = 5;
  r.center = {10.5, -2};
  r.size = {4, 3};
  r.score = 0.25;
  r.camera_id = 1;
  r.label = "say \"hi\"\n\tand\\ \x01";
  const json j = parse_json(r);
  EXPECT_EQ(j["type"], "Region");
  EXPECT_EQ(j["frame"], 12);
  EXPECT_EQ(j["stamp_ns"], 1'700'000'000'123'456'789);
  EXPECT_EQ(j["origin_ns"], 5);
  EXPECT_EQ(j["center"]["x"], 10.5);
  EXPECT_EQ(j["center"]["y"], -2);
  EXPECT_EQ(j["size"]["width"], 4);
  EXPECT_EQ(j["score"], 0.25);
  EXPECT_EQ(j["camera_id"], 1);
  EXPECT_EQ(j["label"], r.label);
}

TEST(Schema, EnumsAreNamesNumbersExactAndNonFiniteNull) {
  FoveaState s;
  s.state = FoveaState::State::kTracking;
  s.score = 0.1 + 0.2;
  s.fovea = {std::nan(""), INFINITY};
  const json j = parse_json(s);
  EXPECT_EQ(j["state"], "tracking");
  EXPECT_EQ(j["score"].get<double>(), 0.1 + 0.2) << "shortest text that reads back exactly";
  EXPECT_TRUE(j["fovea"]["x"].is_null());
  EXPECT_TRUE(j["fovea"]["y"].is_null());

  JointState joints;
  joints.health = {JointState::Health::kReady, JointState::Health::kFault};
  joints.error_code = {0, 0x8130};
  const json k = parse_json(joints);
  EXPECT_EQ(k["health"], json::array({"ready", "fault"}));
  EXPECT_EQ(k["error_code"], json::array({0, 0x8130}));
}

TEST(Schema, MatricesAppearByShapeAndNestedStructsAsObjects) {
  Retina r;
  r.levels.assign(2, cv::Mat(24, 32, CV_8UC3));
  r.geometry.resize(2);
  r.geometry[1].region = {100, 50, 32, 24};
  r.geometry[1].step_x = 2.5;
  const json j = parse_json(r);
  EXPECT_EQ(j["levels"][0], json({{"rows", 24}, {"cols", 32}, {"depth", CV_8U}, {"channels", 3}}));
  EXPECT_EQ(j["geometry"][1]["region"]["x"], 100);
  EXPECT_EQ(j["geometry"][1]["step_x"], 2.5);
  EXPECT_EQ(j["sampling"], "five_point");

  CanFrames c;
  c.frames.resize(1);
  c.frames[0].can_id = 0x181;
  c.frames[0].length = 2;
  c.frames[0].data[1] = 200;
  const json k = parse_json(c);
  EXPECT_EQ(k["frames"][0]["can_id"], 0x181);
  EXPECT_EQ(k["frames"][0]["data"][1], 200) << "a byte as a number, not a character";
}

// Every type's JSON and its schema agree on the fields, so a field described
// once appears in both; each schema is itself valid JSON.
TEST(Schema, EveryTypesObjectsHaveExactlyTheFieldsItsSchemaLists) {
  const std::vector<MessagePtr> all = one_of_each(MessageTypes{});
  ASSERT_EQ(all.size(), described_message_types().size());
  for (const MessagePtr& m : all) {
    const std::string schema_text = json_schema(m->type_name());
    ASSERT_FALSE(schema_text.empty()) << m->type_name();
    const json schema = json::parse(schema_text);
    const json object = parse_json(*m);
    std::vector<std::string> written, listed;
    for (const auto& [key, value] : object.items()) written.push_back(key);
    for (const auto& [key, value] : schema["properties"].items()) listed.push_back(key);
    std::sort(written.begin(), written.end());
    std::sort(listed.begin(), listed.end());
    EXPECT_EQ(written, listed) << m->type_name();
    EXPECT_EQ(schema["title"], std::string(m->type_name()));
  }
  EXPECT_TRUE(json_schema("NoSuchType").empty());
}

TEST(JsonLines, TheSinkWritesOneLinePerMessage) {
  const std::string path = (std::filesystem::temp_directory_path() / "saccade_jsonl_test.jsonl").string();
  {
    auto h =
        testing::NodeHarness::create(R"(<node plugin="util.jsonl"><param name="path" value=")" + path + R"("/></node>)")
            .value_or(nullptr);
    ASSERT_NE(h, nullptr);
    for (int k = 0; k < 3; ++k) {
      auto r = std::make_shared<Region>();
      r->frame_id = k;
      r->center = {k * 1.5, 2};
      h->set("in", r);
      ASSERT_TRUE(h->process().ok());
    }
    h->node().close();
    EXPECT_EQ(h->counter("write_errors"), 0u);
  }
  std::ifstream in(path);
  std::string line;
  int k = 0;
  while (std::getline(in, line)) {
    const json j = json::parse(line);
    EXPECT_EQ(j["frame"], k);
    EXPECT_EQ(j["center"]["x"], k * 1.5);
    ++k;
  }
  EXPECT_EQ(k, 3);
  std::filesystem::remove(path);
}

TEST(JsonLines, AnUnwritablePathIsAnErrorAtOpenNamingIt) {
  // A folder that cannot be made: its parent is a file.
  const std::filesystem::path file = std::filesystem::temp_directory_path() / "saccade_jsonl_not_a_folder";
  std::ofstream(file) << "x";
  const std::string path = (file / "out.jsonl").string();
  std::string error;
  auto h_made =
      testing::NodeHarness::create(R"(<node plugin="util.jsonl"><param name="path" value=")" + path + R"("/></node>)");
  error = h_made.error();
  auto h = std::move(h_made).value_or(nullptr);
  EXPECT_EQ(h, nullptr);
  EXPECT_THAT(error, ::testing::HasSubstr(path));
  std::filesystem::remove(file);
}

TEST(JsonLines, TheFilesFolderIsMadeWhenMissing) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() / "saccade_jsonl_folder";
  std::filesystem::remove_all(folder);
  const std::string path = (folder / "deeper" / "out.jsonl").string();
  {
    auto h =
        testing::NodeHarness::create(R"(<node plugin="util.jsonl"><param name="path" value=")" + path + R"("/></node>)")
            .value_or(nullptr);
    ASSERT_NE(h, nullptr);
    h->node().close();
  }
  EXPECT_TRUE(std::filesystem::exists(path));
  std::filesystem::remove_all(folder);
}

}  // namespace
}  // namespace saccade
