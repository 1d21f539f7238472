#include "saccade/partition.hpp"

#include <algorithm>
#include <map>

#include "saccade/registry.hpp"
#include "text.hpp"

namespace saccade {

const char* to_string(EdgeRoute route) {
  switch (route) {
    case EdgeRoute::kInProcess: return "in-process";
    case EdgeRoute::kSameHost: return "dds-shm";
    case EdgeRoute::kOtherHost: return "dds-udp";
  }
  return "?";
}

namespace {

const PortSpec& output_port(const ResolvedGraph& g, int node, int port) {
  return g.nodes[static_cast<std::size_t>(node)].contract.outputs()[static_cast<std::size_t>(port)];
}

std::string host_of(const ResolvedGraph& g, const std::string& process) {
  for (const auto& p : g.processes)
    if (p.name == process) return p.host.empty() ? "localhost" : p.host;
  return "localhost";
}

// The DDS node standing in for the far end of an edge that leaves `process`:
// a publisher its output feeds, or a subscriber that feeds its input. Its
// parameters carry the edge's QoS, so both processes agree on the topic.
NodeDecl bridge_decl(const ResolvedGraph& graph, const PlannedEdge& pe, bool publish, const std::string& process) {
  const ResolvedEdge& e = *pe.edge;
  const auto& from = graph.nodes[static_cast<std::size_t>(e.from_node)];
  const std::string& port = from.contract.outputs()[static_cast<std::size_t>(e.from_port)].name;
  NodeDecl decl;
  decl.name = std::string(publish ? "dds_pub_" : "dds_sub_") + from.decl.name + "_" + port;
  decl.plugin = publish ? "dds.publish" : "dds.subscribe";
  decl.process = process;
  decl.line = e.line;
  decl.params = {{"topic", pe.topic, e.line},
                 {"type", pe.type, e.line},
                 {"domain", std::to_string(graph.domain), e.line},
                 {"reliable", pe.qos.reliable ? "true" : "false", e.line},
                 {"depth", std::to_string(pe.qos.depth), e.line},
                 {"deadline_ms", text::format_number(pe.qos.deadline_ms), e.line}};
  if (publish) decl.params.push_back({"wait_ms", text::format_number(pe.qos.wait_ms), e.line});
  // Steady clocks are per host: across hosts, latency counts from arrival.
  if (!publish && pe.route == EdgeRoute::kOtherHost) decl.params.push_back({"same_clock", "false", e.line});
  if (!publish && pe.qos.spin) decl.params.push_back({"spin", "true", e.line});
  if (pe.qos.ros2) {
    decl.params.push_back({"ros2", "true", e.line});
  } else if (pe.zero_copy) {
    decl.params.push_back({"zero_copy", "true", e.line});
    decl.params.push_back({"capacity", std::to_string(pe.qos.capacity), e.line});
  }
  return decl;
}

}  // namespace

std::optional<GraphPlan> plan_graph(const ResolvedGraph& graph, Diagnostics& diag) {
  std::size_t errors_before = diag.error_count();
  GraphPlan plan;
  for (const auto& p : graph.processes) plan.processes.push_back(p.name);
  for (const auto& n : graph.nodes)
    if (!n.decl.process.empty() &&
        std::find(plan.processes.begin(), plan.processes.end(), n.decl.process) == plan.processes.end())
      plan.processes.push_back(n.decl.process);

  const std::string prefix = !graph.topic_prefix.empty() ? graph.topic_prefix
                             : !graph.name.empty()       ? graph.name
                                                         : std::string("saccade");
  // One topic per output: the QoS every remote consumer of an output asked for.
  std::map<std::pair<int, int>, const PlannedEdge*> topic_owner;
  plan.edges.reserve(graph.edges.size());
  for (const auto& e : graph.edges) {
    PlannedEdge pe;
    pe.edge = &e;
    const auto& from = graph.nodes[static_cast<std::size_t>(e.from_node)];
    const auto& to = graph.nodes[static_cast<std::size_t>(e.to_node)];
    pe.from_process = from.decl.process;
    pe.to_process = to.decl.process;
    const PortSpec& port = output_port(graph, e.from_node, e.from_port);
    pe.type = port.type;
    // A subscriber bridge emits its topic's type through an untyped port.
    if (pe.type == kAnyType && from.decl.plugin == "dds.subscribe") pe.type = from.params.get_string("type");
    bool crosses = !pe.from_process.empty() && !pe.to_process.empty() && pe.from_process != pe.to_process;
    if (crosses) {
      pe.route = host_of(graph, pe.from_process) == host_of(graph, pe.to_process) ? EdgeRoute::kSameHost
                                                                                  : EdgeRoute::kOtherHost;
      pe.topic = prefix + "/" + from.decl.name + "/" + port.name;
      Result<EdgeQos> qos = parse_edge_qos(e.qos, default_qos(pe.type));
      if (!qos.ok()) {
        diag.error(graph.file, e.line, to.decl.name, "", qos.error());
        continue;
      }
      pe.qos = *qos;
      if (port.type == kAnyType)
        diag.error(graph.file, e.line, to.decl.name, "",
                   "the edge from " + from.decl.name + "." + port.name +
                       " crosses processes but that output's type is 'any': only typed outputs can become DDS topics");
    }
    plan.edges.push_back(std::move(pe));
  }
  for (const auto& pe : plan.edges) {
    if (pe.route == EdgeRoute::kInProcess) continue;
    auto key = std::make_pair(pe.edge->from_node, pe.edge->from_port);
    auto [it, inserted] = topic_owner.emplace(key, &pe);
    if (!inserted && it->second->qos != pe.qos)
      diag.error(graph.file, pe.edge->line, graph.nodes[static_cast<std::size_t>(pe.edge->to_node)].decl.name, "",
                 "topic " + pe.topic + " is read with qos " + pe.qos.text() + " here but " + it->second->qos.text() +
                     " by the edge at line " + std::to_string(it->second->edge->line) + "; one topic, one QoS");
  }
  if (diag.error_count() > errors_before) return std::nullopt;
  // Zero copy needs every reader of the topic on the writer's host; one
  // elsewhere gets the serialised type over UDP, so all of them do.
  for (auto& pe : plan.edges) {
    if (pe.route == EdgeRoute::kInProcess || pe.qos.ros2) continue;
    pe.zero_copy = std::none_of(plan.edges.begin(), plan.edges.end(), [&](const PlannedEdge& other) {
      return other.edge->from_node == pe.edge->from_node && other.edge->from_port == pe.edge->from_port &&
             other.route == EdgeRoute::kOtherHost;
    });
  }
  return plan;
}

std::string format_plan(const ResolvedGraph& graph, const GraphPlan& plan) {
  std::string out;
  auto process_label = [](const std::string& p) { return p.empty() ? std::string("(every process)") : p; };
  std::vector<std::string> groups = plan.processes;
  groups.push_back("");
  for (const auto& p : groups) {
    std::vector<std::string> names;
    for (const auto& n : graph.nodes)
      if (n.decl.process == p) names.push_back(n.decl.name);
    if (names.empty()) continue;
    std::string host = p.empty() ? "" : "  [host " + host_of(graph, p) + "]";
    out += "process " + process_label(p) + host + ": " + text::join(names, ", ") + "\n";
  }
  out += "edges:\n";
  for (const auto& pe : plan.edges) {
    const auto& e = *pe.edge;
    const auto& from = graph.nodes[static_cast<std::size_t>(e.from_node)];
    const auto& to = graph.nodes[static_cast<std::size_t>(e.to_node)];
    out += "  " + from.decl.name + "." + from.contract.outputs()[static_cast<std::size_t>(e.from_port)].name + " -> " +
           to.decl.name + "." + to.contract.inputs()[static_cast<std::size_t>(e.to_port)].name + "  " + pe.type + "  " +
           to_string(pe.route);
    if (pe.route == EdgeRoute::kInProcess) {
      out += "  queue " + e.queue.text();
    } else {
      out += "  " + process_label(pe.from_process) + " -> " + process_label(pe.to_process) + "  topic " + pe.topic +
             "  qos " + pe.qos.text();
      if (pe.zero_copy) out += "  zero_copy";
    }
    if (e.delay) out += "  delayed";
    out += "\n";
  }
  return out;
}

std::optional<ResolvedGraph> partition_graph(const ResolvedGraph& graph, const GraphPlan& plan,
                                             const std::string& process, const Registry& registry, Diagnostics& diag) {
  std::size_t errors_before = diag.error_count();
  if (std::find(plan.processes.begin(), plan.processes.end(), process) == plan.processes.end()) {
    std::string known = text::join(plan.processes, ", ");
    diag.error(graph.file, 0, "", "",
               "no process '" + process + "' in this graph" +
                   (known.empty() ? std::string(" (no node names a process)") : " (processes: " + known + ")"));
    return std::nullopt;
  }
  ResolvedGraph out;
  static_cast<GraphAttributes&>(out) = graph;
  auto runs_here = [&](const ResolvedNode& n) { return n.decl.process.empty() || n.decl.process == process; };
  std::vector<int> remap(graph.nodes.size(), -1);
  for (std::size_t i = 0; i < graph.nodes.size(); ++i)
    if (runs_here(graph.nodes[i])) {
      remap[i] = static_cast<int>(out.nodes.size());
      out.nodes.push_back(graph.nodes[i]);
    }

  std::map<std::pair<int, int>, int> bridge_of_output;  // (node, port) in `graph` -> bridge node in `out`
  auto bridge = [&](const PlannedEdge& pe, bool publish) -> int {
    auto key = std::make_pair(pe.edge->from_node, pe.edge->from_port);
    if (auto it = bridge_of_output.find(key); it != bridge_of_output.end()) return it->second;
    ResolvedNode rn;
    if (!resolve_node(bridge_decl(graph, pe, publish, process), registry, graph.file, diag, rn)) return -1;
    int index = static_cast<int>(out.nodes.size());
    out.nodes.push_back(std::move(rn));
    bridge_of_output.emplace(key, index);
    return index;
  };

  for (const auto& pe : plan.edges) {
    const ResolvedEdge& e = *pe.edge;
    int from = remap[static_cast<std::size_t>(e.from_node)];
    int to = remap[static_cast<std::size_t>(e.to_node)];
    if (from < 0 && to < 0) continue;
    ResolvedEdge re = e;
    if (pe.route == EdgeRoute::kInProcess) {
      // A node of every process and one of another process: local where both run.
      if (from < 0 || to < 0) continue;
      re.from_node = from;
      re.to_node = to;
    } else if (from >= 0) {
      // This process produces, another consumes: the output feeds a publisher.
      // Its queue drops nothing a DDS writer would keep (keep-all edges block).
      int pub = bridge(pe, true);
      if (pub < 0) continue;
      bool already =
          std::any_of(out.edges.begin(), out.edges.end(), [&](const ResolvedEdge& x) { return x.to_node == pub; });
      if (already) continue;
      re.from_node = from;
      re.to_node = pub;
      re.to_port = 0;
      re.delay = 0;
      re.queue = pe.qos.depth == 0 ? QueueSpec{QueuePolicy::kBlock, 4} : QueueSpec{QueuePolicy::kFifo, pe.qos.depth};
    } else {
      int sub = bridge(pe, false);
      if (sub < 0) continue;
      re.from_node = sub;
      re.from_port = 0;
      re.to_node = to;
    }
    out.edges.push_back(re);
  }
  if (diag.error_count() > errors_before) return std::nullopt;
  return out;
}

}  // namespace saccade
