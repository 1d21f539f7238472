#include "canopen.hpp"

#include <cstdio>

namespace saccade::can {

const char* to_string(DriveState s) {
  switch (s) {
    case DriveState::kNotReadyToSwitchOn: return "not ready to switch on";
    case DriveState::kSwitchOnDisabled: return "switch on disabled";
    case DriveState::kReadyToSwitchOn: return "ready to switch on";
    case DriveState::kSwitchedOn: return "switched on";
    case DriveState::kOperationEnabled: return "operation enabled";
    case DriveState::kQuickStopActive: return "quick stop active";
    case DriveState::kFaultReactionActive: return "fault reaction active";
    case DriveState::kFault: return "fault";
    case DriveState::kUnknown: break;
  }
  return "unknown";
}

DriveState decode_statusword(uint16_t sw) {
  // CiA 402: the state is in bits 0-3, 5 and 6 (xxxx xxxx x65x 3210).
  if ((sw & 0x004F) == 0x0000) return DriveState::kNotReadyToSwitchOn;
  if ((sw & 0x004F) == 0x0040) return DriveState::kSwitchOnDisabled;
  if ((sw & 0x006F) == 0x0021) return DriveState::kReadyToSwitchOn;
  if ((sw & 0x006F) == 0x0023) return DriveState::kSwitchedOn;
  if ((sw & 0x006F) == 0x0027) return DriveState::kOperationEnabled;
  if ((sw & 0x006F) == 0x0007) return DriveState::kQuickStopActive;
  if ((sw & 0x004F) == 0x000F) return DriveState::kFaultReactionActive;
  if ((sw & 0x004F) == 0x0008) return DriveState::kFault;
  return DriveState::kUnknown;
}

uint16_t encode_statusword(DriveState s) {
  switch (s) {
    case DriveState::kNotReadyToSwitchOn: return 0x0000;
    case DriveState::kSwitchOnDisabled: return 0x0040;
    case DriveState::kReadyToSwitchOn: return 0x0031;
    case DriveState::kSwitchedOn: return 0x0033;
    case DriveState::kOperationEnabled: return 0x0037;
    case DriveState::kQuickStopActive: return 0x0017;
    case DriveState::kFaultReactionActive: return 0x001F;
    case DriveState::kFault: return 0x0018;
    case DriveState::kUnknown: break;
  }
  return 0xFFFF;
}

DriveState next_state(DriveState s, uint16_t cw) {
  // Commands by their bits (fault reset 7, enable operation 3, quick stop 2,
  // enable voltage 1, switch on 0), as the profile's transitions read them.
  const bool fault_reset = cw & 0x80;
  const bool disable_voltage = (cw & 0x02) == 0;
  const bool quick_stop = (cw & 0x06) == 0x02;
  const bool shutdown = (cw & 0x87) == 0x06;
  const bool switch_on = (cw & 0x8F) == 0x07;
  const bool enable = (cw & 0x8F) == 0x0F;
  switch (s) {
    case DriveState::kFault: return fault_reset ? DriveState::kSwitchOnDisabled : s;
    case DriveState::kSwitchOnDisabled: return shutdown ? DriveState::kReadyToSwitchOn : s;
    case DriveState::kReadyToSwitchOn:
      if (disable_voltage || quick_stop) return DriveState::kSwitchOnDisabled;
      if (switch_on) return DriveState::kSwitchedOn;
      if (enable) return DriveState::kOperationEnabled;  // 2 and 3 in one
      return s;
    case DriveState::kSwitchedOn:
      if (disable_voltage || quick_stop) return DriveState::kSwitchOnDisabled;
      if (shutdown) return DriveState::kReadyToSwitchOn;
      if (enable) return DriveState::kOperationEnabled;
      return s;
    case DriveState::kOperationEnabled:
      if (disable_voltage) return DriveState::kSwitchOnDisabled;
      if (quick_stop) return DriveState::kQuickStopActive;
      if (shutdown) return DriveState::kReadyToSwitchOn;
      if (switch_on) return DriveState::kSwitchedOn;
      return s;
    case DriveState::kQuickStopActive:
      if (disable_voltage) return DriveState::kSwitchOnDisabled;
      if (enable) return DriveState::kOperationEnabled;
      return s;
    default: return s;
  }
}

uint32_t get_u32(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}

void put_u32(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}

namespace {
Frame frame(uint32_t id, uint8_t length) {
  Frame f;
  f.id = id;
  f.length = length;
  return f;
}
uint16_t get_u16(const uint8_t* p) { return static_cast<uint16_t>(p[0] | p[1] << 8); }
void put_u16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v & 0xFF);
  p[1] = static_cast<uint8_t>(v >> 8);
}
}  // namespace

const char* to_string(NmtState s) {
  switch (s) {
    case NmtState::kBootUp: return "boot-up";
    case NmtState::kStopped: return "stopped";
    case NmtState::kOperational: return "operational";
    case NmtState::kPreOperational: return "pre-operational";
  }
  return "unknown";
}

Frame nmt(NmtCommand command, int node) {
  Frame f = frame(cob::kNmt, 2);
  f.data[0] = static_cast<uint8_t>(command);
  f.data[1] = static_cast<uint8_t>(node);
  return f;
}

Frame heartbeat(int node, NmtState state) {
  Frame f = frame(cob::heartbeat(node), 1);
  f.data[0] = static_cast<uint8_t>(state);
  return f;
}

Frame sync_frame() { return frame(cob::kSync, 0); }

Frame emergency(int node, uint16_t error_code, uint8_t error_register) {
  Frame f = frame(cob::emergency(node), 8);
  put_u16(f.data.data(), error_code);
  f.data[2] = error_register;
  return f;
}

Frame sdo_frame(uint32_t cob_id, const Sdo& sdo) {
  Frame f = frame(cob_id, 8);
  const uint8_t unused = static_cast<uint8_t>(4 - sdo.size);
  switch (sdo.kind) {
    case Sdo::Kind::kDownloadRequest: f.data[0] = static_cast<uint8_t>(0x23 | unused << 2); break;
    case Sdo::Kind::kDownloadResponse: f.data[0] = 0x60; break;
    case Sdo::Kind::kUploadRequest: f.data[0] = 0x40; break;
    case Sdo::Kind::kUploadResponse: f.data[0] = static_cast<uint8_t>(0x43 | unused << 2); break;
    case Sdo::Kind::kAbort: f.data[0] = 0x80; break;
    case Sdo::Kind::kUnsupported: f.data[0] = 0x00; break;
  }
  put_u16(&f.data[1], sdo.index);
  f.data[3] = sdo.subindex;
  if (sdo.kind == Sdo::Kind::kDownloadRequest || sdo.kind == Sdo::Kind::kUploadResponse ||
      sdo.kind == Sdo::Kind::kAbort) {
    const uint32_t v =
        sdo.kind == Sdo::Kind::kAbort || sdo.size == 4 ? sdo.value : sdo.value & ((1u << (8 * sdo.size)) - 1);
    put_u32(&f.data[4], v);
  }
  return f;
}

bool parse_sdo(const Frame& f, Sdo& out) {
  if (f.length != 8 || f.rtr) return false;
  const uint8_t cmd = f.data[0];
  out = Sdo{};
  out.index = get_u16(&f.data[1]);
  out.subindex = f.data[3];
  out.value = get_u32(&f.data[4]);
  const bool expedited = (cmd & 0x02) != 0, size_given = (cmd & 0x01) != 0;
  out.size = size_given ? static_cast<uint8_t>(4 - ((cmd >> 2) & 0x03)) : 4;
  switch (cmd >> 5) {
    case 1:  // ccs 1: initiate download (client) ...
      out.kind = expedited ? Sdo::Kind::kDownloadRequest : Sdo::Kind::kUnsupported;
      break;
    case 2:  // ccs 2: initiate upload request (client) or scs 2: upload response (server)
      out.kind =
          cmd == 0x40 ? Sdo::Kind::kUploadRequest : (expedited ? Sdo::Kind::kUploadResponse : Sdo::Kind::kUnsupported);
      break;
    case 3: out.kind = Sdo::Kind::kDownloadResponse; break;  // scs 3
    case 4: out.kind = Sdo::Kind::kAbort; break;
    default: out.kind = Sdo::Kind::kUnsupported; break;
  }
  if (out.size < 4 && out.kind != Sdo::Kind::kAbort) out.value &= (1u << (8 * out.size)) - 1;
  return true;
}

std::string sdo_abort_text(uint32_t code) {
  switch (code) {
    case sdo_abort::kToggle: return "toggle bit not alternated";
    case sdo_abort::kTimeout: return "SDO protocol timed out";
    case sdo_abort::kUnknownCommand: return "command specifier not valid or unknown";
    case sdo_abort::kReadOnly: return "attempt to write a read only object";
    case sdo_abort::kNoObject: return "object does not exist in the object dictionary";
    case sdo_abort::kLengthMismatch: return "data type does not match, length of service parameter does not match";
    case sdo_abort::kNoSubindex: return "sub-index does not exist";
    case sdo_abort::kValueTooHigh: return "value of parameter written too high";
    case sdo_abort::kValueTooLow: return "value of parameter written too low";
    case sdo_abort::kGeneral: return "general error";
    default: break;
  }
  char buf[32];
  std::snprintf(buf, sizeof buf, "abort code 0x%08X", code);
  return buf;
}

Frame rpdo1(int node, uint16_t controlword, int8_t mode) {
  Frame f = frame(cob::rpdo1(node), 3);
  put_u16(f.data.data(), controlword);
  f.data[2] = static_cast<uint8_t>(mode);
  return f;
}

Frame rpdo2(int node, int32_t target) {
  Frame f = frame(cob::rpdo2(node), 4);
  put_u32(f.data.data(), static_cast<uint32_t>(target));
  return f;
}

Frame tpdo1(int node, uint16_t statusword, int8_t mode_display) {
  Frame f = frame(cob::tpdo1(node), 3);
  put_u16(f.data.data(), statusword);
  f.data[2] = static_cast<uint8_t>(mode_display);
  return f;
}

Frame tpdo2(int node, int32_t position, int32_t velocity) {
  Frame f = frame(cob::tpdo2(node), 8);
  put_u32(f.data.data(), static_cast<uint32_t>(position));
  put_u32(&f.data[4], static_cast<uint32_t>(velocity));
  return f;
}

bool parse_rpdo1(const Frame& f, uint16_t& controlword, int8_t& mode) {
  if (f.length != 3 || f.rtr) return false;
  controlword = get_u16(f.data.data());
  mode = static_cast<int8_t>(f.data[2]);
  return true;
}

bool parse_rpdo2(const Frame& f, int32_t& target) {
  if (f.length != 4 || f.rtr) return false;
  target = static_cast<int32_t>(get_u32(f.data.data()));
  return true;
}

bool parse_tpdo1(const Frame& f, uint16_t& statusword, int8_t& mode_display) {
  if (f.length != 3 || f.rtr) return false;
  statusword = get_u16(f.data.data());
  mode_display = static_cast<int8_t>(f.data[2]);
  return true;
}

bool parse_tpdo2(const Frame& f, int32_t& position, int32_t& velocity) {
  if (f.length != 8 || f.rtr) return false;
  position = static_cast<int32_t>(get_u32(f.data.data()));
  velocity = static_cast<int32_t>(get_u32(&f.data[4]));
  return true;
}

}  // namespace saccade::can
