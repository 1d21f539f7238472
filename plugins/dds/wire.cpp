#include "wire.hpp"

#include <algorithm>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>

#include "mailbox.hpp"
#include "saccade/log.hpp"
#include "saccade/schema.hpp"

namespace saccade::dds {

namespace {

namespace fdds = eprosima::fastdds::dds;
using eprosima::fastrtps::rtps::InstanceHandle_t;
using eprosima::fastrtps::rtps::SerializedPayload_t;

// Message type M as the IDL type saccade_idl::<M>: its bytes straight from
// and into the message (cdr.hpp). Unkeyed, unbounded.
template <class M>
class CdrType final : public fdds::TopicDataType {
 public:
  CdrType() {
    setName(cdr::idl_type_name(M::kTypeName).c_str());
    // What a history preallocates per sample (a default message, with its
    // encapsulation, and 4 bytes for a submessage's alignment as fastddsgen's
    // types have); larger ones reallocate (Fast DDS' default
    // PREALLOCATED_WITH_REALLOC).
    m_typeSize = static_cast<uint32_t>(cdr::size_of(M{}) + 4);
    m_isGetKeyDefined = false;
  }

  bool serialize(void* data, SerializedPayload_t* payload) override {
    const auto* sample = static_cast<const CdrSample*>(data);
    const std::size_t n =
        cdr::write(static_cast<const M&>(*sample->message), sample->envelope, payload->data, payload->max_size);
    if (n == 0) return false;
    payload->length = static_cast<uint32_t>(n);
    payload->encapsulation = CDR_LE;
    return true;
  }

  bool deserialize(SerializedPayload_t* payload, void* data) override {
    auto* sample = static_cast<CdrSample*>(data);
    sample->status =
        cdr::read(payload->data, payload->length, static_cast<M&>(*sample->target), sample->envelope, sample->spare);
    return true;  // an unreadable sample is the reader's to count (CdrSample::status)
  }

  std::function<uint32_t()> getSerializedSizeProvider(void* data) override {
    return [data] {
      return static_cast<uint32_t>(cdr::size_of(static_cast<const M&>(*static_cast<CdrSample*>(data)->message)));
    };
  }

  void* createData() override {
    auto* sample = new CdrSample();
    sample->owned = std::make_unique<M>();
    sample->target = sample->owned.get();
    sample->message = sample->target;
    return sample;
  }
  void deleteData(void* data) override { delete static_cast<CdrSample*>(data); }
  bool getKey(void*, InstanceHandle_t*, bool) override { return false; }
};

// The serialised form. With a mailbox (WireOptions::mailbox) the writer also
// posts each message's serialised bytes to its same-host mailbox before DDS
// writes it, and a reader follows the mailbox the first sample names: it
// reads the mailbox first and drops DDS' copies of what it read there (see
// mailbox.hpp).
template <class M>
class Sample final : public WireSample {
 public:
  explicit Sample(const WireOptions& options) : options_(options) {
    mail_.set_wait(options.reader_wait);
    end_.frame_id = -1;
  }

  Status write(fdds::DataWriter& writer, const Message* message, bool& written) override {
    out_.message = message != nullptr ? message : &end_;
    out_.envelope = {message != nullptr ? 0u : kEndOfStream, 0, 0};
    if (options_.mailbox) post_to_mailbox();
    written = writer.write(&out_);
    return {};
  }

  Taken take(fdds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) override {
    why_.clear();
    std::shared_ptr<M> m = fresh<M>(ctx, output, slot);
    const Taken taken = take_into(reader, *m);
    // Without a context the slot keeps the message for the next take (no allocation in steady state).
    if (taken == Taken::kMessage || ctx == nullptr) slot = std::move(m);
    return taken;
  }

  // On the followed mailbox's doorbell (unless DDS has the next post).
  void wait(fdds::DataReader& reader, int timeout_ms) override {
    wait_on_doorbell(
        reader, timeout_ms, [&](int64_t ns) { return options_.mailbox && !dds_turn_ && mail_.wait(last_, ns); },
        [&] { return mail_.newest() > last_; });
  }

  uint64_t frames_mailed() const override { return mailed_; }

 private:
  Taken take_into(fdds::DataReader& reader, M& m) {
    cdr::Envelope envelope;
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
          if (Status s = cdr::read(bytes_.data(), bytes_.size(), m, envelope, &spare_retina_); !s.ok()) {
            why_ = "a mailbox message: " + s.message();
            return Taken::kUnreadable;
          }
          return envelope.flags & kEndOfStream ? Taken::kEnd : Taken::kMessage;
        }
        // Too large for the slots, or gone past (this reader fell a ring
        // behind): DDS has it, and the mailbox waits until DDS gave it.
        if (r != MailboxReader::Read::kNotYet) dds_turn_ = true;
      }
    }
    in_.target = &m;
    in_.spare = &spare_retina_;
    for (;;) {
      fdds::SampleInfo info;
      if (reader.take_next_sample(&in_, &info) != ReturnCode_t::RETCODE_OK) return Taken::kNothing;
      if (!info.valid_data) return Taken::kUnreadable;
      if (!in_.status.ok()) {
        why_ = in_.status.message();
        return Taken::kUnreadable;
      }
      if (options_.mailbox && !seen_first_time(in_.envelope.mailbox, in_.envelope.post)) continue;
      return in_.envelope.flags & kEndOfStream ? Taken::kEnd : Taken::kMessage;
    }
  }

  // The mailbox is made at the first message, with slots twice its size (at
  // least 4 KiB), and made again larger when a message outgrows them (up to
  // kMaxSlotBytes; larger ones are left to DDS): its readers follow the new
  // one from its first DDS sample.
  void post_to_mailbox() {
    constexpr std::size_t kMinSlotBytes = 4096, kMaxSlotBytes = 64 * 1024;
    const M& message = static_cast<const M&>(*out_.message);
    const std::size_t bytes = cdr::size_of(message);
    if (!box_ || (bytes > box_->slot_bytes() && box_->slot_bytes() < kMaxSlotBytes)) {
      box_.reset();
      const std::size_t slot_bytes =
          std::clamp<std::size_t>((2 * bytes + 4095) / 4096 * 4096, kMinSlotBytes, kMaxSlotBytes);
      auto made = Mailbox::create(slot_bytes, options_.mailbox_slots);
      if (!made.ok()) {
        log().warn("no same-host mailbox ({}): messages go through DDS alone", made.error());
        options_.mailbox = false;
        return;
      }
      box_ = std::move(made).value();
    }
    out_.envelope.mailbox = box_->id();
    out_.envelope.post = box_->next_post();
    if (bytes > box_->slot_bytes()) {
      box_->post(nullptr, bytes);  // posted as "in DDS"
      return;
    }
    bytes_.resize(bytes);
    cdr::write(message, out_.envelope, bytes_.data(), bytes_.size());
    box_->post(bytes_.data(), bytes_.size());
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
    if (mail_.follow(box).ok()) {  // else another host's writer: DDS alone
      last_ = post;
      dds_turn_ = false;
    } else {
      unreachable_id_ = box;
    }
    return true;
  }

  WireOptions options_;
  M end_;                                         // what an end of stream carries
  CdrSample out_, in_;                            // the writer's, the reader's
  std::shared_ptr<Retina> spare_retina_;          // see cdr::read
  std::vector<uint8_t> bytes_;                    // a message's serialised bytes, to or from the mailbox
  std::unique_ptr<Mailbox> box_;                  // the writer's
  MailboxReader mail_;                            // the reader's
  uint64_t last_ = 0;                             // the newest post of the followed mailbox this reader had
  uint64_t previous_id_ = 0, previous_last_ = 0;  // the mailbox followed before, and its newest post had
  uint64_t unreachable_id_ = 0;                   // a mailbox that could not be opened (another host's)
  bool dds_turn_ = false;                         // the next post is DDS' to bring
  uint64_t mailed_ = 0;
};

template <class M>
Codec codec() {
  return Codec{M::kTypeName, Codec::Form::kSerialized, 0,
               +[]() -> std::unique_ptr<fdds::TopicDataType> { return std::make_unique<CdrType<M>>(); },
               +[](const WireOptions& o) -> std::unique_ptr<WireSample> { return std::make_unique<Sample<M>>(o); }};
}

template <class... T>
std::vector<Codec> codecs_of(TypeList<T...>) {
  std::vector<Codec> all;
  (all.push_back(codec<T>()), ...);
  return all;
}

const std::vector<Codec>& codecs() {
  static const std::vector<Codec> all = codecs_of(MessageTypes{});
  return all;
}

}  // namespace

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

}  // namespace saccade::dds
