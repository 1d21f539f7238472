#include "saccade/testing.hpp"

#include <stdexcept>

namespace saccade::testing {

const Registry& default_registry() {
  static Registry* registry = [] {
    auto* r = new Registry();  // lives until exit: nodes may outlive any test
    r->load_folders(Registry::default_search_path());
    return r;
  }();
  return *registry;
}

Result<std::unique_ptr<NodeHarness>> NodeHarness::create(const std::string& node_xml, const Registry* registry) {
  if (registry == nullptr) registry = &default_registry();
  Diagnostics diag;
  std::string xml = node_xml;
  // A nameless node gets one, so it can stand in a graph.
  auto at = xml.find("<node");
  if (at != std::string::npos) {
    std::string tag = xml.substr(at, xml.find('>', at) - at);
    bool named = tag.find(" name=") != std::string::npos || tag.find("\tname=") != std::string::npos ||
                 tag.find("\nname=") != std::string::npos;
    if (!named) xml.insert(at + 5, " name=\"under_test\"");
  }
  GraphDecl graph = load_graph_string("<graph>" + xml + "</graph>", "<harness>", diag);
  if (!diag.has_errors() && graph.nodes.size() != 1)
    diag.error("<harness>", 1, "", "", "expected exactly one <node> element");
  std::unique_ptr<NodeHarness> h(new NodeHarness());
  if (!diag.has_errors()) resolve_node(graph.nodes.front(), *registry, "<harness>", diag, h->resolved_);
  if (diag.has_errors()) return Status::error(diag.format());
  Result<std::shared_ptr<Node>> node = registry->create(h->resolved_.decl.plugin);
  if (!node.ok()) return node.status();
  h->node_ = std::move(node).value();
  const Contract& c = h->resolved_.contract;
  h->slot_.name = h->resolved_.decl.name;
  h->slot_.contract = &h->resolved_.contract;
  h->slot_.params = &h->resolved_.params;
  h->slot_.current.resize(c.inputs().size());
  h->slot_.pools.resize(c.outputs().size());
  h->slot_.input_connected.assign(c.inputs().size(), true);
  h->slot_.output_connected.assign(c.outputs().size(), true);
  h->slot_.input_allocators.assign(c.inputs().size(), nullptr);
  h->slot_.output_allocators.assign(c.outputs().size(), nullptr);
  h->slot_.sink = h.get();
  h->stats_.name = h->resolved_.decl.name;
  h->stats_.plugin = h->resolved_.decl.plugin;
  h->slot_.stats = &h->stats_;
  h->emitted_.resize(c.outputs().size());
  OpenContext ctx(h->slot_);
  Status s = h->node_->open(ctx);
  if (!s.ok()) return Status::error("open failed: " + s.message());
  h->opened_ = true;
  return h;
}

NodeHarness::~NodeHarness() {
  if (opened_) node_->close();
  for (auto& m : slot_.current) m.reset();
  emitted_.clear();
  slot_.pools.clear();
}

void NodeHarness::set(const std::string& input, MessagePtr message) {
  int k = resolved_.contract.input_index(input);
  if (k < 0) throw std::invalid_argument("no input '" + input + "' on " + resolved_.decl.plugin);
  slot_.current[static_cast<std::size_t>(k)] = std::move(message);
}

Status NodeHarness::process() {
  slot_.trigger = nullptr;
  for (std::size_t k = 0; k < slot_.current.size(); ++k)
    if (slot_.current[k] && resolved_.contract.inputs()[k].kind != InputKind::kSide) {
      slot_.trigger = slot_.current[k].get();
      break;
    }
  ProcessContext ctx(slot_);
  return node_->process(ctx);
}

void NodeHarness::set_frame_allocator(const std::string& output, cv::MatAllocator* allocator) {
  int k = resolved_.contract.output_index(output);
  if (k < 0) throw std::invalid_argument("no output '" + output + "' on " + resolved_.decl.plugin);
  slot_.output_allocators[static_cast<std::size_t>(k)] = allocator;
}

const std::vector<MessagePtr>& NodeHarness::outputs(const std::string& output) const {
  int k = resolved_.contract.output_index(output);
  if (k < 0) throw std::invalid_argument("no output '" + output + "' on " + resolved_.decl.plugin);
  return emitted_[static_cast<std::size_t>(k)];
}

const Histogram& NodeHarness::timing(const std::string& name) const {
  for (const auto& t : stats_.timings)
    if (t->name == name) return t->histogram;
  throw std::logic_error("node '" + slot_.name + "' has no timing '" + name + "'");
}

uint64_t NodeHarness::counter(const std::string& name) const {
  for (const auto& c : stats_.counters)
    if (c->name == name) return c->value.load();
  throw std::logic_error("node '" + slot_.name + "' has no counter '" + name + "'");
}

void NodeHarness::clear_outputs() {
  for (auto& e : emitted_) e.clear();
}

void NodeHarness::emit(int output, MessagePtr message) {
  emitted_[static_cast<std::size_t>(output)].push_back(std::move(message));
}

Recorder& Recorder::instance() {
  static Recorder r;
  return r;
}

void Recorder::record(const std::string& key, MessagePtr message) {
  std::lock_guard lock(mu_);
  messages_[key].push_back(std::move(message));
}

std::vector<MessagePtr> Recorder::get(const std::string& key) const {
  std::lock_guard lock(mu_);
  auto it = messages_.find(key);
  return it == messages_.end() ? std::vector<MessagePtr>{} : it->second;
}

void Recorder::clear() {
  std::lock_guard lock(mu_);
  messages_.clear();
}

}  // namespace saccade::testing
