#include "saccade/node.hpp"

#include <chrono>
#include <stdexcept>

#include "saccade/stats.hpp"

namespace saccade {

EmitSink::~EmitSink() = default;
Node::~Node() = default;

int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

int checked_port(const NodeSlot& slot, const std::vector<PortSpec>& ports, const char* kind, std::string_view name,
                 std::string_view type) {
  for (std::size_t i = 0; i < ports.size(); ++i) {
    if (ports[i].name != name) continue;
    // A node may take any output as a plain Message (the DDS bridges do).
    if (ports[i].type != type && type != kAnyType)
      throw std::logic_error(std::string(kind) + " '" + std::string(name) + "' carries " + ports[i].type + ", not " +
                             std::string(type));
    return static_cast<int>(i);
  }
  throw std::logic_error("node '" + slot.name + "' has no " + kind + " '" + std::string(name) + "'");
}

}  // namespace

namespace {

// The entry of that name (NamedCounter, NamedTiming), added at the end if new.
template <class Named>
Named& named(const NodeSlot& slot, std::vector<std::unique_ptr<Named>>* all, std::string_view name) {
  if (all == nullptr) throw std::logic_error("node '" + slot.name + "' has no stats to count or time in");
  for (auto& entry : *all)
    if (entry->name == name) return *entry;
  all->push_back(std::make_unique<Named>());
  all->back()->name = std::string(name);
  return *all->back();
}

}  // namespace

std::atomic<uint64_t>& OpenContext::counter(std::string_view name) const {
  return named(*slot_, slot_->stats != nullptr ? &slot_->stats->counters : nullptr, name).value;
}

Histogram& OpenContext::timing(std::string_view name) const {
  return named(*slot_, slot_->stats != nullptr ? &slot_->stats->timings : nullptr, name).histogram;
}

std::size_t input_port_index(const NodeSlot& slot, const void* key, std::string_view name) {
  const int i = slot.contract->input_index(key);
  if (i < 0)
    throw std::logic_error("node '" + slot.name + "': input constant '" + std::string(name) +
                           "' is not in its contract");
  return static_cast<std::size_t>(i);
}

std::size_t output_port_index(const NodeSlot& slot, const void* key, std::string_view name) {
  const int i = slot.contract->output_index(key);
  if (i < 0)
    throw std::logic_error("node '" + slot.name + "': output constant '" + std::string(name) +
                           "' is not in its contract");
  return static_cast<std::size_t>(i);
}

int OpenContext::checked_input(std::string_view name, std::string_view type) const {
  return checked_port(*slot_, slot_->contract->inputs(), "input", name, type);
}

int OpenContext::checked_output(std::string_view name, std::string_view type) const {
  return checked_port(*slot_, slot_->contract->outputs(), "output", name, type);
}

}  // namespace saccade
