#pragma once
// SocketCAN (CAN_RAW): non-blocking, with the kernel's filters and error
// frames, CAN FD frames accepted, kernel receive timestamps (SO_TIMESTAMPNS),
// and ENOBUFS (the interface's queue full) counted rather than fatal. Always
// compiled; it only needs a kernel with CAN sockets at run time.
#include <memory>
#include <string>

#include "bus.hpp"

namespace saccade::can {

class SocketCan final : public Bus {
 public:
  // The open socket, or the error naming the interface and the reason (no
  // CAN support in this kernel, no such interface, ...).
  static Result<std::unique_ptr<SocketCan>> open(const std::string& interface);
  ~SocketCan() override;

  bool send(const Frame& f) override;
  bool receive(Frame& out, int64_t timeout_ns) override;
  void set_filters(FilterSet filters) override;
  BusState state() const override { return state_; }
  const BusCounters& counters() const override { return counters_; }
  std::string describe() const override { return "socketcan " + interface_; }
  const std::string& last_error() const { return last_error_; }

 private:
  SocketCan(int fd, std::string interface) : fd_(fd), interface_(std::move(interface)) {}
  void track_state(const Frame& error_frame);

  int fd_;
  std::string interface_;
  BusState state_ = BusState::kErrorActive;
  uint32_t error_mask_ = 0;  // the error classes the user asked for
  BusCounters counters_;
  std::string last_error_;
};

}  // namespace saccade::can
