// Plugin loading and its failures, on real .so files.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <dlfcn.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <optional>

#include "saccade/plugin.hpp"
#include "saccade/testing.hpp"
#include "support.hpp"

namespace saccade {
namespace {

std::string test_plugin(const std::string& name) { return std::string(SACCADE_TEST_PLUGIN_DIR) + "/" + name; }

bool mapped(const std::string& path) {
  std::ifstream maps("/proc/self/maps");
  std::string line;
  while (std::getline(maps, line))
    if (line.find(path) != std::string::npos) return true;
  return false;
}

TEST(Registry, LoadsEveryBuiltPluginWithContracts) {
  Registry r;
  r.load_folders(Registry::default_search_path());
  EXPECT_TRUE(r.load_errors().empty());
  for (const char* type :
       {"capture.video", "capture.synthetic", "retina", "filters.bank", "snapshot", "util.passthrough"})
    EXPECT_NE(r.find(type), nullptr) << type;
  const NodeTypeInfo* retina = r.find("retina");
  ASSERT_NE(retina, nullptr);
  EXPECT_EQ(retina->contract.inputs().at(0).name, "image");
  EXPECT_EQ(retina->contract.find_param("levels")->default_value, "5");
}

// Every parameter bound to an algorithm's field takes its default from that
// field (ParamBinder); the registry refuses a contract whose defaults do not
// read back as the struct's values. Here, over every built plugin: nothing
// refused, and every default of every node parses within its own range.
TEST(Registry, EveryContractsDefaultsAreTheAlgorithmsAndParse) {
  Registry r;
  r.load_folders(Registry::default_search_path());
  for (const std::string& e : r.load_errors()) ADD_FAILURE() << e;
  std::size_t bound = 0;
  for (const std::string& type : r.types()) {
    const Contract& c = r.find(type)->contract;
    EXPECT_TRUE(c.problems().empty()) << type;
    for (const ParamSpec& p : c.params()) {
      bound += p.bound ? 1 : 0;
      if (p.required || (p.type == ParamType::kPoint && p.default_value.empty())) continue;
      ParamValue v;
      const Status parsed = parse_param(p, p.default_value, v);
      EXPECT_TRUE(parsed.ok()) << type << "." << p.name << " = '" << p.default_value << "': " << parsed.message();
    }
  }
  EXPECT_GT(bound, 100u) << "the nodes' parameters are bound to their algorithms' fields";
}

// The guide's whole-plugin example (test/test_plugins/threshold.cpp), as a
// user would test it.
TEST(GuideExample, ThresholdPluginBindsItsParametersAndThresholdsEveryLevel) {
  Registry r;
  ASSERT_TRUE(r.load_library(test_plugin("saccade_example.so")).ok());
  const Contract& c = r.find("example.threshold")->contract;
  EXPECT_EQ(c.find_param("level")->default_value, "128");
  EXPECT_EQ(c.find_param("invert")->default_value, "false");
  auto h =
      testing::NodeHarness::create(
          R"(<node plugin="example.threshold"><param name="level" value="100"/><param name="invert" value="true"/></node>)",
          &r)
          .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto retina = std::make_shared<Retina>();
  retina->levels = {cv::Mat(24, 32, CV_8U, cv::Scalar(50)), cv::Mat(24, 32, CV_8U, cv::Scalar(150))};
  retina->geometry.resize(2);
  h->set("retina", retina);
  ASSERT_TRUE(h->process().ok());
  auto out = h->last<Retina>("binary");
  ASSERT_NE(out, nullptr);
  EXPECT_EQ(cv::countNonZero(out->levels[0]), 32 * 24) << "darker than 100, inverted";
  EXPECT_EQ(cv::countNonZero(out->levels[1]), 0);
}

TEST(Registry, MissingLibraryNamesTheFile) {
  Registry r;
  const std::string error = r.load_library(test_plugin("saccade_nothere.so")).message();
  EXPECT_FALSE(error.empty());
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_nothere.so: no such plugin library"));
}

TEST(Registry, NotAnElfFileNamesTheFile) {
  Registry r;
  const std::string error = r.load_library(test_plugin("saccade_garbage.so")).message();
  EXPECT_FALSE(error.empty());
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_garbage.so: cannot load"));
  EXPECT_THAT(error, ::testing::Not(::testing::HasSubstr("Bad file descriptor")));
}

TEST(Registry, MissingEntryNamesTheSymbol) {
  Registry r;
  const std::string error = r.load_library(test_plugin("saccade_noentry.so")).message();
  EXPECT_FALSE(error.empty());
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_noentry.so: no symbol 'saccade_plugin_entry'"));
}

TEST(Registry, AbiMismatchIsRefusedBeforeAnythingIsCreated) {
  Registry r;
  const std::string error = r.load_library(test_plugin("saccade_badabi.so")).message();
  EXPECT_FALSE(error.empty());
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_badabi.so: symbol 'saccade_plugin_entry': ABI mismatch"));
  EXPECT_THAT(error, ::testing::HasSubstr("abi 999"));
  EXPECT_TRUE(r.types().empty());
}

TEST(Registry, MissingSymbolFailsAtLoadNotAtFirstCall) {
  Registry r;
  const std::string error = r.load_library(test_plugin("saccade_missingsym.so")).message();
  EXPECT_FALSE(error.empty());
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_missingsym.so: cannot load"));
  EXPECT_THAT(error, ::testing::HasSubstr("saccade_symbol_that_does_not_exist"));
}

TEST(Registry, FolderScanCollectsFailuresAndKeepsTheGoodOnes) {
  Registry r;
  r.load_folders({SACCADE_TEST_PLUGIN_DIR});
  EXPECT_NE(r.find("good.echo"), nullptr);
  EXPECT_EQ(r.load_errors().size(), 4u);  // garbage, noentry, badabi, missingsym
}

TEST(Registry, UnknownPluginInAGraphMentionsItsBrokenLibrary) {
  Registry r;
  r.load_folders({SACCADE_TEST_PLUGIN_DIR});
  Diagnostics diag;
  GraphDecl decl = load_graph_string("<graph><node name=\"b\" plugin=\"badabi.x\"/></graph>", "g.xml", diag);
  resolve_graph(decl, r, diag);
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("its library failed to load"));
}

TEST(Registry, NodeKeepsItsLibraryLoadedAfterTheRegistryIsGone) {
  const std::string path = test_plugin("saccade_good.so");
  std::shared_ptr<Node> node;
  {
    Registry r;
    ASSERT_TRUE(r.load_library(path).ok());
    Result<std::shared_ptr<Node>> created = r.create("good.echo");
    ASSERT_TRUE(created.ok()) << created.error();
    node = std::move(created).value();
  }
  // The registry and its handle are gone; the node's deleter still holds the
  // library (built with -fno-gnu-unique, so nothing else pins it).
  ASSERT_TRUE(mapped(path));
  void* self = dlopen(path.c_str(), RTLD_NOW | RTLD_NOLOAD);
  ASSERT_NE(self, nullptr);
  auto live = reinterpret_cast<int (*)()>(dlsym(self, "saccade_good_live_nodes"));
  ASSERT_NE(live, nullptr);
  EXPECT_EQ(live(), 1);
  dlclose(self);
  // The node still works.
  Contract c = Contract().input<Message>("in", "").output<Message>("out", "");
  Params params;
  NodeSlot slot;
  slot.name = "n";
  slot.contract = &c;
  slot.params = &params;
  slot.current.resize(1);
  slot.pools.resize(1);
  slot.input_connected = {true};
  slot.output_connected = {true};
  struct Sink : EmitSink {
    int emitted = 0;
    void emit(int, MessagePtr) override { ++emitted; }
    bool stop_requested() const override { return false; }
    bool sleep_until(int64_t) override { return true; }
  } sink;
  slot.sink = &sink;
  OpenContext oc(slot);
  ASSERT_TRUE(node->open(oc).ok());
  slot.current[0] = std::make_shared<Region>();
  ProcessContext pc(slot);
  EXPECT_TRUE(node->process(pc).ok());
  EXPECT_EQ(sink.emitted, 1);
  node.reset();
  EXPECT_FALSE(mapped(path)) << "the library should unload with its last node";
}

// Plugin folders: where they are looked for, what is skipped and why.

namespace fs = std::filesystem;

// A fresh folder under the build tree, removed with the object.
struct ScratchFolder {
  explicit ScratchFolder(const std::string& name) : path(std::string(SACCADE_BINARY_DIR) + "/" + name) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchFolder() { fs::remove_all(path); }
  std::string path;
};

// The value of an environment variable for one scope.
struct ScopedEnv {
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* old = std::getenv(name)) old_ = old;
    if (value)
      setenv(name, value, 1);
    else
      unsetenv(name);
  }
  ~ScopedEnv() {
    if (old_)
      setenv(name_, old_->c_str(), 1);
    else
      unsetenv(name_);
  }
  const char* name_;
  std::optional<std::string> old_;
};

TEST(RegistrySearch, BundledPluginsAreFoundBesideLibsaccadeNotAtAFixedPath) {
  // Run from the build tree: its plugins/ folder. (Installed, <libdir>/saccade/plugins
  // beside libsaccade.so: the sdk.out_of_tree_example test runs the installed command.)
  const std::string bundled = Registry::bundled_plugin_dir();
  ASSERT_FALSE(bundled.empty());
  EXPECT_TRUE(fs::equivalent(bundled, std::string(SACCADE_BINARY_DIR) + "/plugins")) << bundled;
}

TEST(RegistrySearch, PluginPathThenEnvironmentThenTheBundledFolder) {
  ScopedEnv env("SACCADE_PLUGIN_PATH", "/env/a::/env/b");
  const std::vector<std::string> expected = {"/cli/x", "/cli/y", "/env/a", "/env/b", Registry::bundled_plugin_dir()};
  EXPECT_EQ(Registry::default_search_path("/cli/x:/cli/y"), expected);
  ScopedEnv unset("SACCADE_PLUGIN_PATH", nullptr);
  EXPECT_EQ(Registry::default_search_path(), std::vector<std::string>{Registry::bundled_plugin_dir()});
}

TEST(RegistrySearch, ALibraryNotNamedSaccadeIsSkippedWithAWarningSayingWhy) {
  ScratchFolder dir("registry_search_misnamed");
  fs::copy_file(test_plugin("saccade_good.so"), dir.path + "/libgood.so");
  fs::copy_file(test_plugin("saccade_good.so"), dir.path + "/good.so.1");
  std::ofstream(dir.path + "/README.txt") << "not a library: no warning\n";
  Registry r;
  r.load_folders({dir.path});
  EXPECT_EQ(r.find("good.echo"), nullptr);
  ASSERT_EQ(r.warnings().size(), 2u);
  for (const std::string& w : r.warnings())
    EXPECT_THAT(w, ::testing::HasSubstr(": skipped: a plugin library's file name must be saccade_<name>.so"));
  EXPECT_TRUE(r.warnings()[0].find("libgood.so") != std::string::npos ||
              r.warnings()[1].find("libgood.so") != std::string::npos);
  EXPECT_TRUE(r.load_errors().empty());
}

TEST(RegistrySearch, ALibraryShadowedByAnEarlierFolderIsAWarningNamingBoth) {
  ScratchFolder dir("registry_search_shadow");
  fs::copy_file(test_plugin("saccade_good.so"), dir.path + "/saccade_good.so");
  Registry r;
  r.load_folders({dir.path, SACCADE_TEST_PLUGIN_DIR});
  ASSERT_NE(r.find("good.echo"), nullptr);
  EXPECT_EQ(r.find("good.echo")->library, dir.path + "/saccade_good.so");
  ASSERT_EQ(r.warnings().size(), 1u);
  EXPECT_THAT(r.warnings()[0], ::testing::HasSubstr(test_plugin("saccade_good.so") +
                                                    ": skipped: saccade_good.so was already loaded from " + dir.path +
                                                    "/saccade_good.so"));
}

TEST(RegistrySearch, AFolderNamedTwiceIsReadOnceWithoutWarnings) {
  Registry r;
  r.load_folders({SACCADE_TEST_PLUGIN_DIR, std::string(SACCADE_TEST_PLUGIN_DIR) + "/"});
  EXPECT_NE(r.find("good.echo"), nullptr);
  EXPECT_TRUE(r.warnings().empty());
  EXPECT_EQ(r.searched().size(), 1u);
}

TEST(RegistrySearch, UnknownPluginSaysWhereItLooked) {
  Registry r;
  r.load_folders({"/no/such/plugin/folder", SACCADE_TEST_PLUGIN_DIR});
  const std::string where = "searched /no/such/plugin/folder (no such folder), " +
                            std::string(SACCADE_TEST_PLUGIN_DIR) +
                            " (3 libraries, 4 failed)";  // good, example, faultkit; 4 broken on purpose
  EXPECT_EQ(r.searched_summary(), where);
  Diagnostics diag;
  GraphDecl decl = load_graph_string("<graph><node name=\"n\" plugin=\"nothere.x\"/></graph>", "g.xml", diag);
  resolve_graph(decl, r, diag);
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("unknown plugin 'nothere.x'; " + where));
  const Result<std::shared_ptr<Node>> created = r.create("nothere.x");
  EXPECT_FALSE(created.ok());
  EXPECT_THAT(created.error(), ::testing::HasSubstr(where));
}

}  // namespace
}  // namespace saccade
