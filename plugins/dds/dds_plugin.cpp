// The DDS bridges: an edge between two processes becomes a topic with a
// dds.publish node on the producer's side and a dds.subscribe node on the
// consumer's. The framework inserts them (saccade run --process, saccade plan);
// a graph may also use them directly.
#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/publisher/DataWriterListener.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/DataReaderListener.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>

#include "domain.hpp"
#include "edge_codec.hpp"
#include "ros2.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"
#include "wire.hpp"

namespace {

using namespace saccade;
namespace fdds = eprosima::fastdds::dds;
namespace sd = saccade::dds;

std::vector<std::string> type_choices() {
  std::vector<std::string> out;
  for (auto t : sd::codec_types()) out.emplace_back(t);
  return out;
}

// What both bridges read beyond the topic and its type, into the structs of
// the DDS side. One parameter feeds two of them: `reliable` the QoS and the
// codec's choice (TopicEnd::open copies it), `capacity` the codec and the ring.
struct BridgeConfig {
  int domain = 0;
  sd::EdgeSettings edge;     // zero_copy: the codec's, at open
  sd::CodecRequest request;  // reliable: edge's
  sd::WireOptions wire;      // capacity: request's; joint_names: parsed from joint_names
  std::string joint_names = "neck,vergence_left,tilt_left,vergence_right,tilt_right";
};

void bind_bridge(ParamBinder<BridgeConfig>& b) {
  using C = BridgeConfig;
  using E = sd::EdgeSettings;
  using R = sd::CodecRequest;
  using W = sd::WireOptions;
  using M = R::SharedMemory;
  b.field("domain", {0, 232}, "DDS domain id", &C::domain)
      .field("reliable", "reliable (else best effort)", &C::edge, &E::reliable)
      .field("depth", {0, 100000}, "keep-last history depth; 0 keeps all (a slow reader blocks the writer)", &C::edge,
             &E::depth)
      .field("deadline_ms", {0, 3.6e6}, "report a peer silent for this long (0: no deadline)", &C::edge,
             &E::deadline_ms)
      .field("zero_copy",
             "one host only (both ends must agree for Image): messages travel through shared memory; how: "
             "shared_memory",
             &C::request, &R::zero_copy)
      .field("shared_memory", {{"auto", M::kAuto}, {"ring", M::kRing}, {"loans", M::kLoans}, {"mailbox", M::kMailbox}},
             "zero_copy: ring (Image, Retina): the pixels stay in the writer's frame ring, readers read them in "
             "place (pinned while their graph holds the frame) and a producer may write into the ring itself; "
             "loans (Image, Retina): plain fixed-capacity types through Fast DDS data sharing, the writer filling "
             "loaned samples, the reader copying out (what a plain Fast DDS peer reads); mailbox (any type): the "
             "serialised message, which the writer also posts to a same-host mailbox in shared memory, waking the "
             "readers there itself (DDS still carries every message, so either end may have it off); auto: ring "
             "for Image, mailbox for every other type. Reliable edges use loans for ring (a ring of reused "
             "buffers cannot promise every frame to a slow reader; a reliable mailbox reader reads every post in "
             "order, from DDS when it fell behind); DDS security always uses loans and no mailbox (they would "
             "bypass its encryption and access control)",
             &C::request, &R::shared_memory)
      .field("capacity", {0, 1 << 30},
             "zero_copy: bytes of pixel data a ring buffer or sample holds (0: the type's default, 4 MiB for Image, "
             "1 MiB for Retina); loans use the smallest plain type at least this large",
             &C::request, &R::capacity)
      .field("ring_slots", {4, 1024},
             "zero_copy ring: buffers in the writer's ring; a frame survives this many newer ones minus one while no "
             "reader holds it, and each reader pins at most a quarter of them (it copies the frames it keeps beyond "
             "that)",
             &C::wire, &W::ring_slots)
      .field("ros2",
             "a ROS 2 topic: the DDS topic is rt/<topic> and the type ROS 2's (Image: sensor_msgs/msg/Image, "
             "JointState: sensor_msgs/msg/JointState), so ROS 2 tools read it, or this node reads theirs",
             &C::request, &R::ros2)
      .field("frame_id", "ros2: the header's frame_id (empty: camera_<camera id> for images)", &C::wire, &W::frame_id)
      .field("joint_names",
             "ros2, JointState: the joints' names in saccade's order, comma-separated (reading: joints are matched "
             "by name; empty: in the message's order)",
             &C::joint_names);
}

Contract with_bridge_params(Contract c) {
  return c.required_string("topic", "DDS topic name")
      .param_enum("type", "Image", type_choices(), "message type the topic carries")
      .params(&bind_bridge);
}

const char* policy_name(fdds::QosPolicyId_t id) {
  switch (id) {
    case fdds::RELIABILITY_QOS_POLICY_ID: return "reliability";
    case fdds::DURABILITY_QOS_POLICY_ID: return "durability";
    case fdds::DEADLINE_QOS_POLICY_ID: return "deadline";
    case fdds::LIVELINESS_QOS_POLICY_ID: return "liveliness";
    case fdds::OWNERSHIP_QOS_POLICY_ID: return "ownership";
    case fdds::DATAREPRESENTATION_QOS_POLICY_ID: return "data representation";
    default: return "a policy";
  }
}

// What a peer did, as the listeners see it (on Fast DDS' threads). The
// counts are the node's own counters (in its stats), registered at open.
struct PeerEvents {
  std::atomic<int> matched{0};
  std::atomic<uint64_t>* deadlines_missed = nullptr;
  std::atomic<uint64_t>* lost = nullptr;
};

// What both ends of a bridge hold: the topic, its codec and QoS, the
// process's participant and the wire sample reused for every message.
struct TopicEnd {
  std::string node, topic_name;
  const sd::Codec* codec = nullptr;
  sd::EdgeSettings edge;
  std::shared_ptr<sd::Domain> domain;
  fdds::Topic* topic = nullptr;
  std::unique_ptr<sd::WireSample> sample;
  bool doorbell = false;  // a same-host frame ring or mailbox, whose reader waits on its writer's doorbell

  Status open(const OpenContext& ctx, BridgeConfig c) {
    const Params& p = ctx.params();
    node = ctx.node_name();
    auto got = sd::Domain::get(c.domain);
    if (!got.ok()) return got.status();
    domain = std::move(got).value();
    sd::CodecRequest& request = c.request;
    request.reliable = c.edge.reliable;
    // The ring's pixels bypass DDS security's encryption and access control,
    // and its buffers are reused whatever a reliable reader has not yet taken.
    if (domain->secure()) request.shared_memory = sd::CodecRequest::SharedMemory::kLoans;
    auto chosen = sd::choose_codec(p.get_string("type"), request);
    if (!chosen.ok()) return chosen.status();
    codec = *chosen;
    edge = c.edge;
    edge.zero_copy = codec->shares_memory();
    topic_name = request.ros2 ? sd::ros2_topic(p.get_string("topic")) : p.get_string("topic");
    auto made = domain->topic(topic_name, *codec);
    if (!made.ok()) return made.status();
    topic = *made;
    sd::WireOptions& options = c.wire;
    options.capacity = request.capacity;
    options.joint_names = comma_list(c.joint_names);
    sd::set_mailbox(request, *codec, edge.depth, options);
    sample = codec->make_sample(options);
    doorbell = codec->form == sd::Codec::Form::kRing || options.mailbox;
    log().debug("{}: topic {} of type {}{}", node, topic_name, topic->get_type_name(),
                codec->form == sd::Codec::Form::kPlain  ? " (zero copy: data sharing, loaned samples)"
                : codec->form == sd::Codec::Form::kRing ? " (zero copy: the pixels stay in the writer's frame ring)"
                : options.mailbox                       ? " (serialised, and through a same-host mailbox)"
                                                        : "");
    return {};
  }
};

class Publish final : public Node {
 public:
  static constexpr const char* kName = "publish";
  static Contract contract() {
    return with_bridge_params(
               Contract("Publishes every message of its input on a DDS topic (the producer's end of an edge between "
                        "processes). At the end of the stream it tells the readers (an end-of-stream sample).")
                   .input<Message>("in", "messages of the topic's type"))
        .param_double("wait_ms", 0, 0, 3.6e6,
                      "at open, wait up to this long for a first reader (nothing is lost to a late start)");
  }

  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    const BridgeConfig c = ctx.config(&bind_bridge);
    if (Status s = end_.open(ctx, c); !s.ok()) return s;
    fdds::Topic* topic = end_.topic;
    fdds::DataWriterQos qos = sd::writer_qos(*end_.domain->publisher(), end_.edge);
    // Peers of another build say so (domain.hpp); a profile's own user data stays on other forms.
    if (auto said = sd::schema_user_data(*end_.codec); !said.empty()) qos.user_data().data_vec(said);
    reliable_ = c.edge.reliable;
    listener_.owner = this;
    written_ = &ctx.counter("written");
    failed_ = &ctx.counter("failed_writes");
    listener_.events.deadlines_missed = &ctx.counter("deadlines_missed");
    writer_ = end_.domain->publisher()->create_datawriter(topic, qos, &listener_, fdds::StatusMask::all());
    if (writer_ == nullptr) return Status::error("cannot create a DDS writer on " + end_.topic_name);
    // A producer that makes its frames in the frame ring spares the writer its copy.
    if (cv::MatAllocator* ring = end_.sample->frame_allocator()) ctx.offer_frame_allocator(in_, ring);
    copied_ = &ctx.counter("copied_frames");
    const double wait_ms = ctx.params().get_double("wait_ms");
    auto give_up = std::chrono::steady_clock::now() + std::chrono::duration<double, std::milli>(wait_ms);
    while (listener_.events.matched.load() == 0 && std::chrono::steady_clock::now() < give_up)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    if (wait_ms > 0 && listener_.events.matched.load() == 0)
      log().warn("{}: no reader of {} after {} ms (is the other process running, on domain {}?); writing anyway",
                 end_.node, end_.topic_name, wait_ms, c.domain);
    return {};
  }

  Status process(ProcessContext& ctx) override {
    auto message = ctx.get(in_);
    if (message->type_name() != end_.codec->type)
      return Status::error("topic " + end_.topic_name + " carries " + std::string(end_.codec->type) + ", got a " +
                           std::string(message->type_name()));
    bool written = false;
    if (Status s = end_.sample->write(*writer_, message.get(), written); !s.ok())
      return Status::error("topic " + end_.topic_name + ": " + s.message());
    if (!written) {
      if (failed_->fetch_add(1) == 0)
        log().warn("{}: write to {} failed (the reader's history is full?)", end_.node, end_.topic_name);
    } else {
      written_->fetch_add(1);
    }
    copied_->store(end_.sample->frames_copied(), std::memory_order_relaxed);
    return {};
  }

  // The readers end their streams too, at once: a peer that waits for this
  // one (a loop across processes) can finish while this graph still runs.
  void inputs_ended() override { send_end_of_stream(); }

  void close() override {
    if (writer_ != nullptr) {
      send_end_of_stream();
      end_.domain->publisher()->delete_datawriter(writer_);
      writer_ = nullptr;
      const uint64_t written = written_->load(), failed = failed_->load();
      log().debug("{}: {} written to {}, {} failed, {} deadlines missed", end_.node, written, end_.topic_name, failed,
                  listener_.events.deadlines_missed->load());
      if (failed > 0)
        log().warn("{}: {} of {} writes to {} failed", end_.node, failed, failed + written, end_.topic_name);
    }
    end_.domain.reset();
  }

 private:
  void send_end_of_stream() {
    if (ended_ || writer_ == nullptr) return;
    ended_ = true;
    // Best effort may lose one sample; the end of the stream is sent thrice.
    bool written = false;
    for (int i = 0; i < (reliable_ ? 1 : 3); ++i) (void)end_.sample->write(*writer_, nullptr, written);
    if (listener_.events.matched.load() == 0) return;
    if (reliable_) {
      writer_->wait_for_acknowledgments(eprosima::fastrtps::Duration_t(2.0));
    } else {
      // Nothing acknowledges best effort, and a reader drops what it has not
      // taken yet from a writer it hears has gone: the writer (deleted right
      // after this, at close) gives the end of the stream time to be taken.
      // Seen across hosts: the end of the stream lost in 1 of 3 runs without it.
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
  }

  struct Listener final : fdds::DataWriterListener {
    Publish* owner = nullptr;
    PeerEvents events;
    void on_publication_matched(fdds::DataWriter*, const fdds::PublicationMatchedStatus& s) override {
      events.matched.store(s.current_count);
      if (s.current_count_change > 0)
        log().info("{}: a reader of {} joined ({} now)", owner->end_.node, owner->end_.topic_name, s.current_count);
      else if (s.current_count_change < 0)
        log().warn("{}: a reader of {} left ({} now)", owner->end_.node, owner->end_.topic_name, s.current_count);
    }
    void on_offered_deadline_missed(fdds::DataWriter*, const fdds::OfferedDeadlineMissedStatus&) override {
      events.deadlines_missed->fetch_add(1);
    }
    void on_offered_incompatible_qos(fdds::DataWriter*, const fdds::OfferedIncompatibleQosStatus& s) override {
      log().error("{}: a reader of {} asks for an incompatible QoS ({}); it gets nothing", owner->end_.node,
                  owner->end_.topic_name, policy_name(s.last_policy_id));
    }
  };

  InputHandle<Message> in_;
  TopicEnd end_;
  fdds::DataWriter* writer_ = nullptr;
  Listener listener_;
  bool reliable_ = false;
  bool ended_ = false;
  std::atomic<uint64_t>* written_ = nullptr;
  std::atomic<uint64_t>* failed_ = nullptr;
  std::atomic<uint64_t>* copied_ = nullptr;
};

struct SubscribeConfig {
  double missing_peer_ms = 5000;
  bool spin = false;  // WireOptions::reader_wait: kSpin
  bool same_clock = true;
};

class Subscribe final : public Node {
 public:
  static constexpr const char* kName = "subscribe";

  static void bind(ParamBinder<SubscribeConfig>& b) {
    using C = SubscribeConfig;
    b.field("missing_peer_ms", {0, 3.6e6}, "report once when no writer has joined this long after start (0: never)",
            &C::missing_peer_ms)
        .field("spin",
               "zero_copy on one host (a frame ring or a mailbox): wait for the writer's posts spinning instead of "
               "asleep, about 1 us a frame instead of 5-10 us, at a whole core while waiting (other edges: no "
               "effect, said at open)",
               &C::spin)
        .field("same_clock",
               "the writer runs on this host: keep its steady-clock origin, so latency counts from the capture in "
               "the writer's process; false (another host, another clock): latency counts from arrival here",
               &C::same_clock);
  }

  static Contract contract() {
    return with_bridge_params(
               Contract(
                   "Emits every message that arrives on a DDS topic (the consumer's end of an edge between processes); "
                   "a source. Ends when the writer sends its end of stream; a writer that vanishes without one (a "
                   "crash) is waited for and rejoined when it comes back.")
                   .output<Message>("out", "messages of the topic's type"))
        .params(&bind);
  }

  Status open(OpenContext& ctx) override {
    out_ = ctx.output<Message>("out");
    BridgeConfig bridge = ctx.config(&bind_bridge);
    const SubscribeConfig c = ctx.config(&bind);
    if (c.spin) bridge.wire.reader_wait = sd::ReaderWait::kSpin;
    if (Status s = end_.open(ctx, bridge); !s.ok()) return s;
    if (c.spin && !end_.doorbell)
      log().warn("{}: spin has no effect on this edge (it spins on a same-host frame ring or mailbox; this one is {})",
                 end_.node, end_.codec->form == sd::Codec::Form::kPlain ? "loaned samples" : "DDS alone");
    fdds::Topic* topic = end_.topic;
    fdds::DataReaderQos qos = sd::reader_qos(*end_.domain->subscriber(), end_.edge);
    if (auto said = sd::schema_user_data(*end_.codec); !said.empty()) qos.user_data().data_vec(said);
    listener_.owner = this;
    listener_.events.lost = &ctx.counter("lost");
    listener_.events.deadlines_missed = &ctx.counter("deadlines_missed");
    unreadable_ = &ctx.counter("unreadable");
    copied_ = &ctx.counter("copied_frames");
    mailed_ = &ctx.counter("mailbox_frames");
    same_clock_ = c.same_clock;
    missing_peer_at_ = c.missing_peer_ms > 0 ? steady_now_ns() + static_cast<int64_t>(c.missing_peer_ms * 1e6) : 0;
    domain_id_ = bridge.domain;
    reader_ = end_.domain->subscriber()->create_datareader(topic, qos, &listener_, fdds::StatusMask::all());
    if (reader_ == nullptr) return Status::error("cannot create a DDS reader on " + end_.topic_name);
    return {};
  }

  Status process(ProcessContext& ctx) override {
    while (!ctx.stop_requested()) {
      MessagePtr message;
      switch (end_.sample->take(*reader_, &ctx, out_.index, message)) {
        case sd::WireSample::Taken::kMessage:
          copied_->store(end_.sample->frames_copied(), std::memory_order_relaxed);
          mailed_->store(end_.sample->frames_mailed(), std::memory_order_relaxed);
          // Not yet shared with anyone: this node made it.
          if (!same_clock_) std::const_pointer_cast<Message>(message)->origin_ns = steady_now_ns();
          ctx.emit(out_, std::move(message));
          return {};
        case sd::WireSample::Taken::kEnd: return Status::end_of_stream();
        case sd::WireSample::Taken::kUnreadable:
          if (unreadable_->fetch_add(1) == 0)
            log().warn("{}: a sample on {} could not be read: {}", end_.node, end_.topic_name,
                       end_.sample->why_unreadable().empty() ? "malformed, or overwritten while read"
                                                             : end_.sample->why_unreadable());
          continue;
        case sd::WireSample::Taken::kNothing: break;
      }
      if (missing_peer_at_ > 0 && steady_now_ns() > missing_peer_at_) {
        missing_peer_at_ = 0;
        if (!listener_.ever_matched.load())
          log().warn(
              "{}: no writer of {} has joined yet (is the other process running, on domain {}, with the same "
              "topic prefix? A writer of another type does not match: this end reads {}, which both ends' "
              "zero_copy, shared_memory and reliable settings decide)",
              end_.node, end_.topic_name, domain_id_, end_.topic->get_type_name());
      }
      end_.sample->wait(*reader_, 50);
    }
    return {};
  }

  void close() override {
    if (reader_ != nullptr) {
      end_.domain->subscriber()->delete_datareader(reader_);
      reader_ = nullptr;
      const uint64_t lost = listener_.events.lost->load(), missed = listener_.events.deadlines_missed->load(),
                     unreadable = unreadable_->load();
      if (lost > 0 || missed > 0 || unreadable > 0)
        log().warn("{}: {} samples of {} lost, {} unreadable, {} deadlines missed", end_.node, lost, end_.topic_name,
                   unreadable, missed);
    }
    end_.domain.reset();
  }

 private:
  struct Listener final : fdds::DataReaderListener {
    Subscribe* owner = nullptr;
    PeerEvents events;
    std::atomic<bool> ever_matched{false};
    void on_subscription_matched(fdds::DataReader*, const fdds::SubscriptionMatchedStatus& s) override {
      events.matched.store(s.current_count);
      if (s.current_count > 0) ever_matched.store(true);
      if (s.current_count_change > 0)
        log().info("{}: the writer of {} joined", owner->end_.node, owner->end_.topic_name);
      else if (s.current_count_change < 0)
        log().warn("{}: the writer of {} left; waiting for it to come back", owner->end_.node, owner->end_.topic_name);
    }
    void on_requested_deadline_missed(fdds::DataReader*, const fdds::RequestedDeadlineMissedStatus& s) override {
      // A silent writer misses every period: said at the 1st, 10th, 100th, ... miss (the total is in the summary).
      const uint64_t n = events.deadlines_missed->fetch_add(1) + 1;
      uint64_t p = 1;
      while (p < n) p *= 10;
      if (p == n)
        log().warn("{}: nothing on {} within its deadline ({} times)", owner->end_.node, owner->end_.topic_name,
                   s.total_count);
    }
    void on_sample_lost(fdds::DataReader*, const fdds::SampleLostStatus& s) override {
      events.lost->store(static_cast<uint64_t>(s.total_count));
    }
    void on_requested_incompatible_qos(fdds::DataReader*, const fdds::RequestedIncompatibleQosStatus& s) override {
      log().error("{}: the writer of {} offers an incompatible QoS ({}); nothing will arrive", owner->end_.node,
                  owner->end_.topic_name, policy_name(s.last_policy_id));
    }
  };

  OutputHandle<Message> out_;
  TopicEnd end_;
  fdds::DataReader* reader_ = nullptr;
  Listener listener_;
  bool same_clock_ = true;
  int64_t missing_peer_at_ = 0;
  int domain_id_ = 0;
  std::atomic<uint64_t>* unreadable_ = nullptr;
  std::atomic<uint64_t>* copied_ = nullptr;
  std::atomic<uint64_t>* mailed_ = nullptr;
};

}  // namespace

SACCADE_PLUGIN("dds", Publish, Subscribe)
