#pragma once
// The graph model, its XML loader and its validator.
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "saccade/contract.hpp"
#include "saccade/diagnostics.hpp"
#include "saccade/status.hpp"

namespace saccade {

class Registry;

enum class QueuePolicy { kLatest, kFifo, kBlock };

struct QueueSpec {
  QueuePolicy policy = QueuePolicy::kLatest;
  int capacity = 1;
  std::string text() const;  // "latest", "fifo:4", "block:2"
};
// Parses "latest", "fifo:N" or "block:N" (N from 1 to 65536).
std::optional<QueueSpec> parse_queue_spec(const std::string& text);

// How an edge between processes travels: DDS reliability, history and deadline.
struct EdgeQos {
  bool reliable = false;
  int depth = 1;             // keep-last depth; 0 = keep all
  double deadline_ms = 0.0;  // 0: none; else a silent writer is reported after this long
  double wait_ms = 0.0;      // the writer waits up to this long for a first reader before it starts
  // Between processes of one host, Image and Retina travel in fixed-capacity
  // shared-memory samples: bytes of pixel data one holds (0: the type's default).
  std::size_t capacity = 0;
  // The topic is a ROS 2 topic (rt/<topic>, ROS 2's message type) that ROS 2
  // tools can read; for the types ROS 2 has (Image, JointState).
  bool ros2 = false;
  // The reader waits for the writer's frames spinning instead of asleep, on
  // one host (about 1 us instead of 5-10 us a frame, at a whole core).
  bool spin = false;
  std::string text() const;  // "best_effort,depth=1", "reliable,keep_all,deadline_ms=200"
  bool operator==(const EdgeQos&) const = default;
};
// The QoS a message type gets by default: camera-rate data best effort keep-last 1
// (a reliable image stream stalls for milliseconds on any loss); commands and
// state reliable, keep-last 8.
EdgeQos default_qos(std::string_view message_type);
// Parses a comma-separated list over `base`: best_effort | reliable, depth=N |
// keep_all, deadline_ms=X, wait_ms=X, capacity=N[K|M] (KiB, MiB), ros2, spin; an
// error naming the item it cannot read.
Result<EdgeQos> parse_edge_qos(const std::string& text, EdgeQos base);

enum class OnError { kStop, kSkip };

struct ParamDecl {
  std::string name;
  std::string value;
  int line = 0;
};

struct SyncDecl {
  std::vector<std::string> inputs;
  double tolerance_ms = 0.0;  // 0: exact timestamps
  int line = 0;
};

struct NodeDecl {
  std::string name;
  std::string plugin;
  std::string process;  // which process runs it; empty = every process
  std::vector<ParamDecl> params;
  std::vector<SyncDecl> syncs;
  OnError on_error = OnError::kStop;
  bool run_inline = false;  // run on the producer's thread instead of a worker
  int line = 0;
};

struct EdgeDecl {
  std::string from_node, from_port, to_node, to_port;
  std::string queue;  // empty: the default (latest)
  std::string qos;    // for an edge between processes; empty: from the message type
  int delay = 0;      // 1: feedback edge, the consumer sees an earlier frame's value
  int line = 0;
};

// A process of a graph split across processes (or PCs): <process name= host=>.
struct ProcessDecl {
  std::string name;
  std::string host;  // processes with the same host share memory; empty: "localhost"
  int line = 0;
};

// What a graph says about itself, beside its nodes and edges: carried
// unchanged from the file to the resolved graph and to each process's part.
struct GraphAttributes {
  std::string file;  // for diagnostics
  std::string name;
  int domain = 0;            // DDS domain of the graph's edges between processes
  std::string topic_prefix;  // of those edges' topics; empty: the graph's name
  std::vector<ProcessDecl> processes;
};

struct GraphDecl : GraphAttributes {
  std::vector<NodeDecl> nodes;
  std::vector<EdgeDecl> edges;
  int line = 0;

  const NodeDecl* find_node(const std::string& name) const;
};

// What a graph file may hold (docs/reliability.md): more is refused before the
// XML is parsed, with the line.
inline constexpr std::size_t kMaxGraphFileBytes = 16u << 20;
inline constexpr int kMaxAttributesPerElement = 256;

// Reads a graph file. Fills `diag` with every problem of form (malformed XML,
// unknown elements or attributes, bad endpoints, limits) and returns what it
// could read.
GraphDecl load_graph_file(const std::string& path, Diagnostics& diag);
GraphDecl load_graph_string(const std::string& xml, const std::string& file_name, Diagnostics& diag);

// Applies "node.param=value" overrides (from --set); unknown nodes are errors.
void apply_overrides(GraphDecl& graph, const std::vector<std::string>& overrides, Diagnostics& diag);

// Expands ${VAR} in parameter values from the environment; SACCADE_SAMPLE_DATA
// defaults to the folder the build was configured with, GRAPH_DIR is the graph
// file's folder. An error for an unknown variable or an unterminated ${.
Result<std::string> expand_variables(const std::string& text, const std::string& graph_file);

struct ResolvedEdge {
  int from_node = -1, from_port = -1, to_node = -1, to_port = -1;
  QueueSpec queue;
  std::string qos;
  int delay = 0;
  int line = 0;
};

struct ResolvedNode {
  NodeDecl decl;
  Contract contract;
  Params params;
};

// A graph whose every node, port, parameter and edge checked out.
struct ResolvedGraph : GraphAttributes {
  std::vector<ResolvedNode> nodes;
  std::vector<ResolvedEdge> edges;
};

// Resolves one node: its plugin, parameters and sync groups (not its edges).
bool resolve_node(const NodeDecl& node, const Registry& registry, const std::string& file, Diagnostics& diag,
                  ResolvedNode& out);

// Validates the whole graph against the registry's contracts and reports every
// error at once; returns nothing when there is any.
std::optional<ResolvedGraph> resolve_graph(const GraphDecl& graph, const Registry& registry, Diagnostics& diag);

// Graphviz text of a graph.
std::string to_dot(const ResolvedGraph& graph);

// Edit distance, for "did you mean".
std::size_t edit_distance(const std::string& a, const std::string& b);
std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates);

}  // namespace saccade
