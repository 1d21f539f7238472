#include "bus.hpp"

#include <algorithm>
#include <cstdio>

#include "cannelloni.hpp"
#include "socketcan.hpp"
#include "virtual_bus.hpp"

namespace saccade::can {

Bus::~Bus() = default;

Frame Frame::from_raw_id(uint32_t can_id) {
  Frame f;
  f.extended = (can_id & kEffFlag) != 0;
  f.rtr = (can_id & kRtrFlag) != 0;
  f.error = (can_id & kErrFlag) != 0;
  f.id = can_id & (f.extended || f.error ? kEffMask : kSffMask);
  return f;
}

bool Frame::operator==(const Frame& o) const {
  return id == o.id && extended == o.extended && rtr == o.rtr && error == o.error && fd == o.fd &&
         fd_flags == o.fd_flags && length == o.length &&
         std::equal(data.begin(), data.begin() + (rtr ? 0 : length), o.data.begin());
}

std::string to_string(const Frame& f) {
  char buf[16];
  std::snprintf(buf, sizeof buf, f.extended ? "%08X" : "%03X", f.id);
  std::string s = buf;
  if (f.error) s += " ERR";
  if (f.fd) s += " FD";
  std::snprintf(buf, sizeof buf, " [%u]", f.length);
  s += buf;
  if (f.rtr) return s + " remote";
  for (int i = 0; i < f.length; ++i) {
    std::snprintf(buf, sizeof buf, " %02X", f.data[static_cast<std::size_t>(i)]);
    s += buf;
  }
  return s;
}

int frame_bits(const Frame& f) {
  // SOF, id, RTR/IDE/r0, DLC, data, CRC + delimiter, ACK + delimiter, EOF, interframe space.
  const int header = f.extended ? 1 + 29 + 3 + 4 : 1 + 11 + 3 + 4;
  return header + (f.rtr ? 0 : 8 * f.length) + 16 + 2 + 7 + 3;
}

bool Filter::matches(const Frame& f) const {
  if (f.error) return false;
  // As can_rcv_list_find() prepares a filter: the ERR bit of the mask is for
  // the error list, and a standard-format filter ignores the extended id bits.
  uint32_t m = mask & ~kErrFlag;
  const uint32_t want = id & ~kInvFilter;
  if ((m & kEffFlag) != 0 && (want & kEffFlag) == 0) m &= kSffMask | kEffFlag | kRtrFlag;
  const bool hit = (f.raw_id() & m) == (want & m);
  return (id & kInvFilter) != 0 ? !hit : hit;
}

bool FilterSet::passes(const Frame& f) const {
  if (f.error) return (f.id & error_mask) != 0;
  if (filters.empty()) return false;
  if (join) return std::all_of(filters.begin(), filters.end(), [&](const Filter& x) { return x.matches(f); });
  return std::any_of(filters.begin(), filters.end(), [&](const Filter& x) { return x.matches(f); });
}

const char* to_string(BusState s) {
  switch (s) {
    case BusState::kErrorActive: return "error active";
    case BusState::kErrorWarning: return "error warning";
    case BusState::kErrorPassive: return "error passive";
    case BusState::kBusOff: return "bus off";
  }
  return "?";
}

namespace {
// A backend's open result as a Bus.
template <class Backend>
Result<std::unique_ptr<Bus>> as_bus(Result<std::unique_ptr<Backend>> opened) {
  if (!opened.ok()) return opened.status();
  return std::unique_ptr<Bus>(std::move(opened).value());
}
}  // namespace

Result<std::unique_ptr<Bus>> open_bus(const std::string& spec, const BusOptions& options) {
  const auto colon = spec.find(':');
  const std::string kind = spec.substr(0, colon), rest = colon == std::string::npos ? "" : spec.substr(colon + 1);
  if (!options.key_file.empty() && kind != "udp")
    return Status::error("bus '" + spec + "': key_file '" + options.key_file + "' is for a udp bus only (a " + kind +
                         " bus carries no key)");
  if (kind == "virtual") {
    if (rest.empty()) return Status::error("bus '" + spec + "': expected virtual:NAME");
    return std::unique_ptr<Bus>(VirtualBus::named(rest)->attach());
  }
  if (kind == "udp") {
    if (options.key_file.empty()) return as_bus(UdpTunnel::open(rest));
    cannelloni::Key key;
    if (Status loaded = cannelloni::load_key(options.key_file, key); !loaded.ok()) return loaded;
    return as_bus(UdpTunnel::open(rest, &key));
  }
  if (kind == "socketcan") return as_bus(SocketCan::open(rest));
  return Status::error("bus '" + spec +
                       "': expected virtual:NAME, udp:[BIND_ADDR:]LOCAL_PORT:HOST:PORT or socketcan:IFNAME");
}

}  // namespace saccade::can
