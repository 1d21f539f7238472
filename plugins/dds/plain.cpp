// The shared-memory forms of Image and Retina (idl/saccade_plain.idl).
// Loans: a writer fills a sample loaned from Fast DDS' data-sharing pool and
// writes it; a reader takes a loan on the writer's memory and copies the
// pixels once into a pooled message. Ring: the pixels stay in the writer's
// frame ring (frame_ring.hpp) and the sample says where; the reader's message
// views them in place. Nothing is serialised on the way.
#include "plain.hpp"

#include <atomic>
#include <cstring>

#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "saccade/log.hpp"
#include "saccade/cdr.hpp"
#include "saccade_plainPubSubTypes.h"

namespace saccade::dds {

namespace wp = saccade_plain;
namespace wc = saccade_plain::common;
namespace fdds = eprosima::fastdds::dds;
using cdr::kEndOfStream;

namespace {

void stamp_to_wire(const Message& in, wc::Stamp& out) {
  out.timestamp_ns(in.timestamp_ns);
  out.origin_ns(in.origin_ns);
  out.frame_id(in.frame_id);
  out.flags(0);
  out.mailbox(0);
  out.post(0);
}

void stamp_from_wire(const wc::Stamp& in, Message& out) {
  out.timestamp_ns = in.timestamp_ns();
  out.origin_ns = in.origin_ns();
  out.frame_id = in.frame_id();
}

void geometry_to_wire(const LevelGeometry& in, wc::LevelGeometry& out) {
  out.area().x(in.region.x);
  out.area().y(in.region.y);
  out.area().width(in.region.width);
  out.area().height(in.region.height);
  out.step_x(in.step_x);
  out.step_y(in.step_y);
}

LevelGeometry geometry_from_wire(const wc::LevelGeometry& in) {
  return {{in.area().x(), in.area().y(), in.area().width(), in.area().height()}, in.step_x(), in.step_y()};
}

void rectification_to_wire(const Rectification& in, wc::Rectification& out) {
  out.enabled(in.enabled);
  out.reserved().fill(0);
  std::copy(in.camera.val, in.camera.val + 9, out.camera().begin());
  std::copy(in.distortion.val, in.distortion.val + 14, out.distortion().begin());
  std::copy(in.rotation.val, in.rotation.val + 9, out.rotation().begin());
  std::copy(in.rectified.val, in.rectified.val + 9, out.rectified().begin());
  out.baseline(in.baseline);
}

Rectification rectification_from_wire(const wc::Rectification& in) {
  Rectification out;
  out.enabled = in.enabled();
  std::copy(in.camera().begin(), in.camera().end(), out.camera.val);
  std::copy(in.distortion().begin(), in.distortion().end(), out.distortion.val);
  std::copy(in.rotation().begin(), in.rotation().end(), out.rotation.val);
  std::copy(in.rectified().begin(), in.rectified().end(), out.rectified.val);
  out.baseline = in.baseline();
  return out;
}

std::string mib(std::size_t bytes) { return std::to_string(bytes >> 20) + " MiB"; }

// Packs `in`'s rows into data[offset..]; false when they do not fit.
template <std::size_t N>
bool pack(const cv::Mat& in, std::array<uint8_t, N>& data, uint32_t offset, wp::MatHeader& header, uint32_t& end) {
  const std::size_t row_bytes = static_cast<std::size_t>(in.cols) * in.elemSize();
  const std::size_t bytes = in.empty() ? 0 : row_bytes * static_cast<std::size_t>(in.rows);
  if (offset + bytes > N) return false;
  header.rows(in.empty() ? 0 : in.rows);
  header.cols(in.empty() ? 0 : in.cols);
  header.cv_type(in.type());
  header.offset(offset);
  if (bytes > 0) {
    if (in.isContinuous()) {
      std::memcpy(data.data() + offset, in.data, bytes);
    } else {
      for (int r = 0; r < in.rows; ++r)
        std::memcpy(data.data() + offset + row_bytes * static_cast<std::size_t>(r), in.ptr(r), row_bytes);
    }
  }
  end = static_cast<uint32_t>(offset + bytes);
  return true;
}

bool is_cv_type(int type) {
  return type >= 0 && CV_MAT_DEPTH(type) <= CV_16F && CV_MAT_CN(type) <= 4 && CV_MAT_TYPE(type) == type;
}

// A header no cv::Mat has: a side negative, one side zero, or no OpenCV type.
Status malformed_header(const wp::MatHeader& header) {
  return Status::error("a malformed image header (" + std::to_string(header.rows()) + "x" +
                       std::to_string(header.cols()) + ", type " + std::to_string(header.cv_type()) + ")");
}

// Unpacks a header's rows into `out` (its buffer reused when the size and type
// match). A header that points outside the used bytes, or names no OpenCV
// type, gives an empty mat and an error: a malformed sample, never a crash.
template <std::size_t N>
Status unpack(const wp::MatHeader& header, const std::array<uint8_t, N>& data, uint32_t size, cv::Mat& out) {
  if (header.rows() <= 0 || header.cols() <= 0) {
    out = cv::Mat();
    return header.rows() == 0 && header.cols() == 0 ? Status{} : malformed_header(header);
  }
  const int type = header.cv_type();
  if (!is_cv_type(type)) {
    out = cv::Mat();
    return malformed_header(header);
  }
  const std::size_t elem = CV_ELEM_SIZE(type);
  const std::size_t bytes = elem * static_cast<std::size_t>(header.rows()) * static_cast<std::size_t>(header.cols());
  const std::size_t used = std::min<std::size_t>(size, N);
  if (static_cast<std::size_t>(header.offset()) + bytes > used) {
    out = cv::Mat();
    return Status::error("an image of " + std::to_string(bytes) + " bytes at byte " + std::to_string(header.offset()) +
                         " of a sample that holds " + std::to_string(used));
  }
  make_exclusive(out);
  out.create(header.rows(), header.cols(), type);
  std::memcpy(out.data, data.data() + header.offset(), bytes);
  return {};
}

}  // namespace

template <class P>
Status to_plain(const Image& in, P& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  uint32_t end = 0;
  if (!pack(in.mat, out.data(), 0, out.mat(), end)) {
    return Status::error("a " + std::to_string(in.mat.cols) + "x" + std::to_string(in.mat.rows) + " image of " +
                         std::to_string(in.mat.total() * in.mat.elemSize()) +
                         " bytes does not fit the edge's shared-memory capacity (" + mib(out.data().size()) +
                         "); give the edge a larger one (qos=\"capacity=16M\")");
  }
  out.size(end);
  return {};
}

template <class P>
Status from_plain(const P& in, Image& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  return unpack(in.mat(), in.data(), in.size(), out.mat);
}

namespace {

// A retina's fields but its pixels, both shared-memory forms alike (the
// levels' MatHeaders are the form's own).
template <class P>
Status retina_fields_to(const Retina& in, P& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  out.source_width(in.source_size.width);
  out.source_height(in.source_size.height);
  out.fovea_x(in.fovea.x);
  out.fovea_y(in.fovea.y);
  out.sampling(static_cast<uint8_t>(in.sampling));
  rectification_to_wire(in.rectification, out.rectification());
  if (in.levels.size() > out.levels().size() || in.geometry.size() != in.levels.size())
    return Status::error("a retina of " + std::to_string(in.levels.size()) + " levels (" +
                         std::to_string(in.geometry.size()) +
                         " geometries) does not fit the shared-memory form (at most " +
                         std::to_string(out.levels().size()) + " levels, one geometry each)");
  out.level_count(static_cast<uint32_t>(in.levels.size()));
  for (std::size_t i = 0; i < in.levels.size(); ++i) geometry_to_wire(in.geometry[i], out.geometry()[i]);
  return {};
}

// A retina's fields but its pixels, and in `levels` the number of levels to
// read; an error when level_count is out of range (the levels the form holds
// are read still).
template <class P>
Status retina_fields_from(const P& in, Retina& out, std::size_t& levels) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  out.source_size = {in.source_width(), in.source_height()};
  out.fovea = {in.fovea_x(), in.fovea_y()};
  out.sampling = in.sampling() == 1 ? Retina::Sampling::kAreaMean : Retina::Sampling::kFivePoint;
  out.rectification = rectification_from_wire(in.rectification());
  levels = std::min<std::size_t>(in.level_count(), in.levels().size());
  out.levels.resize(levels);
  out.geometry.resize(levels);
  for (std::size_t i = 0; i < levels; ++i) out.geometry[i] = geometry_from_wire(in.geometry()[i]);
  out.source.reset();
  if (levels == in.level_count()) return {};
  return Status::error("a retina of " + std::to_string(in.level_count()) + " levels (at most " +
                       std::to_string(in.levels().size()) + ")");
}

}  // namespace

template <class P>
Status to_plain(const Retina& in, P& out) {
  if (Status s = retina_fields_to(in, out); !s.ok()) return s;
  uint32_t end = 0;
  for (std::size_t i = 0; i < in.levels.size(); ++i) {
    if (!pack(in.levels[i], out.data(), end, out.levels()[i], end))
      return Status::error("a retina of " + std::to_string(in.levels.size()) +
                           " levels does not fit the edge's shared-memory capacity (" + mib(out.data().size()) + ")");
  }
  out.size(end);
  return {};
}

// Every level the form holds is read, even after a malformed one; the error
// is the first.
template <class P>
Status from_plain(const P& in, Retina& out) {
  std::size_t n = 0;
  Status read = retina_fields_from(in, out, n);
  for (std::size_t i = 0; i < n; ++i) {
    Status level = unpack(in.levels()[i], in.data(), in.size(), out.levels[i]);
    if (read.ok() && !level.ok()) read = Status::error("level " + std::to_string(i) + ": " + level.message());
  }
  return read;
}

template Status to_plain(const Image&, wp::Image1M&);
template Status to_plain(const Image&, wp::Image4M&);
template Status to_plain(const Image&, wp::Image16M&);
template Status from_plain(const wp::Image1M&, Image&);
template Status from_plain(const wp::Image4M&, Image&);
template Status from_plain(const wp::Image16M&, Image&);
template Status to_plain(const Retina&, wp::Retina1M&);
template Status from_plain(const wp::Retina1M&, Retina&);

namespace {

// Orders the reads of a sample the writer's process may be rewriting.
inline void read_fence() {
#if defined(__SANITIZE_THREAD__)
  std::atomic_signal_fence(std::memory_order_acquire);  // TSan has no fences; it cannot see another process anyway
#else
  std::atomic_thread_fence(std::memory_order_acquire);
#endif
}

// Copies a sample loaned from a data-sharing writer's pool with `copy`; false
// when the writer took that memory for a newer sample meanwhile (so the copy
// may be torn). Fast DDS marks a payload dirty when the writer loans it,
// before any field is written: checking a field of our own (the frame id)
// is not enough, as a copy that began after the writer wrote it but before
// it wrote the rest would pass.
template <class P, class Copy>
bool copy_loaned(fdds::DataReader& reader, const P& sample, const fdds::SampleInfo& info, Copy&& copy) {
  read_fence();
  const bool copied = copy(sample);
  read_fence();
  return copied && reader.is_sample_valid(&sample, &info);
}

// Both shared-memory forms write a sample loaned from the data-sharing pool:
// `fill` fills it from `message`, or, without one, it says the stream ended.
// `fill` returns ok, kRingFull (nothing written, counted as a failed write
// like an exhausted pool: see is_ring_full) or why the message does not fit.
// `end` completes an end-of-stream sample.
template <class P, class Fill, class End>
Status write_loaned(fdds::DataWriter& writer, const Message* message, bool& written, Fill&& fill, End&& end) {
  written = false;
  void* memory = nullptr;
  if (writer.loan_sample(memory) != ReturnCode_t::RETCODE_OK) return {};  // pool exhausted: counted as a failed write
  P& sample = *static_cast<P*>(memory);
  if (message == nullptr) {
    sample.stamp().timestamp_ns(0);
    sample.stamp().origin_ns(0);
    sample.stamp().frame_id(-1);
    sample.stamp().flags(kEndOfStream);
    if constexpr (requires { sample.size(0u); }) sample.size(0);
    end(sample);
  } else if (Status filled = fill(sample); !filled.ok()) {
    writer.discard_loan(memory);
    return is_ring_full(filled) ? Status{} : filled;
  }
  written = writer.write(memory);
  if (!written) writer.discard_loan(memory);
  return {};
}

// A plain sample is never held by the bridge: the writer loans one per
// message from the data-sharing pool, the reader loans the writer's.
template <class M, class P>
class PlainSample final : public WireSample {
 public:
  Status write(fdds::DataWriter& writer, const Message* message, bool& written) override {
    return write_loaned<P>(
        writer, message, written, [&](P& sample) { return to_plain(static_cast<const M&>(*message), sample); },
        [](P&) {});
  }

  Taken take(fdds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) override {
    if (reader.take(samples_, infos_, 1) != ReturnCode_t::RETCODE_OK) return Taken::kNothing;
    Taken result = Taken::kUnreadable;
    if (samples_.length() == 1 && infos_[0].valid_data) {
      const P& sample = samples_[0];
      if (sample.stamp().flags() & kEndOfStream) {
        result = Taken::kEnd;
      } else {
        std::shared_ptr<M> m = fresh<M>(ctx, output, slot);
        // The writer's pool is a ring: a writer far ahead may reuse this
        // sample while it is copied. Dropped, never emitted torn.
        if (copy_loaned(reader, sample, infos_[0], [&](const P& from) { return from_plain(from, *m).ok(); })) {
          slot = std::move(m);
          result = Taken::kMessage;
        }
      }
    }
    reader.return_loan(samples_, infos_);
    return result;
  }

 private:
  FASTDDS_SEQUENCE(Samples, P);
  Samples samples_;
  fdds::SampleInfoSeq infos_;
};

// --- the frame ring ---

void ring_to_wire(const RingAddress& in, wp::RingRef& out) {
  out.writer_pid(in.writer_pid);
  out.ring_id(in.ring_id);
  out.slot(in.slot);
  out.generation(in.generation);
}

RingAddress ring_from_wire(const wp::RingRef& in) {
  return {.writer_pid = in.writer_pid(), .ring_id = in.ring_id(), .slot = in.slot(), .generation = in.generation()};
}

void mat_header(const cv::Mat& mat, std::size_t offset, wp::MatHeader& out) {
  out.rows(mat.empty() ? 0 : mat.rows);
  out.cols(mat.empty() ? 0 : mat.cols);
  out.cv_type(mat.type());
  out.offset(static_cast<uint32_t>(offset));
}

std::size_t packed_bytes(const cv::Mat& mat) { return mat.empty() ? 0 : mat.total() * mat.elemSize(); }

Status too_large(std::size_t bytes, const FrameRing& ring) {
  return Status::error("a frame of " + std::to_string(bytes) +
                       " bytes does not fit the edge's frame ring (buffers of " + mib(ring.slot_bytes()) +
                       "); give the edge a larger one (qos=\"capacity=16M\")");
}

// The mats' rows, packed one after another (each from a 64-byte boundary),
// into a fresh buffer of `ring` held by `hold`; their offsets in it. An
// error: kRingFull, or the frame is larger than a buffer.
template <std::size_t N>
Status copy_into_ring(const cv::Mat* const* mats, std::size_t n, FrameRing& ring, cv::Mat& hold,
                      std::array<std::size_t, N>& offsets) {
  std::size_t total = 0;
  for (std::size_t i = 0; i < n; ++i) {
    offsets[i] = total;
    total += (packed_bytes(*mats[i]) + 63) / 64 * 64;
  }
  if (total > ring.slot_bytes()) return too_large(total, ring);
  hold = ring.take(std::max<std::size_t>(total, 1));
  if (hold.empty()) return Status::error(kRingFull);
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Mat& m = *mats[i];
    if (m.empty()) continue;
    cv::Mat into(m.rows, m.cols, m.type(), hold.data + offsets[i]);
    m.copyTo(into);
  }
  return {};
}

// Where `mats` lie in one buffer of `ring`, when they all do (rows packed).
template <std::size_t N>
bool already_in_ring(const cv::Mat* const* mats, std::size_t n, const FrameRing& ring, RingAddress& at,
                     std::array<std::size_t, N>& offsets) {
  bool any = false;
  for (std::size_t i = 0; i < n; ++i) {
    const cv::Mat& m = *mats[i];
    if (m.empty()) {
      offsets[i] = 0;
      continue;
    }
    RingAddress here;
    if (!m.isContinuous() || !ring.locate(m, here, offsets[i])) return false;
    if (any && (here.slot != at.slot || here.generation != at.generation)) return false;
    at = here;
    any = true;
  }
  return any;
}

// Where `mats` lie in one buffer of `ring` (copied into a fresh one held by
// `hold` unless they lie there already); copy_into_ring's errors.
template <std::size_t N>
Status mats_to_ring(const cv::Mat* const* mats, std::size_t n, FrameRing& ring, cv::Mat& hold, RingAddress& at,
                    std::array<std::size_t, N>& offsets) {
  if (already_in_ring(mats, n, ring, at, offsets)) return {};  // the producer wrote into the ring: no copy
  if (Status s = copy_into_ring(mats, n, ring, hold, offsets); !s.ok()) return s;
  std::size_t base = 0;
  ring.locate(hold, at, base);
  for (std::size_t i = 0; i < n; ++i) offsets[i] += base;
  return {};
}

// The matrix `header` describes, in place in the ring `at` lies in.
Status view_ring(const wp::MatHeader& header, const RingAddress& at, RingReader& reader, cv::Mat& out) {
  if (header.rows() == 0 && header.cols() == 0) {
    out = cv::Mat();
    return {};
  }
  if (header.rows() < 0 || header.cols() < 0 || (header.rows() == 0) != (header.cols() == 0) ||
      !is_cv_type(header.cv_type())) {
    out = cv::Mat();
    return malformed_header(header);
  }
  return reader.view(at, header.offset(), header.rows(), header.cols(), header.cv_type(), out);
}

}  // namespace

Status to_ring(const Image& in, FrameRing& ring, cv::Mat& hold, wp::ImageRef& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  const cv::Mat* mats[] = {&in.mat};
  std::array<std::size_t, 1> offsets{};
  RingAddress at;
  if (Status s = mats_to_ring(mats, 1, ring, hold, at, offsets); !s.ok()) return s;
  mat_header(in.mat, offsets[0], out.mat());
  ring_to_wire(at, out.ring());
  return {};
}

Status to_ring(const Retina& in, FrameRing& ring, cv::Mat& hold, wp::RetinaRef& out) {
  if (Status s = retina_fields_to(in, out); !s.ok()) return s;
  std::array<const cv::Mat*, 16> mats{};
  for (std::size_t i = 0; i < in.levels.size(); ++i) mats[i] = &in.levels[i];
  std::array<std::size_t, 16> offsets{};
  RingAddress at;
  if (Status s = mats_to_ring(mats.data(), in.levels.size(), ring, hold, at, offsets); !s.ok()) return s;
  for (std::size_t i = 0; i < in.levels.size(); ++i) mat_header(in.levels[i], offsets[i], out.levels()[i]);
  ring_to_wire(at, out.ring());
  return {};
}

Status from_ring(const wp::ImageRef& in, RingReader& reader, Image& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  return view_ring(in.mat(), ring_from_wire(in.ring()), reader, out.mat);
}

Status from_ring(const wp::RetinaRef& in, RingReader& reader, Retina& out) {
  std::size_t n = 0;
  if (Status s = retina_fields_from(in, out, n); !s.ok()) return s;
  const RingAddress at = ring_from_wire(in.ring());
  for (std::size_t i = 0; i < n; ++i)
    if (Status s = view_ring(in.levels()[i], at, reader, out.levels[i]); !s.ok()) return s;
  return {};
}

namespace {

// The writer's frame ring is made at the first message (an edge that never
// carries one makes none); the reader maps each writer's ring as it appears.
template <class M, class P>
class RingSample final : public WireSample {
 public:
  RingSample(std::size_t capacity, uint32_t slots, ReaderWait wait) : capacity_(capacity), slots_(slots) {
    frames_.set_wait(wait);
  }

  cv::MatAllocator* frame_allocator() override { return make_ring().ok() ? ring_.get() : nullptr; }

  Status write(fdds::DataWriter& writer, const Message* message, bool& written) override {
    written = false;
    if (message != nullptr)
      if (Status s = make_ring(); !s.ok()) return s;
    cv::Mat hold;  // the buffer a copied frame went into, held until it is written
    // Posted to the ring's mailbox before DDS writes it: a reader there
    // takes it first (see FrameRing::post), and it counts as delivered to
    // them even if DDS then refuses it.
    auto post = [&](P& sample) {
      sample.ring().post(ring_->next_post());
      ring_->post(&sample, sizeof sample);
    };
    Status s = write_loaned<P>(
        writer, message, written,
        [&](P& sample) {
          Status placed = to_ring(static_cast<const M&>(*message), *ring_, hold, sample);
          if (placed.ok()) post(sample);
          return placed;
        },
        [&](P& sample) {
          // The end names the ring too, so that readers drop DDS' copy of what the mailbox gave them.
          sample.ring(wp::RingRef{});
          if (!ring_) return;
          ring_to_wire({.writer_pid = ring_->writer_pid(), .ring_id = ring_->ring_id()}, sample.ring());
          post(sample);
        });
    if (!hold.empty()) ++written_copied_;
    return s;
  }

  uint64_t frames_copied() const override { return written_copied_ + frames_.copied(); }

  // The mailbox of the ring the last sample came from first (its newest
  // sample, if newer than what this reader had), then DDS, whose copies of
  // what the mailbox gave are dropped.
  Taken take(fdds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) override {
    why_.clear();
    uint64_t post = 0;
    // Only while the followed ring is the one the count is of (a sample of
    // a new ring may have been refused after the reader followed it).
    if (frames_.follows(delivered_.ring()) && frames_.mail(delivered_.newest(), &copy_, sizeof copy_, post) &&
        delivered_.take(delivered_.ring(), post))
      return deliver(ctx, output, slot);
    for (;;) {
      if (reader.take(samples_, infos_, 1) != ReturnCode_t::RETCODE_OK) return Taken::kNothing;
      bool copied = samples_.length() == 1 && infos_[0].valid_data;
      if (copied) {
        // Fast DDS' keep-last pool may reuse the sample while it is copied.
        copied = copy_loaned(reader, samples_[0], infos_[0], [&](const P& from) {
          copy_ = from;
          return true;
        });
      }
      reader.return_loan(samples_, infos_);
      if (!copied) return Taken::kUnreadable;
      const RingAddress at = ring_from_wire(copy_.ring());
      post = copy_.ring().post();
      // A ring that cannot be opened says why when its frame is read.
      if (post != 0 && !frames_.follows(at)) (void)frames_.follow(at);
      if (post != 0 && frames_.follows(at)) {
        if (post > frames_.newest_post()) {
          // The writer posts before DDS writes: a number its mailbox never
          // reached is not one it sent (and would stop the mailbox for good).
          why_ = "a sample naming post " + std::to_string(post) + " of a ring that has made " +
                 std::to_string(frames_.newest_post());
          return Taken::kUnreadable;
        }
        if (!delivered_.take(at, post)) continue;  // the mailbox gave it already
      }
      return deliver(ctx, output, slot);
    }
  }

  // On the followed ring's doorbell.
  void wait(fdds::DataReader& reader, int timeout_ms) override {
    // Through DDS while the followed ring is not the one the count is of (see take()).
    const bool counted = frames_.follows(delivered_.ring());
    wait_on_doorbell(
        reader, timeout_ms, [&](int64_t ns) { return counted && frames_.wait_mail(delivered_.newest(), ns); },
        [&] { return counted && frames_.newest_post() > delivered_.newest(); });
  }

  uint64_t frames_mailed() const override { return frames_.mailed(); }

 private:
  Taken deliver(ProcessContext* ctx, int output, MessagePtr& slot) {
    if (copy_.stamp().flags() & kEndOfStream) return Taken::kEnd;
    std::shared_ptr<M> m = fresh<M>(ctx, output, slot);
    if (Status s = from_ring(copy_, frames_, *m); !s.ok()) {
      why_ = s.message();
      return Taken::kUnreadable;
    }
    slot = std::move(m);
    return Taken::kMessage;
  }

  // Makes the writer's ring unless it has one; why it cannot.
  Status make_ring() {
    if (ring_) return {};
    std::string warning;
    auto made = FrameRing::create(capacity_, slots_, &warning);
    if (!warning.empty()) log().warn("{}", warning);
    if (!made.ok()) return made.status();
    ring_ = std::move(made).value();
    return {};
  }

  std::size_t capacity_;
  uint32_t slots_;
  uint64_t written_copied_ = 0;  // frames the writer copied in (their producer did not write them there)
  std::shared_ptr<FrameRing> ring_;
  RingReader frames_;
  DeliveredPosts delivered_;
  P copy_;
  FASTDDS_SEQUENCE(Samples, P);
  Samples samples_;
  fdds::SampleInfoSeq infos_;
};

template <class M, class P, class T>
Codec ring_codec() {
  return Codec{M::kTypeName, Codec::Form::kRing, 0,
               +[]() -> std::unique_ptr<fdds::TopicDataType> { return std::make_unique<T>(); },
               +[](const WireOptions& o) -> std::unique_ptr<WireSample> {
                 return std::make_unique<RingSample<M, P>>(
                     o.capacity != 0 ? o.capacity : default_capacity(M::kTypeName), o.ring_slots, o.reader_wait);
               }};
}

template <class M, class P, class T>
Codec plain_codec(std::size_t capacity) {
  return Codec{
      M::kTypeName, Codec::Form::kPlain, capacity,
      +[]() -> std::unique_ptr<fdds::TopicDataType> { return std::make_unique<T>(); },
      +[](const WireOptions&) -> std::unique_ptr<WireSample> { return std::make_unique<PlainSample<M, P>>(); }};
}

}  // namespace

const std::vector<Codec>& plain_codecs() {
  static const std::vector<Codec> all = {
      plain_codec<Image, wp::Image1M, wp::Image1MPubSubType>(1u << 20),
      plain_codec<Image, wp::Image4M, wp::Image4MPubSubType>(4u << 20),
      plain_codec<Image, wp::Image16M, wp::Image16MPubSubType>(16u << 20),
      plain_codec<Retina, wp::Retina1M, wp::Retina1MPubSubType>(1u << 20),
  };
  return all;
}

const std::vector<Codec>& ring_codecs() {
  static const std::vector<Codec> all = {
      ring_codec<Image, wp::ImageRef, wp::ImageRefPubSubType>(),
      ring_codec<Retina, wp::RetinaRef, wp::RetinaRefPubSubType>(),
  };
  return all;
}

std::size_t default_capacity(std::string_view type) {
  // Image: up to 1280x1024 colour (3.9 MB); larger frames name a larger capacity.
  return type == Image::kTypeName ? 4u << 20 : 1u << 20;
}

const Codec* find_plain_codec(std::string_view type, std::size_t capacity) {
  if (capacity == 0) capacity = default_capacity(type);
  const Codec* best = nullptr;
  for (const auto& c : plain_codecs())
    if (c.type == type && c.capacity >= capacity && (best == nullptr || c.capacity < best->capacity)) best = &c;
  return best;
}

const Codec* find_ring_codec(std::string_view type) {
  for (const auto& c : ring_codecs())
    if (c.type == type) return &c;
  return nullptr;
}

}  // namespace saccade::dds
