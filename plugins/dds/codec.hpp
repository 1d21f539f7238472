#pragma once
// What every form of a message on a DDS edge shares (the serialised form,
// wire.hpp; the shared-memory forms, plain.hpp; the ROS 2 forms, ros2.hpp):
// the sample a bridge moves messages of one type through DDS with, and the
// codec that names a type's form and makes its samples.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <fastdds/dds/topic/TopicDataType.hpp>

#include "saccade/message.hpp"
#include "saccade/node.hpp"
#include "shared_segment.hpp"

namespace eprosima::fastdds::dds {
class DataWriter;
class DataReader;
}  // namespace eprosima::fastdds::dds

namespace saccade::dds {

// How a bridge moves messages of one type through DDS, kept by the bridge for
// its lifetime: a serialised sample it reuses for every message (its buffers
// keep their capacity), or, for a plain type, samples loaned from Fast DDS'
// shared memory. No allocation in steady state either way.
class WireSample {
 public:
  virtual ~WireSample();
  // Writes `message`, or an end of stream when it is null. `written` is false
  // when DDS refused (history full, pool exhausted); an error status means the
  // message does not fit the type (a plain type's capacity).
  virtual Status write(eprosima::fastdds::dds::DataWriter& writer, const Message* message, bool& written) = 0;
  enum class Taken { kNothing, kMessage, kEnd, kUnreadable };
  // Takes the next sample. kMessage: `slot` holds it, a message from ctx's
  // pool for output `output` (without a context: `slot` itself when nobody
  // else holds it, else a new one). kEnd: the writer ended its stream.
  // kUnreadable: a sample that could not be read.
  virtual Taken take(eprosima::fastdds::dds::DataReader& reader, ProcessContext* ctx, int output, MessagePtr& slot) = 0;
  // Sleeps until take() may find something, or `timeout_ms` pass.
  virtual void wait(eprosima::fastdds::dds::DataReader& reader, int timeout_ms);
  // What was wrong with the last kUnreadable sample, when the form can tell.
  const std::string& why_unreadable() const { return why_; }
  // The allocator a producer may create its frames' Mats with, so that they
  // are made in the memory this form sends from and write() copies nothing
  // (the frame ring's writer); nullptr when the form has none.
  virtual cv::MatAllocator* frame_allocator() { return nullptr; }
  // Frames a zero-copy edge copied after all: a writer whose producer did
  // not create them with frame_allocator(), a reader that holds a quarter of
  // the writer's frame ring already.
  virtual uint64_t frames_copied() const { return 0; }
  // Frames a reader took from the writer's frame ring mailbox (woken by the
  // writer itself) rather than from DDS.
  virtual uint64_t frames_mailed() const { return 0; }

 protected:
  std::string why_;
};

// Sleeps until `reader` has an unread sample, or `timeout_ns` pass.
void wait_for_dds(eprosima::fastdds::dds::DataReader& reader, int64_t timeout_ns);

// How a reader that follows a same-host mailbox (the frame ring's or the
// message mailbox) waits: on its doorbell in slices of 5 ms, looking at DDS
// between them, so that a sample only DDS brings (a restarted writer's new
// mailbox, a second writer) waits at most a slice; on DDS alone when there
// is no doorbell to sleep on. `sleep(ns)` sleeps on the doorbell (false:
// none, or its writer closed it); `arrived()` says whether it brought news.
void wait_on_doorbell(eprosima::fastdds::dds::DataReader& reader, int timeout_ms,
                      const std::function<bool(int64_t)>& sleep, const std::function<bool()>& arrived);

// A message of type M to fill: see WireSample::take.
template <class M>
std::shared_ptr<M> fresh(ProcessContext* ctx, int output, MessagePtr& slot) {
  if (ctx != nullptr) return ctx->make(OutputHandle<M>{output});
  if (slot && slot.use_count() == 1 && slot->type_name() == M::kTypeName)
    return std::const_pointer_cast<M>(std::static_pointer_cast<const M>(std::move(slot)));
  return std::make_shared<M>();
}

// What a bridge's samples need to know beyond the message: the names ROS 2
// messages carry and saccade's do not.
struct WireOptions {
  std::string frame_id;                  // ROS 2 Image header.frame_id; empty: "camera_<camera_id>"
  std::vector<std::string> joint_names;  // ROS 2 JointState name[], in saccade's joint order
  std::size_t capacity = 0;              // kRing: bytes a buffer holds (0: 4 MiB for Image, 1 MiB for Retina)
  uint32_t ring_slots = 16;              // kRing: buffers in the writer's ring
  // kSerialised: the writer also posts each message to a same-host mailbox
  // (mailbox.hpp) of `mailbox_slots` slots, and the reader reads the
  // mailbox its writer's samples name; `in_order`: every post in order (a
  // reliable edge), else the newest.
  bool mailbox = false;
  bool in_order = false;
  uint32_t mailbox_slots = 16;
  // How a reader of a ring or a mailbox waits for its doorbell (kSpin: ~1 us
  // instead of ~5-10 us a frame, at a whole core while it waits;
  // shared_segment.hpp). No effect on other edges.
  ReaderWait reader_wait = ReaderWait::kSleep;
};

struct Codec {
  enum class Form {
    kSerialized,  // saccade's IDL type (any size, any host)
    kPlain,       // a plain fixed-capacity type (one host: data sharing and loans)
    kRing,        // a plain type saying where the frame is in the writer's frame ring (one host, no copy)
    kRos2,        // the ROS 2 message (sensor_msgs), on an rt/ topic
  };
  std::string_view type;  // the message's type name
  Form form = Form::kSerialized;
  std::size_t capacity = 0;  // kPlain: bytes of data a sample holds
  std::unique_ptr<eprosima::fastdds::dds::TopicDataType> (*make_type)();
  std::unique_ptr<WireSample> (*make_sample)(const WireOptions&);

  // Plain samples in the writer's data-sharing pool (loans, or the ring's small samples).
  bool shares_memory() const { return form == Form::kPlain || form == Form::kRing; }
};

}  // namespace saccade::dds
