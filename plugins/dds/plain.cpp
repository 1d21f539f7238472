// The shared-memory forms of Image and Retina (idl/saccade.idl, module plain):
// a writer fills a sample loaned from Fast DDS' data-sharing pool and writes
// it; a reader takes a loan on the writer's memory and copies the pixels once
// into a pooled message. Nothing is serialised on the way.
#include <atomic>
#include <cstring>

#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "saccadePubSubTypes.h"
#include "wire.hpp"

namespace saccade::dds {

namespace wp = saccade_idl::plain;
namespace fdds = eprosima::fastdds::dds;

namespace {

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

// Unpacks a header's rows into `out` (its buffer reused when the size and type
// match). A header that points outside the used bytes, or names no OpenCV
// type, gives an empty mat: a malformed sample, never a crash.
template <std::size_t N>
bool unpack(const wp::MatHeader& header, const std::array<uint8_t, N>& data, uint32_t size, cv::Mat& out) {
  if (header.rows() <= 0 || header.cols() <= 0) {
    out = cv::Mat();
    return header.rows() == 0 && header.cols() == 0;
  }
  const int type = header.cv_type();
  if (type < 0 || CV_MAT_DEPTH(type) > CV_16F || CV_MAT_CN(type) > 4 || CV_MAT_TYPE(type) != type) {
    out = cv::Mat();
    return false;
  }
  const std::size_t elem = CV_ELEM_SIZE(type);
  const std::size_t bytes = elem * static_cast<std::size_t>(header.rows()) * static_cast<std::size_t>(header.cols());
  if (static_cast<std::size_t>(header.offset()) + bytes > std::min<std::size_t>(size, N)) {
    out = cv::Mat();
    return false;
  }
  make_exclusive(out);
  out.create(header.rows(), header.cols(), type);
  std::memcpy(out.data, data.data() + header.offset(), bytes);
  return true;
}

}  // namespace

template <class P>
std::string to_plain(const Image& in, P& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  uint32_t end = 0;
  if (!pack(in.mat, out.data(), 0, out.mat(), end)) {
    return "a " + std::to_string(in.mat.cols) + "x" + std::to_string(in.mat.rows) + " image of " +
           std::to_string(in.mat.total() * in.mat.elemSize()) + " bytes does not fit the edge's shared-memory capacity (" +
           mib(out.data().size()) + "); give the edge a larger one (qos=\"capacity=16M\")";
  }
  out.size(end);
  return {};
}

template <class P>
bool from_plain(const P& in, Image& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  return unpack(in.mat(), in.data(), in.size(), out.mat);
}

template <class P>
std::string to_plain(const Retina& in, P& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  out.source_width(in.source_size.width);
  out.source_height(in.source_size.height);
  out.fovea_x(in.fovea.x);
  out.fovea_y(in.fovea.y);
  out.sampling(static_cast<uint8_t>(in.sampling));
  if (in.levels.size() > out.levels().size() || in.geometry.size() != in.levels.size())
    return "a retina of " + std::to_string(in.levels.size()) + " levels (" + std::to_string(in.geometry.size()) +
           " geometries) does not fit the shared-memory form (at most " + std::to_string(out.levels().size()) +
           " levels, one geometry each)";
  out.level_count(static_cast<uint32_t>(in.levels.size()));
  uint32_t end = 0;
  for (std::size_t i = 0; i < in.levels.size(); ++i) {
    if (!pack(in.levels[i], out.data(), end, out.levels()[i], end))
      return "a retina of " + std::to_string(in.levels.size()) + " levels does not fit the edge's shared-memory capacity (" +
             mib(out.data().size()) + ")";
    geometry_to_wire(in.geometry[i], out.geometry()[i]);
  }
  out.size(end);
  return {};
}

template <class P>
bool from_plain(const P& in, Retina& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  out.source_size = {in.source_width(), in.source_height()};
  out.fovea = {in.fovea_x(), in.fovea_y()};
  out.sampling = in.sampling() == 1 ? Retina::Sampling::kAreaMean : Retina::Sampling::kFivePoint;
  const std::size_t n = std::min<std::size_t>(in.level_count(), in.levels().size());
  out.levels.resize(n);
  out.geometry.resize(n);
  bool ok = n == in.level_count();
  for (std::size_t i = 0; i < n; ++i) {
    ok = unpack(in.levels()[i], in.data(), in.size(), out.levels[i]) && ok;
    out.geometry[i] = geometry_from_wire(in.geometry()[i]);
  }
  out.source.reset();
  return ok;
}

template std::string to_plain(const Image&, wp::Image1M&);
template std::string to_plain(const Image&, wp::Image4M&);
template std::string to_plain(const Image&, wp::Image16M&);
template bool from_plain(const wp::Image1M&, Image&);
template bool from_plain(const wp::Image4M&, Image&);
template bool from_plain(const wp::Image16M&, Image&);
template std::string to_plain(const Retina&, wp::Retina1M&);
template bool from_plain(const wp::Retina1M&, Retina&);

namespace {

// Orders the reads of a sample the writer's process may be rewriting.
inline void read_fence() {
#if defined(__SANITIZE_THREAD__)
  std::atomic_signal_fence(std::memory_order_acquire);  // TSan has no fences; it cannot see another process anyway
#else
  std::atomic_thread_fence(std::memory_order_acquire);
#endif
}

// A plain sample is never held by the bridge: the writer loans one per
// message from the data-sharing pool, the reader loans the writer's.
template <class M, class P>
class PlainSample final : public WireSample {
 public:
  Status write(fdds::DataWriter& writer, const Message* message, bool& written) override {
    written = false;
    void* memory = nullptr;
    if (writer.loan_sample(memory) != ReturnCode_t::RETCODE_OK) return {};  // pool exhausted: counted as a failed write
    P& sample = *static_cast<P*>(memory);
    if (message == nullptr) {
      sample.stamp().timestamp_ns(0);
      sample.stamp().origin_ns(0);
      sample.stamp().frame_id(-1);
      sample.stamp().flags(kEndOfStream);
      sample.size(0);
    } else if (std::string error = to_plain(static_cast<const M&>(*message), sample); !error.empty()) {
      writer.discard_loan(memory);
      return Status::error(error);
    }
    written = writer.write(memory);
    if (!written) writer.discard_loan(memory);
    return {};
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
        const int64_t frame = sample.stamp().frame_id();
        read_fence();
        bool ok = from_plain(sample, *m);
        read_fence();
        // The writer's pool is a ring: a writer far ahead may reuse this sample
        // while it is copied. Seen as a changed frame id: drop, never emit a torn frame.
        if (ok && sample.stamp().frame_id() == frame) {
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

template <class M, class P, class T>
Codec plain_codec(std::size_t capacity) {
  return Codec{M::kTypeName, Codec::Form::kPlain, capacity,
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

}  // namespace saccade::dds
