// One test per validation error kind; each checks the message names the line.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "support.hpp"

namespace saccade {
namespace {

using test::diagnose_xml;

// True when some error is on `line` and contains every fragment.
::testing::AssertionResult HasError(const Diagnostics& diag, int line, std::vector<std::string> fragments) {
  for (const auto& d : diag.all()) {
    if (d.warning || d.line != line) continue;
    std::string text = d.format();
    bool all = true;
    for (const auto& f : fragments) all = all && text.find(f) != std::string::npos;
    if (all) return ::testing::AssertionSuccess();
  }
  return ::testing::AssertionFailure() << "no error on line " << line << " with the expected words; got:\n"
                                       << diag.format();
}

const char* kSource = R"(<node name="src" plugin="util.counter"/>)";

TEST(GraphValidation, MalformedXmlNamesTheLine) {
  auto diag = diagnose_xml("<graph>\n  <node name=\"a\" plugin=\"util.null\">\n</graph>\n");
  ASSERT_TRUE(diag.has_errors());
  // tinyxml2 names the line of the element left open.
  EXPECT_TRUE(HasError(diag, 2, {"test.xml:2", "malformed XML", "mismatched element"}));
}

TEST(GraphValidation, UnknownPluginSuggestsTheClosestName) {
  auto diag = diagnose_xml("<graph>\n  <node name=\"r\" plugin=\"retna\"/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 2, {"node 'r'", "unknown plugin 'retna'", "did you mean 'retina'"}));
}

TEST(GraphValidation, UnknownParameterSuggestsTheClosestName) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "\n<node name=\"r\" plugin=\"retina\">\n  <param name=\"levles\" value=\"5\"/>\n</node>"
                           "<edge from=\"src.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 3, {"node 'r'", "unknown parameter 'levles'", "did you mean 'levels'"}));
}

TEST(GraphValidation, MissingRequiredParameter) {
  auto diag = diagnose_xml("<graph>\n<node name=\"v\" plugin=\"capture.video\"/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 2, {"node 'v'", "missing required parameter 'path'"}));
}

TEST(GraphValidation, IllTypedParameterIsCheckedOnTheWholeString) {
  // tinyxml2 would read "12abc" as 12; saccade refuses it.
  auto diag =
      diagnose_xml(std::string("<graph>") + kSource +
                   "\n<node name=\"r\" plugin=\"retina\">\n\n  <param name=\"levels\" value=\"12abc\"/>\n</node>"
                   "<edge from=\"src.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 4, {"parameter 'levels' (int)", "expected an integer, got '12abc'"}));
}

TEST(GraphValidation, OverflowingIntegerIsRefusedNotWrapped) {
  auto diag = diagnose_xml(
      std::string("<graph>") + kSource +
      "\n<node name=\"r\" plugin=\"retina\">\n  <param name=\"levels\" value=\"99999999999999999999\"/>\n</node>"
      "<edge from=\"src.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 3, {"parameter 'levels'", "expected an integer"}));
}

TEST(GraphValidation, OutOfRangeParameter) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "\n<node name=\"r\" plugin=\"retina\">\n  <param name=\"levels\" value=\"40\"/>\n</node>"
                           "<edge from=\"src.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 3, {"parameter 'levels'", "out of range [1, 16]"}));
}

TEST(GraphValidation, BadEnumAndSizeValues) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "\n<node name=\"r\" plugin=\"retina\">\n  <param name=\"mode\" value=\"bilinear\"/>\n"
                           "  <param name=\"size\" value=\"32by24\"/>\n</node>"
                           "<edge from=\"src.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 3, {"parameter 'mode'", "expected one of five_point, area_mean"}));
  EXPECT_TRUE(HasError(diag, 4, {"parameter 'size'", "expected a size WxH"}));
}

TEST(GraphValidation, UnknownPortSuggestsTheClosestName) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "<node name=\"r\" plugin=\"retina\"/>\n<edge from=\"src.image\" to=\"r.imag\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"node 'r' port 'imag'", "unknown input port", "did you mean 'image'"}));
}

TEST(GraphValidation, OutputUsedAsInputIsExplained) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "<node name=\"r\" plugin=\"retina\"/>\n<edge from=\"r.image\" to=\"r.image\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"port 'image'", "unknown output port", "is an input"}));
}

TEST(GraphValidation, TypeMismatchOnAnEdge) {
  auto diag =
      diagnose_xml(std::string("<graph>") + kSource +
                   "<node name=\"f\" plugin=\"filters.bank\"/>\n<edge from=\"src.image\" to=\"f.retina\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"node 'f' port 'retina'", "type mismatch", "produces Image, input expects Retina"}));
}

TEST(GraphValidation, TwoProducersIntoOneInput) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "<node name=\"src2\" plugin=\"util.counter\"/><node name=\"n\" plugin=\"util.null\"/>\n"
                           "<edge from=\"src.image\" to=\"n.in\"/>\n<edge from=\"src2.image\" to=\"n.in\"/></graph>");
  EXPECT_TRUE(HasError(diag, 3, {"node 'n' port 'in'", "already has a producer (edge at line 2)"}));
}

TEST(GraphValidation, UnconnectedRequiredInput) {
  auto diag = diagnose_xml("<graph>\n<node name=\"n\" plugin=\"util.null\"/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 2, {"node 'n' port 'in'", "required input is not connected"}));
}

TEST(GraphValidation, CycleWithoutDelayedEdge) {
  const std::string body = std::string("<graph>") + kSource +
                           "<node name=\"l\" plugin=\"util.latch\"/><node name=\"p\" plugin=\"util.passthrough\"/>"
                           "<edge from=\"src.image\" to=\"l.in\"/>\n<edge from=\"l.out\" to=\"p.in\"/>\n";
  auto diag = diagnose_xml(body + "<edge from=\"p.out\" to=\"l.side\"/></graph>");
  ASSERT_TRUE(diag.has_errors());
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("cycle without a delayed edge"));
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("delay=\"1\""));
  // The same cycle with the feedback edge delayed validates.
  EXPECT_FALSE(diagnose_xml(body + "<edge from=\"p.out\" to=\"l.side\" delay=\"1\"/></graph>").has_errors());
}

TEST(GraphValidation, DuplicateNodeNames) {
  auto diag = diagnose_xml(
      "<graph>\n<node name=\"a\" plugin=\"util.counter\"/>\n<node name=\"a\" plugin=\"util.counter\"/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 3, {"node 'a'", "duplicate node name (first defined at line 2)"}));
}

TEST(GraphValidation, BadQueuePolicyAndDelay) {
  auto diag = diagnose_xml(
      std::string("<graph>") + kSource +
      "<node name=\"n\" plugin=\"util.null\"/>\n<edge from=\"src.image\" to=\"n.in\" queue=\"fifo:0\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"queue must be latest, fifo:N or block:N", "got 'fifo:0'"}));
  diag = diagnose_xml(
      std::string("<graph>") + kSource +
      "<node name=\"n\" plugin=\"util.null\"/>\n<edge from=\"src.image\" to=\"n.in\" delay=\"2\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"delay must be 0 or 1"}));
  diag = diagnose_xml(std::string("<graph>") + kSource +
                      "<node name=\"n\" plugin=\"util.null\"/>\n<edge from=\"src.image\" to=\"n.in\" queue=\"block:2\" "
                      "delay=\"1\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"a delayed (feedback) edge cannot block its producer"}));
}

TEST(GraphValidation, UnknownElementsAndAttributes) {
  auto diag =
      diagnose_xml("<graph>\n<nod name=\"a\"/>\n<node name=\"b\" plugin=\"util.counter\" inlin=\"true\"/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 2, {"unknown element <nod>"}));
  EXPECT_TRUE(HasError(diag, 3, {"unknown attribute 'inlin'", "did you mean 'inline'"}));
}

TEST(GraphValidation, SyncGroupNamesRealInputs) {
  auto diag = diagnose_xml(std::string("<graph>") + kSource +
                           "<node name=\"p\" plugin=\"util.pair\">\n<sync inputs=\"a,c\"/></node>"
                           "<edge from=\"src.image\" to=\"p.a\"/></graph>");
  EXPECT_TRUE(HasError(diag, 2, {"port 'c'", "<sync> names an unknown input"}));
}

TEST(GraphValidation, EveryErrorOfAFileIsReportedAtOnce) {
  auto diag = diagnose_xml(
      "<graph>\n"
      "<node name=\"a\" plugin=\"util.countr\"/>\n"                                       // 2: unknown plugin
      "<node name=\"r\" plugin=\"retina\"><param name=\"levels\" value=\"0\"/></node>\n"  // 3: range, 3: input
      "<node name=\"r\" plugin=\"retina\"/>\n"                                            // 4: duplicate
      "<edge from=\"a.image\" to=\"x.in\"/>\n"                                            // 5: unknown node
      "</graph>");
  EXPECT_GE(diag.error_count(), 4u) << diag.format();
  EXPECT_TRUE(HasError(diag, 2, {"unknown plugin"}));
  EXPECT_TRUE(HasError(diag, 3, {"out of range"}));
  EXPECT_TRUE(HasError(diag, 4, {"duplicate node name"}));
  EXPECT_TRUE(HasError(diag, 5, {"edge to an unknown node"}));
}

TEST(GraphValidation, OverridesFromTheCommandLine) {
  Diagnostics diag;
  GraphDecl decl = load_graph_string(std::string("<graph>") + kSource + "</graph>", "t.xml", diag);
  apply_overrides(decl, {"src.count=7", "nosuch.count=1", "garbage"}, diag);
  EXPECT_EQ(diag.error_count(), 2u) << diag.format();
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("node 'nosuch': no such node"));
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("expected node.param=value, got 'garbage'"));
  ASSERT_EQ(decl.nodes[0].params.size(), 1u);
  EXPECT_EQ(decl.nodes[0].params[0].value, "7");
}

TEST(GraphValidation, VariablesExpandFromTheEnvironment) {
  setenv("SACCADE_TEST_VAR", "/tmp/x", 1);
  EXPECT_EQ(*expand_variables("${SACCADE_TEST_VAR}/a.avi", "g.xml"), "/tmp/x/a.avi");
  EXPECT_EQ(*expand_variables("${GRAPH_DIR}/a", "/data/graphs/g.xml"), "/data/graphs/a");
  const Result<std::string> unknown = expand_variables("${NO_SUCH_VARIABLE_HERE}", "g.xml");
  EXPECT_FALSE(unknown.ok());
  EXPECT_THAT(unknown.error(), ::testing::HasSubstr("unknown variable ${NO_SUCH_VARIABLE_HERE}"));
}

TEST(GraphValidation, DotShowsNodesEdgesAndFeedback) {
  auto graph =
      test::resolve_xml(std::string("<graph name=\"g\">") + kSource +
                        "<node name=\"l\" plugin=\"util.latch\"/><node name=\"p\" plugin=\"util.passthrough\"/>"
                        "<edge from=\"src.image\" to=\"l.in\"/><edge from=\"l.out\" to=\"p.in\"/>"
                        "<edge from=\"p.out\" to=\"l.side\" delay=\"1\"/></graph>");
  std::string dot = to_dot(graph);
  EXPECT_THAT(dot, ::testing::HasSubstr("digraph \"g\""));
  EXPECT_THAT(dot, ::testing::HasSubstr("\"p\":\"o_out\" -> \"l\":\"i_side\" [label=\"latest\", style=dashed"));
}

// Issue 25's crashes and hangs of the graph checker.
TEST(GraphLimits, AChainOfFortyThousandNodesIsCheckedAndItsCycleReportedWithoutRecursion) {
  std::string xml = "<graph>";
  const int n = 40000;
  for (int i = 0; i < n; ++i) xml += "<node name=\"p" + std::to_string(i) + "\" plugin=\"util.passthrough\"/>\n";
  for (int i = 1; i < n; ++i)
    xml += "<edge from=\"p" + std::to_string(i - 1) + ".out\" to=\"p" + std::to_string(i) + ".in\"/>\n";
  const std::string closing = "<edge from=\"p" + std::to_string(n - 1) + ".out\" to=\"p0.in\"/>\n</graph>";
  auto diag = diagnose_xml(xml + closing);
  ASSERT_TRUE(diag.has_errors());
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("cycle without a delayed edge: p0 -> p1 -> p2"))
      << diag.format().substr(0, 300);
}

TEST(GraphLimits, TooManyAttributesAreRefusedBeforeTheXmlIsParsed) {
  std::string many;
  for (int i = 0; i < 100000; ++i) many += " a" + std::to_string(i) + "=\"x\"";
  auto diag = diagnose_xml("<graph>\n<!-- <node a=\"1\" b=\"2\"/> -->\n<node name=\"c\" plugin=\"util.counter\"" +
                           many + "/>\n</graph>");
  EXPECT_TRUE(HasError(diag, 3, {"more than 256 attributes"}));
  EXPECT_EQ(diag.error_count(), 1u) << "one error, not one per attribute";
}

TEST(GraphLimits, AnEmptyFileAFifoAndATooLargeFileAreClearErrors) {
  EXPECT_TRUE(HasError(diagnose_xml(""), 1, {"the file is empty", "<graph>"}));
  const std::string fifo = (std::filesystem::temp_directory_path() / "saccade_graph_fifo.xml").string();
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  Diagnostics diag;
  load_graph_file(fifo, diag);  // would block reading, before the check
  EXPECT_THAT(diag.format(), ::testing::HasSubstr("not a regular file"));
  std::filesystem::remove(fifo);
  const std::string big = (std::filesystem::temp_directory_path() / "saccade_graph_big.xml").string();
  std::ofstream(big) << std::string(kMaxGraphFileBytes + 1, ' ');
  Diagnostics too_big;
  load_graph_file(big, too_big);
  EXPECT_THAT(too_big.format(), ::testing::HasSubstr("a graph file may have at most"));
  std::filesystem::remove(big);
}

}  // namespace
}  // namespace saccade
