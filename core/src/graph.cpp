#include "saccade/graph.hpp"

#include <tinyxml2.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>

#include "saccade/registry.hpp"
#include "text.hpp"

#ifndef SACCADE_DEFAULT_SAMPLE_DATA
#define SACCADE_DEFAULT_SAMPLE_DATA "/usr/share/doc/opencv-doc/examples/data"
#endif

namespace saccade {

std::string QueueSpec::text() const {
  switch (policy) {
    case QueuePolicy::kLatest: return "latest";
    case QueuePolicy::kFifo: return "fifo:" + std::to_string(capacity);
    case QueuePolicy::kBlock: return "block:" + std::to_string(capacity);
  }
  return "?";
}

std::optional<QueueSpec> parse_queue_spec(const std::string& text) {
  if (text.empty() || text == "latest") return QueueSpec{QueuePolicy::kLatest, 1};
  auto colon = text.find(':');
  if (colon == std::string::npos) return std::nullopt;
  std::string kind = text.substr(0, colon);
  int n = 0;
  const char* begin = text.data() + colon + 1;
  const char* end = text.data() + text.size();
  auto [ptr, ec] = std::from_chars(begin, end, n);
  if (ec != std::errc() || ptr != end || begin == end || n < 1 || n > 65536) return std::nullopt;
  if (kind == "fifo") return QueueSpec{QueuePolicy::kFifo, n};
  if (kind == "block") return QueueSpec{QueuePolicy::kBlock, n};
  return std::nullopt;
}

const NodeDecl* GraphDecl::find_node(const std::string& node_name) const {
  for (const auto& n : nodes)
    if (n.name == node_name) return &n;
  return nullptr;
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string did_you_mean(const std::string& word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const auto& c : candidates) {
    std::size_t d = edit_distance(word, c);
    // A suffix match ("bank" for "filters.bank") counts as close too.
    if (c.size() > word.size() && c.compare(c.size() - word.size(), word.size(), word) == 0)
      d = std::min<std::size_t>(d, 1);
    if (d < best_d) {
      best_d = d;
      best = c;
    }
  }
  if (best.empty() || best_d > std::max<std::size_t>(2, word.size() / 3)) return {};
  return " (did you mean '" + best + "'?)";
}

std::string EdgeQos::text() const {
  std::string out = reliable ? "reliable" : "best_effort";
  out += depth == 0 ? ",keep_all" : ",depth=" + std::to_string(depth);
  if (deadline_ms > 0) out += ",deadline_ms=" + text::format_number(deadline_ms);
  if (wait_ms > 0) out += ",wait_ms=" + text::format_number(wait_ms);
  if (capacity > 0)
    out += ",capacity=" + (capacity % (1u << 20) == 0   ? std::to_string(capacity >> 20) + "M"
                           : capacity % (1u << 10) == 0 ? std::to_string(capacity >> 10) + "K"
                                                        : std::to_string(capacity));
  if (ros2) out += ",ros2";
  if (spin) out += ",spin";
  return out;
}

EdgeQos default_qos(std::string_view message_type) {
  EdgeQos q;
  if (message_type == "JointTargets" || message_type == "JointState" || message_type == "GazeRequest") {
    q.reliable = true;
    q.depth = 8;
  }
  return q;
}

namespace {

// "capacity=4M": bytes, or KiB / MiB with a K / M suffix; 1 byte to 1 GiB.
std::optional<std::size_t> parse_capacity(const std::string& item) {
  constexpr std::string_view prefix = "capacity=";
  if (item.rfind(prefix, 0) != 0) return std::nullopt;
  std::string_view number = std::string_view(item).substr(prefix.size());
  double unit = 1;
  if (!number.empty() && (number.back() == 'K' || number.back() == 'M')) {
    unit = number.back() == 'K' ? 1024.0 : 1024.0 * 1024.0;
    number.remove_suffix(1);
  }
  double v = 0;
  if (!text::parse_number(number, v) || v != static_cast<double>(static_cast<int64_t>(v))) return std::nullopt;
  const double bytes = v * unit;
  if (bytes < 1 || bytes > 1024.0 * 1024.0 * 1024.0) return std::nullopt;
  return static_cast<std::size_t>(bytes);
}

}  // namespace

Result<EdgeQos> parse_edge_qos(const std::string& text, EdgeQos base) {
  for (const std::string& item : text::split_list(text, ',')) {
    auto value_after = [&](std::string_view prefix, double lo, double hi, double& value) {
      return item.rfind(prefix, 0) == 0 && text::parse_number(std::string_view(item).substr(prefix.size()), value) &&
             value >= lo && value <= hi;
    };
    double v = 0;
    if (item == "best_effort")
      base.reliable = false;
    else if (item == "reliable")
      base.reliable = true;
    else if (item == "keep_all")
      base.depth = 0;
    else if (value_after("depth=", 1, 100000, v) && v == static_cast<int>(v))
      base.depth = static_cast<int>(v);
    else if (value_after("deadline_ms=", 0, 3.6e6, v))
      base.deadline_ms = v;
    else if (value_after("wait_ms=", 0, 3.6e6, v))
      base.wait_ms = v;
    else if (auto bytes = parse_capacity(item))
      base.capacity = *bytes;
    else if (item == "ros2")
      base.ros2 = true;
    else if (item == "spin")
      base.spin = true;
    else
      return Status::error("qos: unknown item '" + item +
                           "'; expected best_effort or reliable, depth=N (1..100000) or keep_all, deadline_ms=X, "
                           "wait_ms=X, capacity=N, NK or NM (1 byte to 1024M), ros2, spin");
  }
  return base;
}

namespace {

using tinyxml2::XMLAttribute;
using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;

void check_attributes(const XMLElement* e, const std::set<std::string>& allowed, const std::string& file,
                      const std::string& node, Diagnostics& diag) {
  for (const XMLAttribute* a = e->FirstAttribute(); a; a = a->Next()) {
    if (!allowed.count(a->Name())) {
      std::vector<std::string> list(allowed.begin(), allowed.end());
      diag.error(
          file, a->GetLineNum(), node, "",
          std::string("unknown attribute '") + a->Name() + "' on <" + e->Name() + ">" + did_you_mean(a->Name(), list));
    }
  }
}

bool split_endpoint(const char* text, std::string& node, std::string& port) {
  if (text == nullptr) return false;
  std::string s(text);
  auto dot = s.find('.');
  if (dot == std::string::npos || dot == 0 || dot + 1 == s.size()) return false;
  node = s.substr(0, dot);
  port = s.substr(dot + 1);
  return true;
}

// tinyxml2's error in words: "Error=XML_ERROR_PARSING_ATTRIBUTE ErrorID=7 (0x7)
// Line number=3: XMLElement name=node" becomes "parsing attribute (XMLElement
// name=node)"; the line number is the diagnostic's own.
std::string describe_xml_error(const XMLDocument& doc) {
  std::string name = doc.ErrorName();
  if (name.rfind("XML_ERROR_", 0) == 0) name = name.substr(10);
  for (char& c : name) c = c == '_' ? ' ' : static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const std::string full = doc.ErrorStr();
  const auto detail = full.find(": ", full.find("Line number="));
  if (detail != std::string::npos) name += " (" + full.substr(detail + 2) + ")";
  return name;
}

// Limits on a graph file, checked before tinyxml2 parses it (it finds a
// repeated attribute by comparing each with every other: 100,000 attributes
// on one element took 35 s). An error saying what is over, its line in `line`.
Status over_limits(std::string_view xml, int& line) {
  line = 1;
  if (xml.size() > kMaxGraphFileBytes)
    return Status::error("the file is " + std::to_string(xml.size()) + " bytes; a graph file may have at most " +
                         std::to_string(kMaxGraphFileBytes));
  bool in_tag = false, in_comment = false;
  char quote = 0;
  int attributes = 0, tag_line = 1;
  for (std::size_t i = 0; i < xml.size(); ++i) {
    const char c = xml[i];
    if (c == '\n') ++line;
    if (in_comment) {
      if (xml.compare(i, 3, "-->") == 0) in_comment = false;
      continue;
    }
    if (quote != 0) {
      if (c == quote) quote = 0;
      continue;
    }
    if (!in_tag) {
      if (xml.compare(i, 4, "<!--") == 0)
        in_comment = true;
      else if (c == '<')
        in_tag = true, attributes = 0, tag_line = line;
      continue;
    }
    if (c == '"' || c == '\'')
      quote = c;
    else if (c == '=' && ++attributes > kMaxAttributesPerElement) {
      line = tag_line;
      return Status::error("an element with more than " + std::to_string(kMaxAttributesPerElement) + " attributes");
    } else if (c == '>')
      in_tag = false;
  }
  return {};
}

// The <graph> element with its attributes read into `graph`; null when the
// document has none (the error is reported).
const XMLElement* parse_root(const XMLDocument& doc, const std::string& file, Diagnostics& diag, GraphDecl& graph) {
  if (doc.ErrorID() == tinyxml2::XML_ERROR_EMPTY_DOCUMENT) {
    diag.error(file, 1, "", "", "the file is empty; expected a <graph> root element");
    return nullptr;
  }
  if (doc.Error()) {
    diag.error(file, std::max(1, doc.ErrorLineNum()), "", "", "malformed XML: " + describe_xml_error(doc));
    return nullptr;
  }
  const XMLElement* root = doc.RootElement();
  if (root == nullptr || std::string(root->Name()) != "graph") {
    diag.error(file, root ? root->GetLineNum() : 1, "", "", "expected a <graph> root element");
    return nullptr;
  }
  graph.line = root->GetLineNum();
  check_attributes(root, {"name", "domain", "topic_prefix"}, file, "", diag);
  if (const char* n = root->Attribute("name")) graph.name = n;
  if (const char* d = root->Attribute("domain")) {
    int v = -1;
    // Fast DDS maps a domain to UDP ports 7400 + 250 * domain: above 232 they overflow.
    if (!text::parse_number(std::string_view(d), v) || v < 0 || v > 232)
      diag.error(file, graph.line, "", "", std::string("domain must be an integer from 0 to 232, got '") + d + "'");
    else
      graph.domain = v;
  }
  if (const char* t = root->Attribute("topic_prefix")) graph.topic_prefix = t;
  return root;
}

void parse_param(const XMLElement* c, const std::string& file, Diagnostics& diag, NodeDecl& node) {
  check_attributes(c, {"name", "value"}, file, node.name, diag);
  const char* pn = c->Attribute("name");
  const char* pv = c->Attribute("value");
  if (!pv) pv = c->GetText();
  if (!pn || !*pn) {
    diag.error(file, c->GetLineNum(), node.name, "", "<param> needs a name attribute");
    return;
  }
  if (!pv) {
    diag.error(file, c->GetLineNum(), node.name, "", std::string("parameter '") + pn + "' has no value");
    return;
  }
  node.params.push_back({pn, pv, c->GetLineNum()});
}

SyncDecl parse_sync(const XMLElement* c, const std::string& file, const std::string& node, Diagnostics& diag) {
  check_attributes(c, {"inputs", "tolerance_ms"}, file, node, diag);
  SyncDecl sync;
  sync.line = c->GetLineNum();
  // Not text::split_list: inputs may be separated by spaces as well as commas,
  // and a tab or newline stays part of a name (reported as an unknown input).
  std::string inputs = c->Attribute("inputs") ? c->Attribute("inputs") : "";
  std::string item;
  for (char ch : inputs + ",") {
    if (ch == ',' || ch == ' ') {
      if (!item.empty()) sync.inputs.push_back(item);
      item.clear();
    } else {
      item += ch;
    }
  }
  if (sync.inputs.size() < 2)
    diag.error(file, sync.line, node, "", "<sync> needs inputs=\"a,b\" naming two or more inputs");
  if (const char* tol = c->Attribute("tolerance_ms")) {
    // Not text::parse_number: that would also take " 5" and "+5", which are errors here.
    std::string t = tol;
    auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), sync.tolerance_ms);
    if (ec != std::errc() || ptr != t.data() + t.size() || sync.tolerance_ms < 0)
      diag.error(file, sync.line, node, "", "tolerance_ms must be a number >= 0, got '" + t + "'");
  }
  return sync;
}

NodeDecl parse_node(const XMLElement* e, const std::string& file, Diagnostics& diag) {
  NodeDecl node;
  const int line = e->GetLineNum();
  node.line = line;
  const char* name = e->Attribute("name");
  const char* plugin = e->Attribute("plugin");
  if (!name || !*name) diag.error(file, line, "", "", "<node> needs a name attribute");
  if (!plugin || !*plugin) diag.error(file, line, name ? name : "", "", "<node> needs a plugin attribute");
  node.name = name ? name : "";
  node.plugin = plugin ? plugin : "";
  check_attributes(e, {"name", "plugin", "process", "on_error", "inline"}, file, node.name, diag);
  if (const char* p = e->Attribute("process")) node.process = p;
  if (const char* oe = e->Attribute("on_error")) {
    std::string v = oe;
    if (v == "stop")
      node.on_error = OnError::kStop;
    else if (v == "skip")
      node.on_error = OnError::kSkip;
    else
      diag.error(file, line, node.name, "", "on_error must be 'stop' or 'skip', got '" + v + "'");
  }
  if (const char* in = e->Attribute("inline")) {
    std::string v = in;
    if (v == "true")
      node.run_inline = true;
    else if (v != "false")
      diag.error(file, line, node.name, "", "inline must be 'true' or 'false', got '" + v + "'");
  }
  for (const XMLElement* c = e->FirstChildElement(); c; c = c->NextSiblingElement()) {
    std::string ctag = c->Name();
    if (ctag == "param")
      parse_param(c, file, diag, node);
    else if (ctag == "sync")
      node.syncs.push_back(parse_sync(c, file, node.name, diag));
    else
      diag.error(file, c->GetLineNum(), node.name, "",
                 "unknown element <" + ctag + "> in <node>; expected <param> or <sync>");
  }
  return node;
}

void parse_edge(const XMLElement* e, const std::string& file, Diagnostics& diag, GraphDecl& graph) {
  const int line = e->GetLineNum();
  check_attributes(e, {"from", "to", "queue", "delay", "qos"}, file, "", diag);
  EdgeDecl edge;
  edge.line = line;
  bool ok = true;
  if (!split_endpoint(e->Attribute("from"), edge.from_node, edge.from_port)) {
    diag.error(
        file, line, "", "",
        "edge 'from' must be node.port, got '" + std::string(e->Attribute("from") ? e->Attribute("from") : "") + "'");
    ok = false;
  }
  if (!split_endpoint(e->Attribute("to"), edge.to_node, edge.to_port)) {
    diag.error(file, line, "", "",
               "edge 'to' must be node.port, got '" + std::string(e->Attribute("to") ? e->Attribute("to") : "") + "'");
    ok = false;
  }
  if (const char* q = e->Attribute("queue")) edge.queue = q;
  if (const char* q = e->Attribute("qos")) edge.qos = q;
  if (const char* d = e->Attribute("delay")) {
    std::string v = d;
    if (v == "0")
      edge.delay = 0;
    else if (v == "1")
      edge.delay = 1;
    else
      diag.error(file, line, edge.to_node, edge.to_port, "delay must be 0 or 1, got '" + v + "'");
  }
  if (ok) graph.edges.push_back(std::move(edge));
}

void parse_process(const XMLElement* e, const std::string& file, Diagnostics& diag, GraphDecl& graph) {
  const int line = e->GetLineNum();
  check_attributes(e, {"name", "host"}, file, "", diag);
  ProcessDecl process;
  process.line = line;
  if (const char* n = e->Attribute("name")) process.name = n;
  if (const char* h = e->Attribute("host")) process.host = h;
  if (process.name.empty())
    diag.error(file, line, "", "", "<process> needs a name attribute");
  else
    graph.processes.push_back(std::move(process));
}

GraphDecl parse_document(XMLDocument& doc, const std::string& file, Diagnostics& diag) {
  GraphDecl graph;
  graph.file = file;
  const XMLElement* root = parse_root(doc, file, diag, graph);
  if (root == nullptr) return graph;
  for (const XMLElement* e = root->FirstChildElement(); e; e = e->NextSiblingElement()) {
    std::string tag = e->Name();
    if (tag == "node")
      graph.nodes.push_back(parse_node(e, file, diag));
    else if (tag == "edge")
      parse_edge(e, file, diag, graph);
    else if (tag == "process")
      parse_process(e, file, diag, graph);
    else
      diag.error(file, e->GetLineNum(), "", "", "unknown element <" + tag + ">; expected <node>, <edge> or <process>");
  }
  return graph;
}

}  // namespace

GraphDecl load_graph_file(const std::string& path, Diagnostics& diag) {
  GraphDecl empty;
  empty.file = path;
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) {
    diag.error(path, 0, "", "", "no such graph file");
    return empty;
  }
  // A FIFO or a device would block the read, or never end.
  if (!std::filesystem::is_regular_file(status)) {
    diag.error(path, 0, "", "", "not a regular file; expected a graph file");
    return empty;
  }
  const auto size = std::filesystem::file_size(path, ec);
  if (!ec && size > kMaxGraphFileBytes) {
    diag.error(path, 0, "", "",
               "the file is " + std::to_string(size) + " bytes; a graph file may have at most " +
                   std::to_string(kMaxGraphFileBytes));
    return empty;
  }
  std::ifstream in(path, std::ios::binary);
  std::string xml((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.good() && !in.eof()) {
    diag.error(path, 0, "", "", "cannot read the file");
    return empty;
  }
  return load_graph_string(xml, path, diag);
}

GraphDecl load_graph_string(const std::string& xml, const std::string& file_name, Diagnostics& diag) {
  int line = 0;
  if (Status over = over_limits(xml, line); !over.ok()) {
    diag.error(file_name, line, "", "", over.message());
    GraphDecl g;
    g.file = file_name;
    return g;
  }
  XMLDocument doc;
  doc.Parse(xml.c_str(), xml.size());
  return parse_document(doc, file_name, diag);
}

void apply_overrides(GraphDecl& graph, const std::vector<std::string>& overrides, Diagnostics& diag) {
  for (const auto& o : overrides) {
    auto eq = o.find('=');
    auto dot = o.find('.');
    if (eq == std::string::npos || dot == std::string::npos || dot > eq || dot == 0 || dot + 1 == eq) {
      diag.error("--set", 0, "", "", "expected node.param=value, got '" + o + "'");
      continue;
    }
    std::string node = o.substr(0, dot), param = o.substr(dot + 1, eq - dot - 1), value = o.substr(eq + 1);
    auto it = std::find_if(graph.nodes.begin(), graph.nodes.end(), [&](const NodeDecl& n) { return n.name == node; });
    if (it == graph.nodes.end()) {
      std::vector<std::string> names;
      for (const auto& n : graph.nodes) names.push_back(n.name);
      diag.error("--set", 0, node, "", "no such node" + did_you_mean(node, names));
      continue;
    }
    auto p = std::find_if(it->params.begin(), it->params.end(), [&](const ParamDecl& d) { return d.name == param; });
    if (p != it->params.end()) {
      p->value = value;
      p->line = 0;
    } else {
      it->params.push_back({param, value, 0});
    }
  }
}

Result<std::string> expand_variables(const std::string& text, const std::string& graph_file) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '$' && i + 1 < text.size() && text[i + 1] == '{') {
      auto close = text.find('}', i + 2);
      if (close == std::string::npos) { return Status::error("unterminated ${ in '" + text + "'"); }
      std::string var = text.substr(i + 2, close - i - 2);
      const char* env = std::getenv(var.c_str());
      if (env != nullptr) {
        out += env;
      } else if (var == "SACCADE_SAMPLE_DATA") {
        out += SACCADE_DEFAULT_SAMPLE_DATA;
      } else if (var == "GRAPH_DIR") {
        auto dir = std::filesystem::path(graph_file).parent_path().string();
        out += dir.empty() ? "." : dir;
      } else {
        return Status::error("unknown variable ${" + var + "} (not in the environment)");
      }
      i = close;
    } else {
      out += text[i];
    }
  }
  return out;
}

bool resolve_node(const NodeDecl& n, const Registry& registry, const std::string& file, Diagnostics& diag,
                  ResolvedNode& rn) {
  std::size_t errors_before = diag.error_count();
  rn.decl = n;
  const NodeTypeInfo* info = registry.find(n.plugin);
  if (info == nullptr) {
    std::string msg = "unknown plugin '" + n.plugin + "'" + did_you_mean(n.plugin, registry.types());
    std::string lib = n.plugin.substr(0, n.plugin.find('.'));
    for (const auto& e : registry.load_errors())
      if (e.find("saccade_" + lib + ".so") != std::string::npos) msg += "; its library failed to load: " + e;
    msg += "; " + registry.searched_summary();  // where it was looked for
    diag.error(file, n.line, n.name, "", msg);
  } else {
    rn.contract = info->contract;
    // Parameters: every given one known and well-formed, every required one given.
    std::set<std::string> given;
    std::vector<std::string> known;
    for (const auto& spec : rn.contract.params()) known.push_back(spec.name);
    for (const auto& p : n.params) {
      int line = p.line > 0 ? p.line : n.line;
      const ParamSpec* spec = rn.contract.find_param(p.name);
      if (spec == nullptr) {
        diag.error(file, line, n.name, "",
                   "unknown parameter '" + p.name + "' for plugin '" + n.plugin + "'" + did_you_mean(p.name, known));
        continue;
      }
      if (!given.insert(p.name).second) {
        diag.error(file, line, n.name, "", "parameter '" + p.name + "' given twice");
        continue;
      }
      Result<std::string> value = expand_variables(p.value, file);
      if (!value.ok()) {
        diag.error(file, line, n.name, "", "parameter '" + p.name + "': " + value.error());
        continue;
      }
      ParamValue v;
      if (Status parsed = parse_param(*spec, *value, v); !parsed.ok()) {
        diag.error(file, line, n.name, "",
                   "parameter '" + p.name + "' (" + std::string(to_string(spec->type)) + "): " + parsed.message() +
                       (p.line == 0 ? " [from --set]" : ""));
        continue;
      }
      rn.params.set(p.name, std::move(v));
    }
    for (const auto& spec : rn.contract.params()) {
      if (given.count(spec.name)) continue;
      if (spec.required) {
        diag.error(file, n.line, n.name, "", "missing required parameter '" + spec.name + "' (" + spec.doc + ")");
        continue;
      }
      if (!takes_default(spec)) continue;  // optional, no default: absent
      ParamValue v;
      // An unknown variable in a default is read as written (and its parse says what is wrong).
      Result<std::string> expanded = expand_variables(spec.default_value, file);
      const std::string& value = expanded.ok() ? *expanded : spec.default_value;
      if (Status parsed = parse_param(spec, value, v); !parsed.ok())
        diag.error(file, n.line, n.name, "",
                   "default of parameter '" + spec.name + "' is invalid: " + parsed.message());
      else
        rn.params.set(spec.name, std::move(v));
    }
    // Sync groups name existing trigger inputs, each in one group at most.
    std::set<std::string> in_group;
    for (const auto& s : n.syncs) {
      for (const auto& in : s.inputs) {
        const PortSpec* port = rn.contract.find_input(in);
        if (port == nullptr) {
          std::vector<std::string> inputs;
          for (const auto& ip : rn.contract.inputs()) inputs.push_back(ip.name);
          diag.error(file, s.line, n.name, in, "<sync> names an unknown input" + did_you_mean(in, inputs));
        } else if (port->kind == InputKind::kSide) {
          diag.error(file, s.line, n.name, in, "<sync> cannot pair a side input");
        } else if (!in_group.insert(in).second) {
          diag.error(file, s.line, n.name, in, "input is in two sync groups");
        }
      }
    }
  }
  return diag.error_count() == errors_before;
}

namespace {

// Where each resolved node is, by name; and the names, for "did you mean".
struct NodeIndex {
  std::map<std::string, int> index;
  std::vector<std::string> names;
};

NodeIndex resolve_nodes(const GraphDecl& graph, const Registry& registry, Diagnostics& diag, ResolvedGraph& out) {
  const std::string& file = graph.file;
  NodeIndex nodes;
  for (const auto& n : graph.nodes) {
    if (n.name.find('.') != std::string::npos) diag.error(file, n.line, n.name, "", "node names may not contain '.'");
    if (nodes.index.count(n.name)) {
      const NodeDecl* first = graph.find_node(n.name);
      diag.error(file, n.line, n.name, "",
                 "duplicate node name (first defined at line " + std::to_string(first->line) + ")");
      continue;
    }
    ResolvedNode rn;
    resolve_node(n, registry, file, diag, rn);
    nodes.index[n.name] = static_cast<int>(out.nodes.size());
    nodes.names.push_back(n.name);
    out.nodes.push_back(std::move(rn));
  }
  return nodes;
}

// When the graph declares processes, every node's process must be one of them.
void check_processes(const GraphDecl& graph, Diagnostics& diag) {
  const std::string& file = graph.file;
  std::vector<std::string> process_names;
  for (const auto& p : graph.processes) {
    if (std::find(process_names.begin(), process_names.end(), p.name) != process_names.end())
      diag.error(file, p.line, "", "", "duplicate <process> '" + p.name + "'");
    process_names.push_back(p.name);
  }
  if (!process_names.empty())
    for (const auto& n : graph.nodes)
      if (!n.process.empty() && std::find(process_names.begin(), process_names.end(), n.process) == process_names.end())
        diag.error(
            file, n.line, n.name, "",
            "process '" + n.process + "' is not declared by a <process>" + did_you_mean(n.process, process_names));
}

// An edge's own attributes and its endpoint nodes; false when any is wrong.
bool resolve_edge_decl(const EdgeDecl& e, const NodeIndex& nodes, const std::string& file, Diagnostics& diag,
                       ResolvedEdge& re) {
  re.line = e.line;
  re.delay = e.delay;
  re.qos = e.qos;
  bool ok = true;
  if (!e.qos.empty()) {
    if (Result<EdgeQos> qos = parse_edge_qos(e.qos, EdgeQos{}); !qos.ok()) {
      diag.error(file, e.line, e.to_node, e.to_port, qos.error());
      ok = false;
    }
  }
  auto from = nodes.index.find(e.from_node);
  auto to = nodes.index.find(e.to_node);
  if (from == nodes.index.end()) {
    diag.error(file, e.line, e.from_node, "", "edge from an unknown node" + did_you_mean(e.from_node, nodes.names));
    ok = false;
  }
  if (to == nodes.index.end()) {
    diag.error(file, e.line, e.to_node, "", "edge to an unknown node" + did_you_mean(e.to_node, nodes.names));
    ok = false;
  }
  auto queue = parse_queue_spec(e.queue);
  if (!queue) {
    diag.error(file, e.line, e.to_node, e.to_port,
               "queue must be latest, fifo:N or block:N (N from 1 to 65536), got '" + e.queue + "'");
    ok = false;
  } else {
    re.queue = *queue;
    if (e.delay == 1 && queue->policy == QueuePolicy::kBlock) {
      diag.error(file, e.line, e.to_node, e.to_port, "a delayed (feedback) edge cannot block its producer");
      ok = false;
    }
  }
  if (!ok) return false;
  re.from_node = from->second;
  re.to_node = to->second;
  return true;
}

// The edge's ports on its nodes' contracts, and their types agreeing; false
// when the edge is to be dropped.
bool resolve_edge_ports(const EdgeDecl& e, const ResolvedGraph& out, const std::string& file, Diagnostics& diag,
                        ResolvedEdge& re) {
  const ResolvedNode& fn = out.nodes[static_cast<std::size_t>(re.from_node)];
  const ResolvedNode& tn = out.nodes[static_cast<std::size_t>(re.to_node)];
  if (fn.contract.outputs().empty() && fn.contract.inputs().empty() && fn.contract.params().empty())
    return false;  // unknown plugin, already reported
  re.from_port = fn.contract.output_index(e.from_port);
  re.to_port = tn.contract.input_index(e.to_port);
  bool ok = true;
  if (re.from_port < 0) {
    std::vector<std::string> outs;
    for (const auto& p : fn.contract.outputs()) outs.push_back(p.name);
    std::string hint =
        fn.contract.find_input(e.from_port) ? " ('" + e.from_port + "' is an input)" : did_you_mean(e.from_port, outs);
    diag.error(file, e.line, e.from_node, e.from_port, "unknown output port of plugin '" + fn.decl.plugin + "'" + hint);
    ok = false;
  }
  if (re.to_port < 0 &&
      !(tn.contract.outputs().empty() && tn.contract.inputs().empty() && tn.contract.params().empty())) {
    std::vector<std::string> ins;
    for (const auto& p : tn.contract.inputs()) ins.push_back(p.name);
    std::string hint =
        tn.contract.find_output(e.to_port) ? " ('" + e.to_port + "' is an output)" : did_you_mean(e.to_port, ins);
    diag.error(file, e.line, e.to_node, e.to_port, "unknown input port of plugin '" + tn.decl.plugin + "'" + hint);
    ok = false;
  }
  if (!ok || re.to_port < 0) return false;
  const PortSpec& op = fn.contract.outputs()[static_cast<std::size_t>(re.from_port)];
  const PortSpec& ip = tn.contract.inputs()[static_cast<std::size_t>(re.to_port)];
  if (!port_types_match(op.type, ip.type)) {
    diag.error(
        file, e.line, e.to_node, e.to_port,
        "type mismatch: " + e.from_node + "." + e.from_port + " produces " + op.type + ", input expects " + ip.type);
    return false;
  }
  return true;
}

// The line of the edge feeding each (node, input).
using ProducerLines = std::map<std::pair<int, int>, int>;

ProducerLines resolve_edges(const GraphDecl& graph, const NodeIndex& nodes, Diagnostics& diag, ResolvedGraph& out) {
  const std::string& file = graph.file;
  ProducerLines producer_line;
  for (const auto& e : graph.edges) {
    ResolvedEdge re;
    if (!resolve_edge_decl(e, nodes, file, diag, re) || !resolve_edge_ports(e, out, file, diag, re)) continue;
    auto key = std::make_pair(re.to_node, re.to_port);
    if (auto it = producer_line.find(key); it != producer_line.end()) {
      diag.error(
          file, e.line, e.to_node, e.to_port,
          "input already has a producer (edge at line " + std::to_string(it->second) + "); one producer per input");
      continue;
    }
    producer_line[key] = e.line;
    out.edges.push_back(re);
  }
  return producer_line;
}

void check_required_inputs(const ResolvedGraph& out, const ProducerLines& producer_line, Diagnostics& diag) {
  for (std::size_t i = 0; i < out.nodes.size(); ++i) {
    const auto& n = out.nodes[i];
    for (std::size_t k = 0; k < n.contract.inputs().size(); ++k) {
      const auto& port = n.contract.inputs()[k];
      if (port.kind == InputKind::kTrigger && !producer_line.count({static_cast<int>(i), static_cast<int>(k)}))
        diag.error(out.file, n.decl.line, n.decl.name, port.name,
                   "required input is not connected (" + port.type + ": " + port.doc + ")");
    }
  }
}

// Cycles must pass through a delayed edge; the first one found is reported.
// Depth first with a stack of its own: a graph of tens of thousands of nodes
// in a chain would overflow the thread's stack by recursion.
void check_cycles(const ResolvedGraph& out, Diagnostics& diag) {
  std::vector<std::vector<const ResolvedEdge*>> adj(out.nodes.size());
  for (const auto& e : out.edges)
    if (e.delay == 0) adj[static_cast<std::size_t>(e.from_node)].push_back(&e);
  std::vector<int> state(out.nodes.size(), 0);  // 0 new, 1 on the path, 2 done
  struct Frame {
    int node;
    std::size_t next;  // the next of its edges to follow
  };
  std::vector<Frame> path;
  auto name = [&](int node) -> const std::string& { return out.nodes[static_cast<std::size_t>(node)].decl.name; };
  for (std::size_t root = 0; root < out.nodes.size(); ++root) {
    if (state[root] != 0) continue;
    path.push_back({static_cast<int>(root), 0});
    state[root] = 1;
    while (!path.empty()) {
      Frame& f = path.back();
      const auto& edges = adj[static_cast<std::size_t>(f.node)];
      if (f.next == edges.size()) {
        state[static_cast<std::size_t>(f.node)] = 2;
        path.pop_back();
        continue;
      }
      const ResolvedEdge* e = edges[f.next++];
      const int v = e->to_node;
      if (state[static_cast<std::size_t>(v)] == 1) {
        std::string cycle = name(v);
        bool on = false;
        for (const Frame& step : path) {
          if (step.node == v)
            on = true;
          else if (on)
            cycle += " -> " + name(step.node);
        }
        cycle += " -> " + name(v);
        diag.error(out.file, e->line, name(v), "",
                   "cycle without a delayed edge: " + cycle + " (mark the feedback edge delay=\"1\")");
        return;
      }
      if (state[static_cast<std::size_t>(v)] == 0) {
        state[static_cast<std::size_t>(v)] = 1;
        path.push_back({v, 0});
      }
    }
  }
}

}  // namespace

std::optional<ResolvedGraph> resolve_graph(const GraphDecl& graph, const Registry& registry, Diagnostics& diag) {
  ResolvedGraph out;
  static_cast<GraphAttributes&>(out) = graph;
  std::size_t errors_before = diag.error_count();
  NodeIndex nodes = resolve_nodes(graph, registry, diag, out);
  check_processes(graph, diag);
  ProducerLines producer_line = resolve_edges(graph, nodes, diag, out);
  check_required_inputs(out, producer_line, diag);
  check_cycles(out, diag);
  if (diag.error_count() > errors_before) return std::nullopt;
  return out;
}

std::string to_dot(const ResolvedGraph& graph) {
  std::string out = "digraph \"" + (graph.name.empty() ? std::string("saccade") : graph.name) + "\" {\n";
  out += "  rankdir=LR;\n  node [shape=record, fontname=\"Helvetica\"];\n";
  for (const auto& n : graph.nodes) {
    std::string ins, outs;
    for (const auto& p : n.contract.inputs()) ins += (ins.empty() ? "" : "|") + ("<i_" + p.name + "> " + p.name);
    for (const auto& p : n.contract.outputs()) outs += (outs.empty() ? "" : "|") + ("<o_" + p.name + "> " + p.name);
    out += "  \"" + n.decl.name + "\" [label=\"{{" + ins + "}|" + n.decl.name + "\\n(" + n.decl.plugin + ")|{" + outs +
           "}}\"];\n";
  }
  for (const auto& e : graph.edges) {
    const auto& f = graph.nodes[static_cast<std::size_t>(e.from_node)];
    const auto& t = graph.nodes[static_cast<std::size_t>(e.to_node)];
    out += "  \"" + f.decl.name + "\":\"o_" + f.contract.outputs()[static_cast<std::size_t>(e.from_port)].name +
           "\" -> \"" + t.decl.name + "\":\"i_" + t.contract.inputs()[static_cast<std::size_t>(e.to_port)].name +
           "\" [label=\"" + e.queue.text() + "\"" + (e.delay ? ", style=dashed, constraint=false" : "") + "];\n";
  }
  return out + "}\n";
}

}  // namespace saccade
