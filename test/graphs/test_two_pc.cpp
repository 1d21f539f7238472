// One graph, two processes: the plan of graphs/two_pc.xml, the part each
// process runs, and a split run over DDS (a second process on loopback) that
// gives bit for bit what the single-process run gives.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <unistd.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "saccade/partition.hpp"
#include "support.hpp"

namespace saccade {
namespace {

std::optional<ResolvedGraph> load(const std::string& file, const std::string& topic_prefix = "") {
  Diagnostics diag;
  GraphDecl decl = load_graph_file(file, diag);
  if (!topic_prefix.empty()) decl.topic_prefix = topic_prefix;
  auto graph = resolve_graph(decl, testing::default_registry(), diag);
  EXPECT_FALSE(diag.has_errors()) << diag.format();
  return graph;
}

// The same for a graph given as XML text, `name` standing for its file.
std::optional<ResolvedGraph> load_text(const std::string& xml, const std::string& name) {
  Diagnostics diag;
  GraphDecl decl = load_graph_string(xml, name, diag);
  auto graph = resolve_graph(decl, testing::default_registry(), diag);
  EXPECT_FALSE(diag.has_errors()) << diag.format();
  return graph;
}

const PlannedEdge* find_edge(const GraphPlan& plan, const ResolvedGraph& g, const std::string& from,
                             const std::string& to) {
  for (const auto& pe : plan.edges)
    if (g.nodes[static_cast<std::size_t>(pe.edge->from_node)].decl.name == from &&
        g.nodes[static_cast<std::size_t>(pe.edge->to_node)].decl.name == to)
      return &pe;
  return nullptr;
}

TEST(TwoPcPlan, EdgesBetweenProcessesBecomeTopicsWithTheirTypesQos) {
  auto graph = load(SACCADE_SOURCE_DIR "/graphs/two_pc.xml");
  ASSERT_TRUE(graph);
  Diagnostics diag;
  auto plan = plan_graph(*graph, diag);
  ASSERT_TRUE(plan) << diag.format();
  EXPECT_EQ(plan->processes, (std::vector<std::string>{"head_pc", "robot_pc"}));
  int dds = 0;
  for (const auto& pe : plan->edges) dds += pe.route != EdgeRoute::kInProcess;
  EXPECT_EQ(dds, 4);  // the joint state, the fovea's gaze requests to the head and to the driver's wake, head.moved
  const PlannedEdge* state = find_edge(*plan, *graph, "driver", "cameras");
  ASSERT_NE(state, nullptr);
  EXPECT_EQ(state->route, EdgeRoute::kSameHost);
  EXPECT_EQ(state->topic, "saccade/two_pc/driver/state");
  EXPECT_EQ(state->type, "JointState");
  EXPECT_TRUE(state->qos.reliable);
  EXPECT_EQ(state->qos.depth, 8);
  const PlannedEdge* gaze = find_edge(*plan, *graph, "fovea", "head");
  ASSERT_NE(gaze, nullptr);
  EXPECT_EQ(gaze->from_process, "head_pc");
  EXPECT_EQ(gaze->to_process, "robot_pc");
  const PlannedEdge* wake = find_edge(*plan, *graph, "fovea", "driver");
  ASSERT_NE(wake, nullptr);
  EXPECT_EQ(wake->type, "GazeRequest");
  EXPECT_EQ(wake->to_process, "robot_pc");
  // The same process: a pointer hand-off.
  EXPECT_EQ(find_edge(*plan, *graph, "driver", "head")->route, EdgeRoute::kInProcess);
  EXPECT_EQ(find_edge(*plan, *graph, "retina", "fovea")->route, EdgeRoute::kInProcess);
  // The printed plan says all of it.
  std::string text = format_plan(*graph, *plan);
  EXPECT_THAT(text, ::testing::HasSubstr("process robot_pc  [host localhost]: driver, drives, head, drive_truth"));
  EXPECT_THAT(text, ::testing::HasSubstr("fovea.gaze -> head.gaze  GazeRequest  dds-shm  head_pc -> robot_pc  topic "
                                         "saccade/two_pc/fovea/gaze  qos reliable,depth=8"));
}

TEST(TwoPcPlan, EachProcessRunsItsNodesAndOneBridgePerRemoteOutput) {
  auto graph = load(SACCADE_SOURCE_DIR "/graphs/two_pc.xml");
  ASSERT_TRUE(graph);
  Diagnostics diag;
  auto plan = plan_graph(*graph, diag);
  ASSERT_TRUE(plan);
  auto head = partition_graph(*graph, *plan, "head_pc", testing::default_registry(), diag);
  ASSERT_TRUE(head) << diag.format();
  std::map<std::string, const ResolvedNode*> nodes;
  for (const auto& n : head->nodes) nodes[n.decl.name] = &n;
  EXPECT_EQ(nodes.count("driver"), 0u);
  EXPECT_EQ(nodes.count("head"), 0u);
  EXPECT_EQ(nodes.count("cameras"), 1u);
  ASSERT_EQ(nodes.count("dds_sub_driver_state"), 1u);
  ASSERT_EQ(nodes.count("dds_sub_head_moved"), 1u);
  ASSERT_EQ(nodes.count("dds_pub_fovea_gaze"), 1u);
  const ResolvedNode& sub = *nodes["dds_sub_driver_state"];
  EXPECT_EQ(sub.decl.plugin, "dds.subscribe");
  EXPECT_EQ(sub.params.get_string("type"), "JointState");
  EXPECT_EQ(sub.params.get_string("topic"), "saccade/two_pc/driver/state");
  EXPECT_TRUE(sub.params.get_bool("reliable"));
  EXPECT_EQ(sub.params.get_int("depth"), 8);
  EXPECT_TRUE(sub.params.get_bool("zero_copy")) << "both processes on one host";
  EXPECT_TRUE(nodes["dds_pub_fovea_gaze"]->params.get_bool("zero_copy"));
  EXPECT_EQ(head->nodes.size(), 7u + 3u);
  // The robot's side mirrors it.
  auto robot = partition_graph(*graph, *plan, "robot_pc", testing::default_registry(), diag);
  ASSERT_TRUE(robot) << diag.format();
  int subs = 0, pubs = 0;
  for (const auto& n : robot->nodes) {
    subs += n.decl.plugin == "dds.subscribe";
    pubs += n.decl.plugin == "dds.publish";
  }
  EXPECT_EQ(subs, 1);
  EXPECT_EQ(pubs, 2);
}

TEST(TwoPcPlan, ZeroCopyOnlyWhenEveryReaderSharesTheWritersHostAndTheCapacityTravels) {
  auto graph = load_text(R"(<graph name="g">
<process name="a" host="h1"/><process name="b" host="h1"/><process name="c" host="h2"/>
<node name="cam" process="a" plugin="capture.synthetic"/>
<node name="near" process="b" plugin="util.record"/>
<node name="far" process="c" plugin="util.record"/>
<node name="near_truth" process="b" plugin="util.record"/>
<edge from="cam.image" to="near.in" qos="capacity=16M"/>
<edge from="cam.right" to="far.in"/>
<edge from="cam.truth" to="near_truth.in"/>
</graph>)",
                         "hosts.xml");
  ASSERT_TRUE(graph);
  Diagnostics diag;
  auto plan = plan_graph(*graph, diag);
  ASSERT_TRUE(plan) << diag.format();
  EXPECT_EQ(plan->edges[0].qos.capacity, 16u << 20);
  EXPECT_EQ(plan->edges[0].qos.text(), "best_effort,depth=1,capacity=16M");
  // The plan says which edges the bridges will carry without a copy.
  EXPECT_TRUE(plan->edges[0].zero_copy);
  EXPECT_FALSE(plan->edges[1].zero_copy) << "its reader is on another host";
  const std::string text = format_plan(*graph, *plan);
  EXPECT_THAT(text, ::testing::HasSubstr("cam.image -> near.in  Image  dds-shm  a -> b  topic g/cam/image  qos "
                                         "best_effort,depth=1,capacity=16M  zero_copy"));
  EXPECT_THAT(text, ::testing::HasSubstr(
                        "cam.right -> far.in  Image  dds-udp  a -> c  topic g/cam/right  qos best_effort,depth=1\n"));
  auto a = partition_graph(*graph, *plan, "a", testing::default_registry(), diag);
  ASSERT_TRUE(a) << diag.format();
  std::map<std::string, const ResolvedNode*> nodes;
  for (const auto& n : a->nodes) nodes[n.decl.name] = &n;
  ASSERT_EQ(nodes.count("dds_pub_cam_image"), 1u);
  EXPECT_TRUE(nodes["dds_pub_cam_image"]->params.get_bool("zero_copy"));
  EXPECT_EQ(nodes["dds_pub_cam_image"]->params.get_int("capacity"), 16 << 20);
  ASSERT_EQ(nodes.count("dds_pub_cam_right"), 1u);
  EXPECT_FALSE(nodes["dds_pub_cam_right"]->params.get_bool("zero_copy")) << "its reader is on another host";
  auto c = partition_graph(*graph, *plan, "c", testing::default_registry(), diag);
  ASSERT_TRUE(c) << diag.format();
  for (const auto& n : c->nodes) {
    if (n.decl.plugin == "dds.subscribe") {
      EXPECT_FALSE(n.params.get_bool("zero_copy")) << n.decl.name;
      EXPECT_FALSE(n.params.get_bool("same_clock")) << n.decl.name << ": another host's steady clock";
    }
  }
  auto b = partition_graph(*graph, *plan, "b", testing::default_registry(), diag);
  ASSERT_TRUE(b) << diag.format();
  for (const auto& n : b->nodes) {
    if (n.decl.plugin == "dds.subscribe") { EXPECT_TRUE(n.params.get_bool("same_clock")) << n.decl.name; }
  }

  EXPECT_EQ(parse_edge_qos("capacity=512K", EdgeQos{})->capacity, 512u << 10);
  EXPECT_EQ(parse_edge_qos("capacity=1000", EdgeQos{})->capacity, 1000u);
  const Result<EdgeQos> too_large = parse_edge_qos("capacity=2G", EdgeQos{});
  EXPECT_FALSE(too_large.ok());
  EXPECT_THAT(too_large.error(), ::testing::HasSubstr("capacity=N, NK or NM"));
  EXPECT_FALSE(parse_edge_qos("capacity=1.5M", EdgeQos{}).ok());
  EXPECT_FALSE(parse_edge_qos("capacity=2048M", EdgeQos{}).ok());
}

TEST(TwoPcPlan, ARos2EdgeAsksBothBridgesForTheRos2FormNotZeroCopy) {
  auto graph = load_text(R"(<graph name="g">
<process name="a" host="h1"/><process name="b" host="h1"/>
<node name="cam" process="a" plugin="capture.synthetic"/>
<node name="rec" process="b" plugin="util.record"/>
<edge from="cam.image" to="rec.in" qos="ros2"/>
</graph>)",
                         "ros2.xml");
  ASSERT_TRUE(graph);
  Diagnostics diag;
  auto plan = plan_graph(*graph, diag);
  ASSERT_TRUE(plan) << diag.format();
  EXPECT_EQ(plan->edges[0].qos.text(), "best_effort,depth=1,ros2");
  for (const char* process : {"a", "b"}) {
    auto part = partition_graph(*graph, *plan, process, testing::default_registry(), diag);
    ASSERT_TRUE(part) << diag.format();
    int bridges = 0;
    for (const auto& n : part->nodes)
      if (n.decl.plugin.rfind("dds.", 0) == 0) {
        ++bridges;
        EXPECT_TRUE(n.params.get_bool("ros2")) << n.decl.name;
        EXPECT_FALSE(n.params.get_bool("zero_copy")) << n.decl.name << ": ROS 2 cannot read plain types";
      }
    EXPECT_EQ(bridges, 1) << process;
  }
}

TEST(TwoPcPlan, ASpinningEdgeAsksItsSubscriberToSpin) {
  auto graph = load_text(R"(<graph name="g">
<process name="a" host="h1"/><process name="b" host="h1"/>
<node name="cam" process="a" plugin="capture.synthetic"/>
<node name="rec" process="b" plugin="util.record"/>
<node name="truth" process="b" plugin="util.record"/>
<edge from="cam.image" to="rec.in" qos="spin"/>
<edge from="cam.truth" to="truth.in"/>
</graph>)",
                         "spin.xml");
  ASSERT_TRUE(graph);
  Diagnostics diag;
  auto plan = plan_graph(*graph, diag);
  ASSERT_TRUE(plan) << diag.format();
  EXPECT_EQ(plan->edges[0].qos.text(), "best_effort,depth=1,spin");
  EXPECT_THAT(format_plan(*graph, *plan), ::testing::HasSubstr("qos best_effort,depth=1,spin  zero_copy"));
  auto b = partition_graph(*graph, *plan, "b", testing::default_registry(), diag);
  ASSERT_TRUE(b) << diag.format();
  std::map<std::string, bool> spins;
  for (const auto& n : b->nodes)
    if (n.decl.plugin == "dds.subscribe") spins[n.decl.name] = n.params.get_bool("spin");
  EXPECT_EQ(spins, (std::map<std::string, bool>{{"dds_sub_cam_image", true}, {"dds_sub_cam_truth", false}}));
  auto a = partition_graph(*graph, *plan, "a", testing::default_registry(), diag);
  ASSERT_TRUE(a) << diag.format();
  for (const auto& n : a->nodes)
    EXPECT_FALSE(n.params.has("spin") && n.params.get_bool("spin")) << n.decl.name << ": only readers spin";
}

TEST(TwoPcPlan, MistakesAreReportedWithFileLineAndWhatWasExpected) {
  auto diagnose = [](const std::string& xml, const std::string& process = "") {
    Diagnostics diag;
    GraphDecl decl = load_graph_string(xml, "split.xml", diag);
    auto graph = resolve_graph(decl, testing::default_registry(), diag);
    if (graph) {
      auto plan = plan_graph(*graph, diag);
      if (plan && !process.empty()) partition_graph(*graph, *plan, process, testing::default_registry(), diag);
    }
    return diag.format();
  };
  const std::string head = R"(<graph name="g"><process name="a"/><process name="b"/>
<node name="src" process="a" plugin="util.counter"/>
)";
  std::string unknown = diagnose(head + R"(<node name="sink" process="c" plugin="util.null"/>
<edge from="src.image" to="sink.in"/></graph>)");
  EXPECT_THAT(unknown, ::testing::HasSubstr("split.xml:3"));
  EXPECT_THAT(unknown, ::testing::HasSubstr("process 'c' is not declared"));

  std::string bad_qos = diagnose(head + R"(<node name="sink" process="b" plugin="util.record"/>
<edge from="src.image" to="sink.in" qos="reliable,depth=zero"/></graph>)");
  EXPECT_THAT(bad_qos, ::testing::HasSubstr("split.xml:4"));
  EXPECT_THAT(bad_qos, ::testing::HasSubstr("unknown item 'depth=zero'"));

  std::string conflict = diagnose(head + R"(<node name="x" process="b" plugin="util.record"/>
<node name="y" process="b" plugin="util.record"/>
<edge from="src.image" to="x.in" qos="reliable"/>
<edge from="src.image" to="y.in" qos="best_effort"/></graph>)");
  EXPECT_THAT(conflict, ::testing::HasSubstr("split.xml:6"));
  EXPECT_THAT(conflict, ::testing::HasSubstr("one topic, one QoS"));

  std::string untyped = diagnose(head + R"(<node name="pass" process="a" plugin="util.passthrough"/>
<node name="sink" process="b" plugin="util.record"/>
<edge from="src.image" to="pass.in"/>
<edge from="pass.out" to="sink.in"/></graph>)");
  EXPECT_THAT(untyped, ::testing::HasSubstr("output's type is 'any'"));

  std::string no_such = diagnose(head + R"(<node name="sink" process="b" plugin="util.record"/>
<edge from="src.image" to="sink.in"/></graph>)",
                                 "robot");
  EXPECT_THAT(no_such, ::testing::HasSubstr("no process 'robot' in this graph (processes: a, b)"));
}

struct Records {
  std::vector<std::shared_ptr<const Retina>> retinas;
  std::vector<std::shared_ptr<const FeatureMaps>> maps;
  std::vector<std::shared_ptr<const Motion>> motions;
};

Records take_records() {
  return {test::recorded<Retina>("retinas"), test::recorded<FeatureMaps>("maps"), test::recorded<Motion>("motions")};
}

void expect_identical(const cv::Mat& a, const cv::Mat& b, const std::string& what) {
  ASSERT_EQ(a.type(), b.type()) << what;
  ASSERT_EQ(a.size(), b.size()) << what;
  EXPECT_EQ(test::max_abs_diff(a.reshape(1), b.reshape(1)), 0) << what;
}

TEST(TwoPcRun, TwoProcessesOverDdsGiveExactlyWhatOneProcessGives) {
  const std::string file = SACCADE_SOURCE_DIR "/test/graphs/two_pc_vision.xml";
  const int frames = 40;
  // Alone on the topics: ctest may run other DDS tests at the same time.
  const std::string prefix = "test/two_pc_vision/" + std::to_string(getpid());

  // One process.
  auto whole = load(file, prefix);
  ASSERT_TRUE(whole);
  testing::Recorder::instance().clear();
  {
    ExecutorOptions o;
    o.deterministic = true;
    o.max_frames = frames;
    Executor executor(*whole, testing::default_registry(), o);
    ASSERT_TRUE(executor.open().ok());
    ASSERT_TRUE(executor.run().ok());
  }
  Records single = take_records();
  ASSERT_EQ(single.retinas.size(), static_cast<std::size_t>(frames));

  // Two: the head PC's part in a child process, the robot PC's here.
  Diagnostics diag;
  auto plan = plan_graph(*whole, diag);
  ASSERT_TRUE(plan) << diag.format();
  auto robot = partition_graph(*whole, *plan, "robot_pc", testing::default_registry(), diag);
  ASSERT_TRUE(robot) << diag.format();
  testing::Recorder::instance().clear();
  Executor executor(*robot, testing::default_registry());
  ASSERT_TRUE(executor.open().ok());
  pid_t child = test::spawn_saccade({"--log-level", "warn", "run", file, "--process", "head_pc", "--frames",
                                     std::to_string(frames), "--topic-prefix", prefix});
  ASSERT_GT(child, 0);
  Status status;
  std::atomic<bool> finished{false};
  std::thread runner([&] {
    status = executor.run();
    finished = true;
  });
  int code = test::wait_child(child, 120);
  // The child's end of stream ends this graph; if it never arrives, fail
  // saying so instead of hanging until CTest's timeout.
  const bool ended = code == 0 && test::wait_for([&] { return finished.load(); }, 30);
  if (!ended) executor.request_stop();
  runner.join();
  ASSERT_EQ(code, 0) << "the head_pc process failed or hung";
  ASSERT_TRUE(ended) << "the head_pc process exited, but its end of stream did not reach this graph within 30 s ("
                     << testing::Recorder::instance().get("retinas").size() << " retinas, "
                     << testing::Recorder::instance().get("maps").size() << " maps, "
                     << testing::Recorder::instance().get("motions").size() << " motions recorded)";
  ASSERT_TRUE(status.ok()) << status.message();
  Records split = take_records();
  // One host: the retinas, maps and motions travel serialised through their
  // writers' mailboxes (those that fit a slot), in order, once each. How
  // many depends on the load: a writer more than the mailbox's 16 slots
  // ahead of its reader leaves the overwritten posts to DDS (which has them
  // too), and the child here writes 40 frames as fast as it can. CI on two
  // busy cores saw 31 of 120 mailed. So: the mailbox was in use, and
  // whatever came by which path, everything arrived, in order, once.
  uint64_t mailed = 0;
  for (const NodeStats* s : executor.stats())
    for (const auto& c : s->counters)
      if (c->name == "mailbox_frames") mailed += c->value.load();
  EXPECT_GT(mailed, 0u) << "nothing came through the same-host mailbox";

  ASSERT_EQ(split.retinas.size(), single.retinas.size());
  ASSERT_EQ(split.maps.size(), single.maps.size());
  ASSERT_EQ(split.motions.size(), single.motions.size());
  for (std::size_t i = 0; i < single.retinas.size(); ++i) {
    const Retina &a = *single.retinas[i], &b = *split.retinas[i];
    EXPECT_EQ(a.frame_id, b.frame_id);
    EXPECT_EQ(a.timestamp_ns, b.timestamp_ns);
    EXPECT_EQ(a.fovea, b.fovea);
    ASSERT_EQ(a.levels.size(), b.levels.size());
    for (std::size_t l = 0; l < a.levels.size(); ++l) {
      expect_identical(a.levels[l], b.levels[l], "retina level");
      EXPECT_EQ(a.geometry[l].region, b.geometry[l].region);
    }
    const FeatureMaps &fa = *single.maps[i], &fb = *split.maps[i];
    ASSERT_EQ(fa.names, fb.names);
    for (std::size_t f = 0; f < fa.maps.size(); ++f)
      for (std::size_t l = 0; l < fa.maps[f].size(); ++l) expect_identical(fa.maps[f][l], fb.maps[f][l], fa.names[f]);
    const Motion &ma = *single.motions[i], &mb = *split.motions[i];
    EXPECT_EQ(ma.energy, mb.energy);
    EXPECT_EQ(ma.moving, mb.moving);
    EXPECT_EQ(ma.centroid, mb.centroid);
    EXPECT_EQ(ma.first, mb.first);
  }
}

}  // namespace
}  // namespace saccade
