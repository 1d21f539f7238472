#include "virtual_bus.hpp"

#include <chrono>
#include <map>

namespace saccade::can {

namespace {
int64_t steady_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}
}  // namespace

std::shared_ptr<VirtualBus> VirtualBus::create() { return std::shared_ptr<VirtualBus>(new VirtualBus()); }

std::shared_ptr<VirtualBus> VirtualBus::named(const std::string& name) {
  static std::mutex mu;
  static std::map<std::string, std::shared_ptr<VirtualBus>> buses;
  std::lock_guard lock(mu);
  auto& bus = buses[name];
  if (!bus) bus = create();
  return bus;
}

std::unique_ptr<VirtualPort> VirtualBus::attach() {
  std::lock_guard lock(mu_);
  ports_.emplace_back();
  return std::make_unique<VirtualPort>(shared_from_this(), static_cast<int>(ports_.size()) - 1);
}

void VirtualBus::set_faults(Faults faults) {
  std::lock_guard lock(mu_);
  faults_ = faults;
  rng_.seed(faults.seed);
}

void VirtualBus::set_time(int64_t ns) {
  {
    std::lock_guard lock(mu_);
    if (sim_time_ns_ < 0) {
      // From the steady clock to simulated time: what was sent before is due now.
      for (PortState& p : ports_)
        for (Queued& q : p.queue) q.due_ns = q.frame.timestamp_ns = ns;
    }
    sim_time_ns_ = ns;
  }
  arrived_.notify_all();
}

int64_t VirtualBus::now() const {
  std::lock_guard lock(mu_);
  return now_locked();
}

int64_t VirtualBus::now_locked() const { return sim_time_ns_ >= 0 ? sim_time_ns_ : steady_ns(); }

void VirtualBus::enqueue(PortState& p, const Frame& f) {
  if (p.queue.full()) p.queue.set_capacity(2 * p.queue.capacity());
  p.queue.push_back({f.timestamp_ns, f});
}

bool VirtualBus::deliver(int from, const Frame& f) {
  {
    std::lock_guard lock(mu_);
    PortState& sender = ports_[static_cast<std::size_t>(from)];
    if (sender.state == BusState::kBusOff) {
      ++sender.counters.send_failed;
      return false;
    }
    ++sender.counters.sent;
    if (faults_.drop > 0 && std::uniform_real_distribution<double>(0, 1)(rng_) < faults_.drop) {
      ++sender.counters.dropped;
      return true;  // lost on the wire: the sender cannot tell
    }
    const int64_t now = now_locked();
    Frame stamped = f;
    stamped.timestamp_ns = now + faults_.delay_ns;
    for (std::size_t i = 0; i < ports_.size(); ++i) {
      PortState& p = ports_[i];
      if (static_cast<int>(i) == from || !p.attached || p.state == BusState::kBusOff) continue;
      if (!p.filters.passes(stamped)) {
        ++p.counters.filtered;
        continue;
      }
      enqueue(p, stamped);
    }
  }
  arrived_.notify_all();
  return true;
}

bool VirtualBus::take(int port, Frame& out, int64_t timeout_ns) {
  std::unique_lock lock(mu_);
  PortState& p = ports_[static_cast<std::size_t>(port)];
  const auto ready = [&] { return !p.queue.empty() && p.queue.front().due_ns <= now_locked(); };
  if (!ready()) {
    if (timeout_ns <= 0) return false;
    if (!arrived_.wait_for(lock, std::chrono::nanoseconds(timeout_ns), ready)) return false;
  }
  out = p.queue.front().frame;
  p.queue.pop_front();
  ++p.counters.received;
  if (out.error) ++p.counters.error_frames;
  return true;
}

void VirtualBus::set_port_state(int port, BusState s) {
  {
    std::lock_guard lock(mu_);
    PortState& p = ports_[static_cast<std::size_t>(port)];
    if (p.state == s) return;
    p.state = s;
    // The error frame a controller reports for the change (linux/can/error.h).
    Frame e;
    e.error = true;
    e.length = 8;
    if (s == BusState::kBusOff) {
      e.id = error_class::kBusOff;
    } else if (s == BusState::kErrorActive) {
      e.id = error_class::kRestarted | error_class::kController;
      e.data[1] = controller_status::kActive;
    } else {
      e.id = error_class::kController;
      e.data[1] = s == BusState::kErrorPassive ? controller_status::kRxPassive | controller_status::kTxPassive
                                               : controller_status::kRxWarning | controller_status::kTxWarning;
    }
    e.timestamp_ns = now_locked();
    if (s == BusState::kBusOff) p.queue.clear();  // a bus-off controller loses what it had not read
    if (p.filters.passes(e)) enqueue(p, e);
  }
  arrived_.notify_all();
}

VirtualPort::~VirtualPort() {
  std::lock_guard lock(bus_->mu_);
  bus_->ports_[static_cast<std::size_t>(index_)].attached = false;
  bus_->ports_[static_cast<std::size_t>(index_)].queue.clear();
}

bool VirtualPort::send(const Frame& f) { return bus_->deliver(index_, f); }

bool VirtualPort::receive(Frame& out, int64_t timeout_ns) { return bus_->take(index_, out, timeout_ns); }

void VirtualPort::set_filters(FilterSet filters) {
  std::lock_guard lock(bus_->mu_);
  bus_->ports_[static_cast<std::size_t>(index_)].filters = std::move(filters);
}

BusState VirtualPort::state() const {
  std::lock_guard lock(bus_->mu_);
  return bus_->ports_[static_cast<std::size_t>(index_)].state;
}

const BusCounters& VirtualPort::counters() const {
  std::lock_guard lock(bus_->mu_);
  snapshot_ = bus_->ports_[static_cast<std::size_t>(index_)].counters;
  return snapshot_;
}

}  // namespace saccade::can
