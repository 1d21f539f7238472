#pragma once
// CANopen (CiA 301) and the CiA 402 drive profile, as the head's drives speak
// them: COB-IDs, NMT, heartbeat, SYNC, emergency, expedited SDO, the default
// PDO mapping of a 402 drive, the power state machine and profile position
// mode's handshake bits. Pure encoding and decoding: the master (master.hpp)
// and the simulated drive (drive_sim.hpp) build on it.
#include <cstdint>
#include <string>

#include "bus.hpp"

namespace saccade::can {

// COB-IDs of node n (1..127).
namespace cob {
constexpr uint32_t kNmt = 0x000, kSync = 0x080;
constexpr uint32_t emergency(int n) { return 0x080 + static_cast<uint32_t>(n); }
constexpr uint32_t tpdo1(int n) { return 0x180 + static_cast<uint32_t>(n); }
constexpr uint32_t rpdo1(int n) { return 0x200 + static_cast<uint32_t>(n); }
constexpr uint32_t tpdo2(int n) { return 0x280 + static_cast<uint32_t>(n); }
constexpr uint32_t rpdo2(int n) { return 0x300 + static_cast<uint32_t>(n); }
constexpr uint32_t sdo_response(int n) { return 0x580 + static_cast<uint32_t>(n); }  // server -> client
constexpr uint32_t sdo_request(int n) { return 0x600 + static_cast<uint32_t>(n); }   // client -> server
constexpr uint32_t heartbeat(int n) { return 0x700 + static_cast<uint32_t>(n); }
constexpr int node_of(uint32_t id) { return static_cast<int>(id & 0x7F); }
constexpr uint32_t function_of(uint32_t id) { return id & 0x780; }
}  // namespace cob

// NMT commands (byte 0 of an NMT frame) and the states a heartbeat reports.
enum class NmtCommand : uint8_t {
  kStart = 0x01,
  kStop = 0x02,
  kPreOperational = 0x80,
  kResetNode = 0x81,
  kResetCommunication = 0x82
};
enum class NmtState : uint8_t { kBootUp = 0x00, kStopped = 0x04, kOperational = 0x05, kPreOperational = 0x7F };
const char* to_string(NmtState s);
Frame nmt(NmtCommand command, int node);  // node 0: every node
Frame heartbeat(int node, NmtState state);
Frame sync_frame();
Frame emergency(int node, uint16_t error_code, uint8_t error_register);

// Objects of the dictionary the head uses.
namespace object {
constexpr uint16_t kProducerHeartbeatTime = 0x1017;  // u16, ms
constexpr uint16_t kTpdo1Communication = 0x1800;     // sub 2: transmission type (u8)
constexpr uint16_t kControlword = 0x6040, kStatusword = 0x6041;
constexpr uint16_t kModesOfOperation = 0x6060, kModesOfOperationDisplay = 0x6061;  // i8
constexpr uint16_t kPositionActual = 0x6064, kVelocityActual = 0x606C;             // i32 counts, counts/s
constexpr uint16_t kFollowingErrorWindow = 0x6065;                                 // u32 counts
constexpr uint16_t kFollowingErrorTimeout = 0x6066;                                // u16 ms
constexpr uint16_t kTargetPosition = 0x607A;                                       // i32 counts
constexpr uint16_t kSoftwarePositionLimit = 0x607D;                                // sub 1 min, 2 max, i32
constexpr uint16_t kProfileVelocity = 0x6081, kProfileAcceleration = 0x6083, kProfileDeceleration = 0x6084;
}  // namespace object
constexpr int8_t kProfilePositionMode = 1;
// A PDO's transmission type (sub-index 2 of its communication parameter):
// on every SYNC, or event-driven (a TPDO sent when its data change, an RPDO
// acted on when it arrives).
namespace transmission {
constexpr uint8_t kEverySync = 1, kOnChange = 255;
}

// Emergency error codes the simulated drive raises.
namespace emcy {
constexpr uint16_t kNoError = 0x0000, kFollowingError = 0x8611, kHeartbeat = 0x8130, kGeneric = 0x1000;
}

// Expedited SDO (at most 4 bytes). The client sends a request on
// 0x600+n, the server answers on 0x580+n.
struct Sdo {
  enum class Kind : uint8_t {
    kDownloadRequest,   // write: client -> server
    kDownloadResponse,  // write acknowledged
    kUploadRequest,     // read
    kUploadResponse,    // the value read
    kAbort,             // either side: `value` holds the abort code
    kUnsupported,       // segmented or block transfer: not spoken here
  };
  Kind kind = Kind::kUnsupported;
  uint16_t index = 0;
  uint8_t subindex = 0;
  uint32_t value = 0;
  uint8_t size = 4;  // bytes of `value` that count (1, 2 or 4)
};
namespace sdo_abort {
constexpr uint32_t kToggle = 0x05030000, kTimeout = 0x05040000, kUnknownCommand = 0x05040001, kReadOnly = 0x06010002,
                   kNoObject = 0x06020000, kLengthMismatch = 0x06070010, kNoSubindex = 0x06090011,
                   kValueTooHigh = 0x06090031, kValueTooLow = 0x06090032, kGeneral = 0x08000000;
}
Frame sdo_frame(uint32_t cob_id, const Sdo& sdo);
// False when the frame is not 8 bytes long.
bool parse_sdo(const Frame& f, Sdo& out);
std::string sdo_abort_text(uint32_t code);

// CiA 402 power states, decoded from the statusword.
enum class DriveState {
  kNotReadyToSwitchOn,
  kSwitchOnDisabled,
  kReadyToSwitchOn,
  kSwitchedOn,
  kOperationEnabled,
  kQuickStopActive,
  kFaultReactionActive,
  kFault,
  kUnknown
};
const char* to_string(DriveState s);
DriveState decode_statusword(uint16_t statusword);
uint16_t encode_statusword(DriveState s);  // the state's bits (bit 4 voltage enabled set where the profile has it)

// Controlword commands.
namespace control {
constexpr uint16_t kShutdown = 0x0006, kSwitchOn = 0x0007, kEnableOperation = 0x000F, kDisableVoltage = 0x0000,
                   kQuickStop = 0x0002, kDisableOperation = 0x0007, kFaultReset = 0x0080;
}

// The drive's next state for a controlword (the CiA 402 transitions); the
// state itself where the command does not apply.
DriveState next_state(DriveState s, uint16_t controlword);

// The default PDO mapping of a CiA 402 drive.
// RPDO1: controlword (u16) + modes of operation (i8); RPDO2: target position (i32);
// TPDO1: statusword (u16) + modes of operation display (i8);
// TPDO2: position actual (i32) + velocity actual (i32). Little-endian.
Frame rpdo1(int node, uint16_t controlword, int8_t mode = kProfilePositionMode);
Frame rpdo2(int node, int32_t target_position);
Frame tpdo1(int node, uint16_t statusword, int8_t mode_display = kProfilePositionMode);
Frame tpdo2(int node, int32_t position_actual, int32_t velocity_actual);
// Each false when the frame's length does not fit the mapping.
bool parse_rpdo1(const Frame& f, uint16_t& controlword, int8_t& mode);
bool parse_rpdo2(const Frame& f, int32_t& target_position);
bool parse_tpdo1(const Frame& f, uint16_t& statusword, int8_t& mode_display);
bool parse_tpdo2(const Frame& f, int32_t& position_actual, int32_t& velocity_actual);

// Profile position mode: the controlword's set-point bits and the
// statusword's answers.
namespace pp {
constexpr uint16_t kNewSetPoint = 1u << 4, kChangeSetImmediately = 1u << 5, kRelative = 1u << 6, kHalt = 1u << 8;
constexpr uint16_t kTargetReached = 1u << 10, kSetPointAcknowledge = 1u << 12, kFollowingError = 1u << 13;
constexpr uint16_t kWarning = 1u << 7, kRemote = 1u << 9;
}  // namespace pp

uint32_t get_u32(const uint8_t* p);
void put_u32(uint8_t* p, uint32_t v);

}  // namespace saccade::can
