#pragma once
// An in-process CAN bus: every frame one port sends reaches every other port
// (not itself, as a CAN_RAW socket without RECV_OWN_MSGS), through that
// port's filters. Its clock is the steady clock, or a simulated one that
// whoever drives the simulation sets; fault injection drops frames, delays
// them on that clock, and puts a port error-passive or bus-off. Thread-safe.
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <random>
#include <string>
#include <vector>

#include <boost/circular_buffer.hpp>

#include "bus.hpp"

namespace saccade::can {

class VirtualPort;

class VirtualBus : public std::enable_shared_from_this<VirtualBus> {
 public:
  struct Faults {
    double drop = 0.0;     // probability that a frame is lost for everyone
    int64_t delay_ns = 0;  // every frame arrives this much later (bus clock)
    uint64_t seed = 1;
  };

  static std::shared_ptr<VirtualBus> create();
  // The process-wide bus of that name, created on first use: nodes of one
  // graph meet on it.
  static std::shared_ptr<VirtualBus> named(const std::string& name);

  std::unique_ptr<VirtualPort> attach();
  void set_faults(Faults faults);

  // Simulated time: once set, the bus clock only moves when set again.
  void set_time(int64_t ns);
  int64_t now() const;

 private:
  friend class VirtualPort;
  struct Queued {
    int64_t due_ns;
    Frame frame;
  };
  struct PortState {
    // A ring that only grows (a deque allocates a block and frees one as
    // frames stream through): the bus carries frames without allocating.
    boost::circular_buffer<Queued> queue{64};
    FilterSet filters;
    BusState state = BusState::kErrorActive;
    BusCounters counters;
    bool attached = true;
  };
  VirtualBus() = default;
  int64_t now_locked() const;
  static void enqueue(PortState& p, const Frame& f);
  bool deliver(int from, const Frame& f);
  bool take(int port, Frame& out, int64_t timeout_ns);
  void set_port_state(int port, BusState s);

  mutable std::mutex mu_;
  std::condition_variable arrived_;
  std::vector<PortState> ports_;
  Faults faults_;
  std::mt19937_64 rng_{1};
  int64_t sim_time_ns_ = -1;
};

class VirtualPort final : public Bus {
 public:
  VirtualPort(std::shared_ptr<VirtualBus> bus, int index) : bus_(std::move(bus)), index_(index) {}
  ~VirtualPort() override;
  bool send(const Frame& f) override;
  bool receive(Frame& out, int64_t timeout_ns) override;
  void set_filters(FilterSet filters) override;
  BusState state() const override;
  const BusCounters& counters() const override;
  std::string describe() const override { return "virtual port " + std::to_string(index_); }
  // Fault injection: this port's controller goes error-passive, bus-off, or
  // back to error-active; the port receives the error frame a controller
  // would report.
  void inject_state(BusState s) { bus_->set_port_state(index_, s); }
  VirtualBus& bus() { return *bus_; }

 private:
  std::shared_ptr<VirtualBus> bus_;
  int index_;
  mutable BusCounters snapshot_;
};

}  // namespace saccade::can
