#pragma once
// One graph, several processes: which node runs where, how each edge travels,
// and the part of the graph one process runs, with its edges to other processes
// replaced by DDS bridge nodes (dds.publish / dds.subscribe). Plugin code does
// not change: a bridge is an ordinary node the framework inserts.
#include <optional>
#include <string>
#include <vector>

#include "saccade/graph.hpp"

namespace saccade {

class Registry;

enum class EdgeRoute {
  kInProcess,  // a shared_ptr hand-off
  kSameHost,   // DDS over shared memory
  kOtherHost,  // DDS over UDP
};
const char* to_string(EdgeRoute route);

struct PlannedEdge {
  const ResolvedEdge* edge = nullptr;
  std::string from_process, to_process;  // empty: the node runs in every process
  std::string type;                      // the producer port's message type
  EdgeRoute route = EdgeRoute::kInProcess;
  std::string topic;  // DDS edges only
  EdgeQos qos;        // DDS edges only
  // DDS edges whose output has every reader on the writer's host (and is no
  // ROS 2 topic): the bridges are told zero_copy, so messages travel through
  // shared memory (images in the writer's frame ring, other types through its
  // message mailbox; how: the bridges' shared_memory).
  bool zero_copy = false;
};

struct GraphPlan {
  std::vector<std::string> processes;  // declared, then any only named by nodes
  std::vector<PlannedEdge> edges;      // in the graph's edge order
};

// Where everything runs and how every edge travels. The topic of an output is
// "<prefix>/<node>/<port>" (prefix: the graph's topic_prefix, else its name);
// an edge's qos attribute overrides its type's default QoS. Two outputs'
// consumers in one process must agree on the QoS (one topic, one reader).
std::optional<GraphPlan> plan_graph(const ResolvedGraph& graph, Diagnostics& diag);

// The human-readable plan: nodes per process, then every edge with its route.
std::string format_plan(const ResolvedGraph& graph, const GraphPlan& plan);

// The part of `graph` that `process` runs: its own nodes and those of no
// process; each output with consumers elsewhere gains a dds.publish node, each
// remote output this process consumes a dds.subscribe node (one per output).
// An unknown process is an error that lists the known ones.
std::optional<ResolvedGraph> partition_graph(const ResolvedGraph& graph, const GraphPlan& plan,
                                             const std::string& process, const Registry& registry, Diagnostics& diag);

}  // namespace saccade
