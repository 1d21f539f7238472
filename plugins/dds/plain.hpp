#pragma once
// The shared-memory forms of Image and Retina (idl/saccade_plain.idl): a plain fixed-capacity sample loaned from Fast
// DDS' data-sharing pool, or a small sample saying where the pixels are in the writer's frame ring (frame_ring.hpp);
// their codecs.
#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

#include "codec.hpp"
#include "frame_ring.hpp"
#include "saccade_plain.h"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade::dds {

// The shared-memory (plain, fixed-capacity) forms of the camera-rate types,
// written into and read from a caller's sample and message (reused buffers).
// to_plain: an error saying why the message does not fit. from_plain: an
// error for a malformed sample (what it could not read is left empty).
template <class P>
Status to_plain(const Image& in, P& out);
template <class P>
Status from_plain(const P& in, Image& out);
template <class P>
Status to_plain(const Retina& in, P& out);
template <class P>
Status from_plain(const P& in, Retina& out);

// The frame-ring forms (frame_ring.hpp): the sample says where the pixels
// are in the writer's ring. to_ring copies them into a free buffer of `ring`
// (held by `hold` until the sample is written) unless the producer wrote them
// there already; its error is kRingFull when every buffer is held (a failed
// write, not a fault: tell it with is_ring_full), else why the message does
// not fit. from_ring views them in place (pinned while `out` holds them), or
// returns why it cannot.
inline const std::string kRingFull = "every buffer of the frame ring is held";
// Whether `status` is to_ring's "every buffer is held".
inline bool is_ring_full(const Status& status) { return status.is_error() && status.message() == kRingFull; }
Status to_ring(const Image& in, FrameRing& ring, cv::Mat& hold, saccade_plain::ImageRef& out);
Status to_ring(const Retina& in, FrameRing& ring, cv::Mat& hold, saccade_plain::RetinaRef& out);
Status from_ring(const saccade_plain::ImageRef& in, RingReader& reader, Image& out);
Status from_ring(const saccade_plain::RetinaRef& in, RingReader& reader, Retina& out);

// Bytes a shared-memory sample or ring buffer of `type` holds unless the edge
// says otherwise: 4 MiB for Image, 1 MiB for Retina.
std::size_t default_capacity(std::string_view type);
// The plain codec of `type` with the smallest capacity >= `capacity` (0: the
// type's default: 4 MiB for Image, 1 MiB for Retina); nullptr when the type has
// none that large.
const Codec* find_plain_codec(std::string_view type, std::size_t capacity);
// The frame-ring codec of `type`; nullptr when the type has none.
const Codec* find_ring_codec(std::string_view type);
const std::vector<Codec>& plain_codecs();
const std::vector<Codec>& ring_codecs();

}  // namespace saccade::dds
