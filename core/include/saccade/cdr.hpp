#pragma once
// Messages as CDR bytes (the plain XCDR1 form DDS, MCAP's "cdr" channels and
// Foxglove read) and the IDL that describes those bytes, both derived from the
// fields each type names once (message.hpp): no hand-written wire type, no
// conversion to keep in step. A message's bytes are its envelope (Message's
// stamp and the stream's flags), then its fields in order, then, for a type
// that refers to a Retina (FeatureMaps, FoveaState), that retina as a
// sequence of at most one.
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::cdr {

// What travels with every message beyond its fields (IDL: common::Stamp,
// after Message's timestamp_ns, origin_ns and frame_id).
struct Envelope {
  uint32_t flags = 0;    // kEndOfStream
  uint64_t mailbox = 0;  // the writer's same-host mailbox (plugins/dds/mailbox.hpp); 0: none
  uint64_t post = 0;     // this message's post number there
};
inline constexpr uint32_t kEndOfStream = 1u;

// Bytes of `message`'s CDR form, with its 4-byte encapsulation header.
template <class M>
std::size_t size_of(const M& message);

// Writes `message` into out[0, size_of(message)), little endian; returns the
// bytes written, or 0 when `capacity` is smaller than that.
template <class M>
std::size_t write(const M& message, const Envelope& envelope, uint8_t* out, std::size_t capacity);

// The same into `out`, resized to fit (its capacity is reused).
template <class M>
void write(const M& message, const Envelope& envelope, std::vector<uint8_t>& out);

// Reads `out` and `envelope` from size bytes written by write() or by any CDR
// writer of the IDL type (either endianness). An error saying what was wrong
// for bytes that are not such a message: too short, a sequence longer than
// the bytes, an enum value the type does not name, a matrix no cv::Mat can
// have. Buffers `out` already holds are reused. `spare`, for a type that
// carries a retina: a retina of an earlier message, refilled in place once
// nobody else holds it (a reader passes the same one every time and
// allocates none in steady state).
template <class M>
Status read(const uint8_t* data, std::size_t size, M& out, Envelope& envelope,
            std::shared_ptr<Retina>* spare = nullptr);

// The IDL (OMG IDL 4) of every described message type, module saccade_idl,
// as idl/saccade.idl holds it.
const std::string& idl();

// The IDL name of message type `type`: "saccade_idl::Region".
std::string idl_type_name(std::string_view type);

// The IDL of message type `type` alone, as idl() writes it (the building
// blocks it uses, the retina it carries, its struct); empty for a type
// visit_message does not know.
std::string idl_of(std::string_view type);

// A fingerprint of idl_of(type)'s declarations, its comments left out
// (64-bit FNV-1a): builds that write `type` in the same CDR layout have the
// same one. 0 for a type visit_message does not know.
uint64_t schema_fingerprint(std::string_view type);

}  // namespace saccade::cdr
