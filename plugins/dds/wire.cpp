#include "wire.hpp"

#include <algorithm>
#include <cstring>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include <fastcdr/Cdr.h>
#include <fastcdr/FastBuffer.h>
#include <fastcdr/exceptions/Exception.h>

#include "mailbox.hpp"
#include "saccade/log.hpp"
#include "saccadePubSubTypes.h"

namespace saccade::dds {

namespace w = saccade_idl;
namespace wc = saccade_idl::common;

namespace {

wc::Point2 point_to_wire(cv::Point2d p) {
  wc::Point2 out;
  out.x(p.x);
  out.y(p.y);
  return out;
}
cv::Point2d point_from_wire(const wc::Point2& p) { return {p.x(), p.y()}; }

wc::Box box_to_wire(const Box& b) {
  wc::Box out;
  out.x(b.x);
  out.y(b.y);
  out.w(b.w);
  out.h(b.h);
  return out;
}

Box box_from_wire(const wc::Box& b) { return {b.x(), b.y(), b.w(), b.h()}; }

wc::Vec3 vec_to_wire(const cv::Vec3d& v) {
  wc::Vec3 out;
  out.x(v[0]);
  out.y(v[1]);
  out.z(v[2]);
  return out;
}
cv::Vec3d vec_from_wire(const wc::Vec3& v) { return {v.x(), v.y(), v.z()}; }

wc::Quaternion quaternion_to_wire(const cv::Vec4d& q) {
  wc::Quaternion out;
  out.w(q[0]);
  out.x(q[1]);
  out.y(q[2]);
  out.z(q[3]);
  return out;
}

cv::Vec4d quaternion_from_wire(const wc::Quaternion& q) { return {q.w(), q.x(), q.y(), q.z()}; }

wc::Rect rect_to_wire(const cv::Rect& r) {
  wc::Rect out;
  out.x(r.x);
  out.y(r.y);
  out.width(r.width);
  out.height(r.height);
  return out;
}
cv::Rect rect_from_wire(const wc::Rect& r) { return {r.x(), r.y(), r.width(), r.height()}; }

// Element-wise copy between vectors of different element types (enums as octets).
template <class Out, class In>
void copy_cast(const std::vector<In>& in, std::vector<Out>& out) {
  out.resize(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) out[i] = static_cast<Out>(in[i]);
}

// The retina a message refers to travels with it, as a sequence of at most one.
void retina_to_wire(const std::shared_ptr<const Retina>& in, std::vector<w::Retina>& out) {
  out.resize(in ? 1 : 0);
  if (in) to_wire(*in, out[0]);
}

// `spare`, when given, is the reader's retina of an earlier message: refilled
// in place once no message holds it any more, so a reader allocates none in
// steady state (its levels keep their buffers too).
std::shared_ptr<const Retina> retina_from_wire(const std::vector<w::Retina>& in, std::shared_ptr<Retina>* spare) {
  if (in.empty()) return nullptr;
  std::shared_ptr<Retina> retina;
  if (spare != nullptr && *spare && spare->use_count() == 1)
    retina = *spare;
  else
    retina = std::make_shared<Retina>();
  if (spare != nullptr) *spare = retina;
  from_wire(in[0], *retina);
  return retina;
}

// The serialised form. With a mailbox (WireOptions::mailbox) the writer also
// posts each message's serialised bytes to its same-host mailbox before DDS
// writes it, and a reader follows the mailbox the first sample names: it
// reads the mailbox first and drops DDS' copies of what it read there (see
// mailbox.hpp).
template <class M, class W>
class Sample final : public WireSample {
 public:
  explicit Sample(const WireOptions& options) : options_(options) { mail_.set_wait(options.reader_wait); }

  Status write(eprosima::fastdds::dds::DataWriter& writer, const Message* message, bool& written) override {
    if (message != nullptr) {
      to_wire(static_cast<const M&>(*message), wire_);
    } else {
      wire_.stamp().frame_id(-1);
      wire_.stamp().flags(kEndOfStream);
    }
    wire_.stamp().mailbox(0);
    wire_.stamp().post(0);
    if (options_.mailbox) post_to_mailbox();
    written = writer.write(&wire_);
    return {};
  }

  Taken take(eprosima::fastdds::dds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) override {
    why_.clear();
    if (options_.mailbox && !dds_turn_ && mail_.open()) {
      const uint64_t newest = mail_.newest();
      if (newest > last_) {
        // In order, every post (a reliable edge); else the newest.
        uint64_t post = options_.in_order ? last_ + 1 : newest;
        MailboxReader::Read r = mail_.read(post, bytes_);
        if (r == MailboxReader::Read::kOverwritten && !options_.in_order) r = mail_.read(post = mail_.newest(), bytes_);
        if (r == MailboxReader::Read::kMessage) {
          last_ = post;
          ++mailed_;
          if (!deserialize()) return Taken::kUnreadable;
          return deliver(ctx, output, slot);
        }
        // Too large for the slots, or gone past (this reader fell a ring
        // behind): DDS has it, and the mailbox waits until DDS gave it.
        if (r != MailboxReader::Read::kNotYet) dds_turn_ = true;
      }
    }
    for (;;) {
      eprosima::fastdds::dds::SampleInfo info;
      if (reader.take_next_sample(&wire_, &info) != ReturnCode_t::RETCODE_OK) return Taken::kNothing;
      if (!info.valid_data) return Taken::kUnreadable;
      if (options_.mailbox && !seen_first_time(wire_.stamp().mailbox(), wire_.stamp().post())) continue;
      return deliver(ctx, output, slot);
    }
  }

  // On the followed mailbox's doorbell (unless DDS has the next post).
  void wait(eprosima::fastdds::dds::DataReader& reader, int timeout_ms) override {
    wait_on_doorbell(
        reader, timeout_ms, [&](int64_t ns) { return options_.mailbox && !dds_turn_ && mail_.wait(last_, ns); },
        [&] { return mail_.newest() > last_; });
  }

  uint64_t frames_mailed() const override { return mailed_; }

 private:
  Taken deliver(ProcessContext* ctx, int output, MessagePtr& slot) {
    if (wire_.stamp().flags() & kEndOfStream) return Taken::kEnd;
    std::shared_ptr<M> m = fresh<M>(ctx, output, slot);
    if constexpr (requires { from_wire(wire_, *m, &spare_retina_); })
      from_wire(wire_, *m, &spare_retina_);
    else
      from_wire(wire_, *m);
    slot = std::move(m);
    return Taken::kMessage;
  }

  // The mailbox is made at the first message, with slots twice its size (at
  // least 4 KiB), and made again larger when a message outgrows them (up to
  // kMaxSlotBytes; larger ones are left to DDS): its readers follow the new
  // one from its first DDS sample.
  void post_to_mailbox() {
    constexpr std::size_t kMinSlotBytes = 4096, kMaxSlotBytes = 64 * 1024;
    const std::size_t bytes = W::getCdrSerializedSize(wire_) + 4;  // + the encapsulation
    if (!box_ || (bytes > box_->slot_bytes() && box_->slot_bytes() < kMaxSlotBytes)) {
      box_.reset();
      std::string error;
      const std::size_t slot_bytes =
          std::clamp<std::size_t>((2 * bytes + 4095) / 4096 * 4096, kMinSlotBytes, kMaxSlotBytes);
      box_ = Mailbox::create(slot_bytes, options_.mailbox_slots, &error);
      if (!box_) {
        log().warn("no same-host mailbox ({}): messages go through DDS alone", error);
        options_.mailbox = false;
        return;
      }
    }
    wire_.stamp().mailbox(box_->id());
    wire_.stamp().post(box_->next_post());
    if (bytes > box_->slot_bytes()) {
      box_->post(nullptr, bytes);  // posted as "in DDS"
      return;
    }
    bytes_.resize(bytes);
    eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(bytes_.data()), bytes_.size());
    eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
    cdr.serialize_encapsulation();
    wire_.serialize(cdr);
    box_->post(bytes_.data(), cdr.getSerializedDataLength());
  }

  bool deserialize() {
    try {
      eprosima::fastcdr::FastBuffer buffer(reinterpret_cast<char*>(bytes_.data()), bytes_.size());
      eprosima::fastcdr::Cdr cdr(buffer, eprosima::fastcdr::Cdr::DEFAULT_ENDIAN, eprosima::fastcdr::Cdr::DDS_CDR);
      cdr.read_encapsulation();
      wire_.deserialize(cdr);
      return true;
    } catch (const eprosima::fastcdr::exception::Exception& e) {
      why_ = std::string("a mailbox message that does not deserialise: ") + e.what();
      return false;
    }
  }

  // Whether a DDS sample (of mailbox `box`, post `post`) is one this reader
  // has not had from a mailbox. Follows the first mailbox a sample names, and
  // a new one once that one's writer closed it or died (a restarted writer);
  // a second live writer's samples come through DDS alone.
  bool seen_first_time(uint64_t box, uint64_t post) {
    if (box == 0 || post == 0) return true;
    if (box == mail_.id()) {
      if (post <= last_) return false;
      last_ = post;
      dds_turn_ = false;
      return true;
    }
    if (box == previous_id_) {
      if (post <= previous_last_) return false;
      previous_last_ = post;
      return true;
    }
    if (box == unreachable_id_ || (mail_.open() && mail_.writer_alive())) return true;
    previous_id_ = mail_.id();
    previous_last_ = last_;
    std::string ignored;  // another host's writer: DDS alone
    if (mail_.follow(box, ignored)) {
      last_ = post;
      dds_turn_ = false;
    } else {
      unreachable_id_ = box;
    }
    return true;
  }

  WireOptions options_;
  W wire_;
  std::shared_ptr<Retina> spare_retina_;
  std::vector<uint8_t> bytes_;                    // a message's serialised bytes, to or from the mailbox
  std::unique_ptr<Mailbox> box_;                  // the writer's
  MailboxReader mail_;                            // the reader's
  uint64_t last_ = 0;                             // the newest post of the followed mailbox this reader had
  uint64_t previous_id_ = 0, previous_last_ = 0;  // the mailbox followed before, and its newest post had
  uint64_t unreachable_id_ = 0;                   // a mailbox that could not be opened (another host's)
  bool dds_turn_ = false;                         // the next post is DDS' to bring
  uint64_t mailed_ = 0;
};

template <class M, class W, class P>
Codec codec() {
  return Codec{M::kTypeName, Codec::Form::kSerialized, 0,
               +[]() -> std::unique_ptr<eprosima::fastdds::dds::TopicDataType> { return std::make_unique<P>(); },
               +[](const WireOptions& o) -> std::unique_ptr<WireSample> { return std::make_unique<Sample<M, W>>(o); }};
}

const std::vector<Codec>& codecs() {
  static const std::vector<Codec> all = {
      codec<Image, w::Image, w::ImagePubSubType>(),
      codec<Retina, w::Retina, w::RetinaPubSubType>(),
      codec<FeatureMaps, w::FeatureMaps, w::FeatureMapsPubSubType>(),
      codec<Motion, w::Motion, w::MotionPubSubType>(),
      codec<Region, w::Region, w::RegionPubSubType>(),
      codec<StereoFixation, w::StereoFixation, w::StereoFixationPubSubType>(),
      codec<GazeRequest, w::GazeRequest, w::GazeRequestPubSubType>(),
      codec<JointState, w::JointState, w::JointStatePubSubType>(),
      codec<JointTargets, w::JointTargets, w::JointTargetsPubSubType>(),
      codec<HeadPose, w::HeadPose, w::HeadPosePubSubType>(),
      codec<FoveaState, w::FoveaState, w::FoveaStatePubSubType>(),
      codec<Classification, w::Classification, w::ClassificationPubSubType>(),
      codec<CanFrames, w::CanFrames, w::CanFramesPubSubType>(),
  };
  return all;
}

}  // namespace

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
  out.area(rect_to_wire(in.region));
  out.step_x(in.step_x);
  out.step_y(in.step_y);
}

LevelGeometry geometry_from_wire(const wc::LevelGeometry& in) {
  LevelGeometry out;
  out.region = rect_from_wire(in.area());
  out.step_x = in.step_x();
  out.step_y = in.step_y();
  return out;
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

const Codec* find_codec(std::string_view type) {
  for (const auto& c : codecs())
    if (c.type == type) return &c;
  return nullptr;
}

std::vector<std::string_view> codec_types() {
  std::vector<std::string_view> out;
  for (const auto& c : codecs()) out.push_back(c.type);
  return out;
}

// --- cv::Mat: rows packed without padding ---

// The longest side a Mat read from the wire may have.
constexpr int kMaxMatSide = 1 << 16;

void to_wire(const cv::Mat& in, wc::Mat& out) {
  out.rows(in.rows);
  out.cols(in.cols);
  out.cv_type(in.type());
  const std::size_t row_bytes = static_cast<std::size_t>(in.cols) * in.elemSize();
  auto& data = out.data();
  data.resize(row_bytes * static_cast<std::size_t>(std::max(in.rows, 0)));
  if (in.empty()) return;
  if (in.isContinuous()) {
    std::memcpy(data.data(), in.data, data.size());
  } else {
    for (int r = 0; r < in.rows; ++r)
      std::memcpy(data.data() + row_bytes * static_cast<std::size_t>(r), in.ptr(r), row_bytes);
  }
}

void from_wire(const wc::Mat& in, cv::Mat& out) {
  // A header no Mat can have (an element type OpenCV does not know, sides
  // past a limit) reads as no image: a malformed or hostile sample must not
  // make OpenCV throw or allocate without bound.
  const int type = in.cv_type();
  if (in.rows() <= 0 || in.cols() <= 0 || in.rows() > kMaxMatSide || in.cols() > kMaxMatSide || type < 0 ||
      CV_MAT_DEPTH(type) > CV_16F || type != CV_MAKETYPE(CV_MAT_DEPTH(type), CV_MAT_CN(type))) {
    out.release();
    return;
  }
  const std::size_t bytes =
      static_cast<std::size_t>(in.rows()) * static_cast<std::size_t>(in.cols()) * CV_ELEM_SIZE(type);
  // Data shorter than its header says: only a little (a truncated sample)
  // leaves zeros; a header claiming far more than it carries is no image.
  if (bytes > in.data().size() + (std::size_t{1} << 20)) {
    out.release();
    return;
  }
  make_exclusive(out);
  out.create(in.rows(), in.cols(), type);
  const std::size_t n = std::min(bytes, in.data().size());
  if (n > 0) std::memcpy(out.data, in.data().data(), n);
  if (n < bytes) std::memset(out.data + n, 0, bytes - n);
}

void to_wire(const Image& in, w::Image& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  to_wire(in.mat, out.mat());
}

void from_wire(const w::Image& in, Image& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  from_wire(in.mat(), out.mat);
}

void to_wire(const Retina& in, w::Retina& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  out.levels().resize(in.levels.size());
  for (std::size_t i = 0; i < in.levels.size(); ++i) to_wire(in.levels[i], out.levels()[i]);
  out.geometry().resize(in.geometry.size());
  for (std::size_t i = 0; i < in.geometry.size(); ++i) geometry_to_wire(in.geometry[i], out.geometry()[i]);
  out.source_width(in.source_size.width);
  out.source_height(in.source_size.height);
  out.fovea_x(in.fovea.x);
  out.fovea_y(in.fovea.y);
  out.sampling(static_cast<uint8_t>(in.sampling));
  rectification_to_wire(in.rectification, out.rectification());
}

void from_wire(const w::Retina& in, Retina& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  out.levels.resize(in.levels().size());
  for (std::size_t i = 0; i < in.levels().size(); ++i) from_wire(in.levels()[i], out.levels[i]);
  out.geometry.resize(in.geometry().size());
  for (std::size_t i = 0; i < in.geometry().size(); ++i) out.geometry[i] = geometry_from_wire(in.geometry()[i]);
  out.source_size = {in.source_width(), in.source_height()};
  out.fovea = {in.fovea_x(), in.fovea_y()};
  out.sampling = in.sampling() == 1 ? Retina::Sampling::kAreaMean : Retina::Sampling::kFivePoint;
  out.rectification = rectification_from_wire(in.rectification());
  out.source.reset();  // the frame itself does not travel
}

void to_wire(const FeatureMaps& in, w::FeatureMaps& out) {
  stamp_to_wire(in, out.stamp());
  out.features().resize(in.names.size());
  for (std::size_t f = 0; f < in.names.size(); ++f) {
    auto& feature = out.features()[f];
    feature.name(in.names[f]);
    const auto& levels = in.maps[f];
    feature.levels().resize(levels.size());
    for (std::size_t l = 0; l < levels.size(); ++l) to_wire(levels[l], feature.levels()[l]);
  }
  retina_to_wire(in.retina, out.source_retina());
}

void from_wire(const w::FeatureMaps& in, FeatureMaps& out, std::shared_ptr<Retina>* spare) {
  stamp_from_wire(in.stamp(), out);
  const auto& features = in.features();
  out.names.resize(features.size());
  out.maps.resize(features.size());
  for (std::size_t f = 0; f < features.size(); ++f) {
    out.names[f] = features[f].name();
    out.maps[f].resize(features[f].levels().size());
    for (std::size_t l = 0; l < features[f].levels().size(); ++l) from_wire(features[f].levels()[l], out.maps[f][l]);
  }
  out.retina = retina_from_wire(in.source_retina(), spare);
}

void to_wire(const Motion& in, w::Motion& out) {
  stamp_to_wire(in, out.stamp());
  out.camera_id(in.camera_id);
  out.first(in.first);
  out.energy() = in.energy;
  out.moving() = in.moving;
  out.centroid().resize(in.centroid.size());
  for (std::size_t i = 0; i < in.centroid.size(); ++i) out.centroid()[i] = point_to_wire(in.centroid[i]);
}

void from_wire(const w::Motion& in, Motion& out) {
  stamp_from_wire(in.stamp(), out);
  out.camera_id = in.camera_id();
  out.first = in.first();
  out.energy = in.energy();
  out.moving = in.moving();
  out.centroid.resize(in.centroid().size());
  for (std::size_t i = 0; i < in.centroid().size(); ++i) out.centroid[i] = point_from_wire(in.centroid()[i]);
}

void to_wire(const Region& in, w::Region& out) {
  stamp_to_wire(in, out.stamp());
  out.center(point_to_wire(in.center));
  out.width(in.size.width);
  out.height(in.size.height);
  out.score(in.score);
  out.depth(in.depth);
  out.camera_id(in.camera_id);
  out.label(in.label);
}

void from_wire(const w::Region& in, Region& out) {
  stamp_from_wire(in.stamp(), out);
  out.center = point_from_wire(in.center());
  out.size = {in.width(), in.height()};
  out.score = in.score();
  out.depth = in.depth();
  out.camera_id = in.camera_id();
  out.label = in.label();
}

void to_wire(const StereoFixation& in, w::StereoFixation& out) {
  stamp_to_wire(in, out.stamp());
  out.pixel(point_to_wire(in.pixel));
  out.fovea_width(in.fovea.width);
  out.fovea_height(in.fovea.height);
  out.disparity(in.disparity);
  out.score(in.score);
  out.depth(in.depth);
  out.depth_sigma(in.depth_sigma);
  out.point(vec_to_wire(in.point));
  out.point_head(vec_to_wire(in.point_head));
  out.point_head_valid(in.point_head_valid);
  out.rectified(in.rectified);
  out.camera_id(in.camera_id);
}

void from_wire(const w::StereoFixation& in, StereoFixation& out) {
  stamp_from_wire(in.stamp(), out);
  out.pixel = point_from_wire(in.pixel());
  out.fovea = {in.fovea_width(), in.fovea_height()};
  out.disparity = in.disparity();
  out.score = in.score();
  out.depth = in.depth();
  out.depth_sigma = in.depth_sigma();
  out.point = vec_from_wire(in.point());
  out.point_head = vec_from_wire(in.point_head());
  out.point_head_valid = in.point_head_valid();
  out.rectified = in.rectified();
  out.camera_id = in.camera_id();
}

void to_wire(const GazeRequest& in, w::GazeRequest& out) {
  stamp_to_wire(in, out.stamp());
  out.kind(static_cast<uint8_t>(in.kind));
  out.pixel(point_to_wire(in.pixel));
  out.direction(vec_to_wire(in.direction));
  out.image_width(in.image_size.width);
  out.image_height(in.image_size.height);
  out.focal_px(in.focal_px);
  out.depth(in.depth);
  out.disparity(in.disparity);
  out.point(vec_to_wire(in.point));
  out.azimuth(in.azimuth);
  out.elevation(in.elevation);
  out.camera_id(in.camera_id);
  out.reason(in.reason);
}

void from_wire(const w::GazeRequest& in, GazeRequest& out) {
  stamp_from_wire(in.stamp(), out);
  out.kind = in.kind() <= static_cast<uint8_t>(GazeRequest::Kind::kRelative) ? static_cast<GazeRequest::Kind>(in.kind())
                                                                             : GazeRequest::Kind::kDirection;
  out.pixel = point_from_wire(in.pixel());
  out.direction = vec_from_wire(in.direction());
  out.image_size = {in.image_width(), in.image_height()};
  out.focal_px = in.focal_px();
  out.depth = in.depth();
  out.disparity = in.disparity();
  out.point = vec_from_wire(in.point());
  out.azimuth = in.azimuth();
  out.elevation = in.elevation();
  out.camera_id = in.camera_id();
  out.reason = in.reason();
}

void to_wire(const JointState& in, w::JointState& out) {
  stamp_to_wire(in, out.stamp());
  out.position() = in.position;
  out.velocity() = in.velocity;
  copy_cast(in.health, out.health());
  out.updated_ns() = in.updated_ns;
  out.error_code() = in.error_code;
  out.cycle(in.cycle);
  out.detail(in.detail);
}

void from_wire(const w::JointState& in, JointState& out) {
  stamp_from_wire(in.stamp(), out);
  out.position = in.position();
  out.velocity = in.velocity();
  out.health.resize(in.health().size());
  for (std::size_t i = 0; i < in.health().size(); ++i)
    out.health[i] = in.health()[i] <= static_cast<uint8_t>(JointState::Health::kSilent)
                        ? static_cast<JointState::Health>(in.health()[i])
                        : JointState::Health::kFault;  // an unknown health is not a healthy one
  out.updated_ns = in.updated_ns();
  out.error_code = in.error_code();
  out.cycle = in.cycle();
  out.detail = in.detail();
}

void to_wire(const JointTargets& in, w::JointTargets& out) {
  stamp_to_wire(in, out.stamp());
  out.position() = in.position;
  out.velocity() = in.velocity;
  out.hold(in.hold);
  out.reset(in.reset);
  out.fault(in.fault);
  out.cause_origin_ns(in.cause_origin_ns);
  out.cause_taken_ns(in.cause_taken_ns);
}

void from_wire(const w::JointTargets& in, JointTargets& out) {
  stamp_from_wire(in.stamp(), out);
  out.position = in.position();
  out.velocity = in.velocity();
  out.hold = in.hold();
  out.reset = in.reset();
  out.fault = in.fault();
  out.cause_origin_ns = in.cause_origin_ns();
  out.cause_taken_ns = in.cause_taken_ns();
}

void to_wire(const HeadPose& in, w::HeadPose& out) {
  stamp_to_wire(in, out.stamp());
  out.left_position(vec_to_wire(in.left_position));
  out.left_rotation(quaternion_to_wire(in.left_rotation));
  out.right_position(vec_to_wire(in.right_position));
  out.right_rotation(quaternion_to_wire(in.right_rotation));
  out.fixation(vec_to_wire(in.fixation));
  out.fixation_valid(in.fixation_valid);
  out.fixation_gap(in.fixation_gap);
}

void from_wire(const w::HeadPose& in, HeadPose& out) {
  stamp_from_wire(in.stamp(), out);
  out.left_position = vec_from_wire(in.left_position());
  out.left_rotation = quaternion_from_wire(in.left_rotation());
  out.right_position = vec_from_wire(in.right_position());
  out.right_rotation = quaternion_from_wire(in.right_rotation());
  out.fixation = vec_from_wire(in.fixation());
  out.fixation_valid = in.fixation_valid();
  out.fixation_gap = in.fixation_gap();
}

void to_wire(const FoveaState& in, w::FoveaState& out) {
  stamp_to_wire(in, out.stamp());
  out.state(static_cast<uint8_t>(in.state));
  out.fovea(point_to_wire(in.fovea));
  out.next(point_to_wire(in.next));
  out.target(box_to_wire(in.target));
  out.target_valid(in.target_valid);
  out.confidence(in.confidence);
  out.score(in.score);
  out.attention_shift(in.attention_shift);
  out.gaze_request(in.gaze_request);
  out.attention_shifts(in.attention_shifts);
  out.gaze_requests(in.gaze_requests);
  out.frames_lost(in.frames_lost);
  out.camera_id(in.camera_id);
  retina_to_wire(in.retina, out.source_retina());
}

void from_wire(const w::FoveaState& in, FoveaState& out, std::shared_ptr<Retina>* spare) {
  stamp_from_wire(in.stamp(), out);
  out.state = in.state() <= static_cast<uint8_t>(FoveaState::State::kUncertain)
                  ? static_cast<FoveaState::State>(in.state())
                  : FoveaState::State::kLost;
  out.fovea = point_from_wire(in.fovea());
  out.next = point_from_wire(in.next());
  out.target = box_from_wire(in.target());
  out.target_valid = in.target_valid();
  out.confidence = in.confidence();
  out.score = in.score();
  out.attention_shift = in.attention_shift();
  out.gaze_request = in.gaze_request();
  out.attention_shifts = in.attention_shifts();
  out.gaze_requests = in.gaze_requests();
  out.frames_lost = in.frames_lost();
  out.camera_id = in.camera_id();
  out.retina = retina_from_wire(in.source_retina(), spare);
}

void to_wire(const Classification& in, w::Classification& out) {
  stamp_to_wire(in, out.stamp());
  out.outcome(static_cast<uint8_t>(in.outcome));
  out.best(in.best);
  out.score(in.score);
  out.scores() = in.scores;
  if (in.classes)
    out.classes() = *in.classes;
  else
    out.classes().clear();
  out.area(rect_to_wire(in.region));
  out.camera_id(in.camera_id);
}

void from_wire(const w::Classification& in, Classification& out) {
  stamp_from_wire(in.stamp(), out);
  out.outcome = in.outcome() <= static_cast<uint8_t>(Classification::Outcome::kNotClassified)
                    ? static_cast<Classification::Outcome>(in.outcome())
                    : Classification::Outcome::kNotClassified;
  out.best = in.best();
  out.score = in.score();
  out.scores = in.scores();
  // The class names rarely change: keep sharing the ones this message already holds.
  if (!out.classes || *out.classes != in.classes())
    out.classes = std::make_shared<const std::vector<std::string>>(in.classes());
  out.region = rect_from_wire(in.area());
  out.camera_id = in.camera_id();
}

void to_wire(const CanFrames& in, w::CanFrames& out) {
  stamp_to_wire(in, out.stamp());
  out.frames().resize(in.frames.size());
  for (std::size_t i = 0; i < in.frames.size(); ++i) {
    const CanFrames::Frame& f = in.frames[i];
    w::CanFrame& o = out.frames()[i];
    o.can_id(f.can_id);
    o.flags(f.flags);
    o.data().assign(f.data.begin(), f.data.begin() + std::min<std::size_t>(f.length, f.data.size()));
    o.timestamp_ns(f.timestamp_ns);
  }
  out.bus(in.bus);
}

void from_wire(const w::CanFrames& in, CanFrames& out) {
  stamp_from_wire(in.stamp(), out);
  out.frames.resize(in.frames().size());
  for (std::size_t i = 0; i < in.frames().size(); ++i) {
    const w::CanFrame& f = in.frames()[i];
    CanFrames::Frame& o = out.frames[i];
    o.can_id = f.can_id();
    o.flags = f.flags();
    const std::size_t n = std::min(f.data().size(), o.data.size());
    o.length = static_cast<uint8_t>(n);
    o.data.fill(0);
    std::copy_n(f.data().begin(), n, o.data.begin());
    o.timestamp_ns = f.timestamp_ns();
  }
  out.bus = in.bus();
}

}  // namespace saccade::dds
