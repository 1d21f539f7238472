#pragma once
// A CAN frame, the kernel's filter semantics, and the interface every bus
// backend implements (SocketCAN, the cannelloni UDP tunnel, the in-process
// virtual bus). The CANopen master and the simulated drives only see `Bus`.
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "saccade/status.hpp"

namespace saccade::can {

// Flags of the kernel's can_id encoding (linux/can.h), used by filters and by
// the cannelloni wire format.
inline constexpr uint32_t kEffFlag = 0x80000000U;  // extended (29-bit) id
inline constexpr uint32_t kRtrFlag = 0x40000000U;  // remote transmission request
inline constexpr uint32_t kErrFlag = 0x20000000U;  // error frame
inline constexpr uint32_t kSffMask = 0x000007FFU;
inline constexpr uint32_t kEffMask = 0x1FFFFFFFU;
inline constexpr uint32_t kInvFilter = 0x20000000U;  // in a filter's id: match what does NOT pass

// Error classes of an error frame's id (linux/can/error.h) and the
// controller-status byte (data[1]) for CAN_ERR_CRTL.
namespace error_class {
inline constexpr uint32_t kTxTimeout = 0x001, kLostArbitration = 0x002, kController = 0x004, kProtocol = 0x008,
                          kTransceiver = 0x010, kNoAck = 0x020, kBusOff = 0x040, kBusError = 0x080, kRestarted = 0x100,
                          kAll = 0x1FFFFFFF;
}
namespace controller_status {
inline constexpr uint8_t kRxWarning = 0x04, kTxWarning = 0x08, kRxPassive = 0x10, kTxPassive = 0x20, kActive = 0x40;
}

struct Frame {
  uint32_t id = 0;  // 11 or 29 bits; an error frame: its error classes
  bool extended = false, rtr = false, error = false;
  bool fd = false;       // CAN FD: up to 64 bytes
  uint8_t fd_flags = 0;  // CANFD_BRS 0x01, CANFD_ESI 0x02
  uint8_t length = 0;    // 0..8 (classic), 0..64 (FD)
  std::array<uint8_t, 64> data{};
  int64_t timestamp_ns = 0;  // reception time (kernel timestamp, bus time)

  // The kernel's can_id: id plus the EFF / RTR / ERR flags.
  uint32_t raw_id() const { return id | (extended ? kEffFlag : 0) | (rtr ? kRtrFlag : 0) | (error ? kErrFlag : 0); }
  static Frame from_raw_id(uint32_t can_id);
  bool operator==(const Frame& o) const;  // id, flags, length and data; not the timestamp
};

std::string to_string(const Frame& f);  // "601 [8] 40 64 60 00 00 00 00 00", candump style

// Bits a classic data frame occupies on the wire, without stuffing: for bus
// load estimates.
int frame_bits(const Frame& f);

// One receive filter with the kernel's CAN_RAW_FILTER semantics: a frame
// passes when (frame.raw_id() & mask) == (id & mask); kInvFilter in `id`
// inverts it. Error frames bypass filters (the error mask selects them).
struct Filter {
  uint32_t id = 0, mask = 0;
  // Exactly this 11-bit id, data or remote frames of standard format only.
  static Filter exact(uint32_t sff_id) { return {sff_id, kSffMask | kEffFlag}; }
  bool matches(const Frame& f) const;
};

// What a socket lets through: any filter (or all of them, `join` as
// CAN_RAW_JOIN_FILTERS), and error frames whose classes meet `error_mask`.
// The kernel's default is one filter that passes everything and no errors.
struct FilterSet {
  std::vector<Filter> filters{Filter{0, 0}};
  bool join = false;
  uint32_t error_mask = 0;
  bool passes(const Frame& f) const;
};

enum class BusState : uint8_t { kErrorActive, kErrorWarning, kErrorPassive, kBusOff };
const char* to_string(BusState s);

struct BusCounters {
  uint64_t sent = 0, received = 0;
  uint64_t filtered = 0;         // arrived but stopped by the filters
  uint64_t send_failed = 0;      // not sent: bus off, buffer full (ENOBUFS), socket error
  uint64_t error_frames = 0;     // error frames delivered
  uint64_t malformed = 0;        // tunnel packets that did not decode
  uint64_t lost = 0;             // tunnel packets missing in the sequence
  uint64_t dropped = 0;          // frames the fault injection threw away
  uint64_t duplicated = 0;       // frames the fault injection sent twice (udp: their packet)
  uint64_t reordered = 0;        // frames the fault injection held back behind the next packet (udp)
  uint64_t corrupted = 0;        // frames in packets the fault injection altered a byte of (udp)
  uint64_t foreign = 0;          // tunnel packets from another address or port than the peer's
  uint64_t unauthenticated = 0;  // keyed tunnel: packets without a valid tag (none, wrong key, altered)
  uint64_t replayed = 0;         // keyed tunnel: authentic packets seen before, or of an earlier session
};

// Every counter by name, as the CAN nodes show them in their stats ("bus_" + name).
inline constexpr struct {
  const char* name;
  uint64_t BusCounters::*field;
} kBusCounterFields[] = {
    {"sent", &BusCounters::sent},
    {"received", &BusCounters::received},
    {"filtered", &BusCounters::filtered},
    {"send_failed", &BusCounters::send_failed},
    {"error_frames", &BusCounters::error_frames},
    {"malformed", &BusCounters::malformed},
    {"lost", &BusCounters::lost},
    {"dropped", &BusCounters::dropped},
    {"duplicated", &BusCounters::duplicated},
    {"reordered", &BusCounters::reordered},
    {"corrupted", &BusCounters::corrupted},
    {"foreign", &BusCounters::foreign},
    {"unauthenticated", &BusCounters::unauthenticated},
    {"replayed", &BusCounters::replayed},
};

class Bus {
 public:
  virtual ~Bus();
  // Sends (or, for the tunnel, queues until flush()) one frame; false when it
  // could not, counted in send_failed.
  virtual bool send(const Frame& f) = 0;
  // Sends what send() queued: the tunnel packs one control cycle into one packet.
  virtual void flush() {}
  // The next frame that passes the filters, waiting up to `timeout_ns` (0:
  // only what has already arrived).
  virtual bool receive(Frame& out, int64_t timeout_ns) = 0;
  virtual void set_filters(FilterSet filters) = 0;
  virtual BusState state() const = 0;
  virtual const BusCounters& counters() const = 0;
  virtual std::string describe() const = 0;
};

// How a bus is opened besides its spec.
struct BusOptions {
  // A udp bus: the file of the link's shared key (64 hex characters, readable
  // by its owner only); every packet is then authenticated. Empty: none.
  std::string key_file;
};

// Opens a bus from a spec: "virtual:NAME" (the process-wide virtual bus of
// that name), "udp:[BIND_ADDR:]LOCAL_PORT:HOST:PORT" (the cannelloni tunnel)
// or "socketcan:IFNAME". The open bus, or the error naming the spec and what
// is wrong with it or with opening it.
Result<std::unique_ptr<Bus>> open_bus(const std::string& spec, const BusOptions& options = {});

}  // namespace saccade::can
