// One-way latency and throughput of an edge between two processes on one host:
// a saccade DDS edge (the bridges' own code: codecs, QoS, participant), a plain
// Fast DDS writer/reader with the best settings found (a plain type, data
// sharing, loans), and Fast DDS with its defaults (an unbounded type, default
// QoS and transports). The reader runs in a child process (this program with
// --role reader); both sides read CLOCK_MONOTONIC, so the latency is the
// reader's clock once the payload is usable minus the writer's once it was
// ready in the writer's memory: every edge's copy into what DDS sends counts,
// as a saccade edge's does (the message is ready before the bridge packs it).
// best_in_place alone starts its clock after filling the loan: a producer
// that writes its payload straight into DDS' memory, the floor of the stack.
//
//   saccade_dds_bench [--messages N] [--period-us P] [--throughput-s S] [--payload NAME] [--variant NAME]
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <fastdds/dds/core/LoanableSequence.hpp>
#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/publisher/DataWriter.hpp>
#include <fastdds/dds/subscriber/DataReader.hpp>
#include <fastdds/dds/subscriber/SampleInfo.hpp>
#include <fastdds/dds/topic/TypeSupport.hpp>
#include <opencv2/core.hpp>

#include "dds_benchPubSubTypes.h"
#include "codec.hpp"
#include "domain.hpp"
#include "edge_codec.hpp"
#include "saccade/graph.hpp"
#include "saccade/message.hpp"

extern char** environ;

namespace {

namespace fdds = eprosima::fastdds::dds;
using namespace saccade;
namespace sd = saccade::dds;

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int64_t process_cpu_ns() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<int64_t>(t.tv_sec) * 1'000'000'000 + t.tv_nsec;
}

struct Options {
  std::string role = "driver", payload = "all", variant = "all";
  int messages = 2000;
  int period_us = 2000;
  double throughput_s = 1.0;
  int domain = 73;
};

struct PayloadKind {
  const char* name;
  std::size_t bytes;  // what a plain peer carries
  const char* saccade_type;
};
const PayloadKind kPayloads[] = {
    {"64B", 64, "JointTargets"},
    {"retina", 5 * 32 * 24, "Retina"},
    {"gray", 1024 * 768, "Image"},
    {"colour", 1024 * 768 * 3, "Image"},
};
// *_spin: the reader spins instead of sleeping between messages (a whole
// core): saccade's on its writer's doorbell (the edge's `spin`), the plain
// peer by polling take() (what a plain Fast DDS reader can do).
const char* const kVariants[] = {"saccade_in_place",  "saccade",  "best_in_place", "best",
                                 "best_copy",         "defaults", "defaults_rel",  "saccade_in_place_spin",
                                 "best_in_place_spin"};
bool spins(const std::string& variant) { return variant.ends_with("_spin"); }
std::string without_spin(const std::string& variant) {
  return spins(variant) ? variant.substr(0, variant.size() - 5) : variant;
}
// saccade_in_place needs a producer that can write into the edge's memory: images.
bool applies(const char* variant, const PayloadKind& k) {
  return without_spin(variant) != "saccade_in_place" || std::string(k.saccade_type) == "Image";
}

// The saccade message a payload stands for, filled with noise.
std::shared_ptr<Message> make_message(const PayloadKind& p) {
  std::string type = p.saccade_type;
  if (type == "JointTargets") {
    auto m = std::make_shared<JointTargets>();
    m->position = {0.1, -0.2, 0.3, -0.1,
                   0.2};  // 5 joints: 2 x 40 B of doubles, the stamp and flags: ~130 B on the wire
    m->velocity = {0, 0, 0, 0, 0};
    return m;
  }
  if (type == "Retina") {
    auto m = std::make_shared<Retina>();
    for (int l = 0; l < 5; ++l) {
      m->levels.emplace_back(24, 32, CV_8UC1);
      cv::randu(m->levels.back(), 0, 256);
      m->geometry.push_back({cv::Rect(0, 0, 32 << l, 24 << l), double(1 << l), double(1 << l)});
    }
    m->source_size = {1024, 768};
    return m;
  }
  auto m = std::make_shared<Image>();
  m->mat.create(768, 1024, p.bytes == 1024 * 768 ? CV_8UC1 : CV_8UC3);
  cv::randu(m->mat, 0, 256);
  return m;
}

// --- the three kinds of writer and reader, behind one interface ---

struct Writer {
  virtual ~Writer() = default;
  virtual bool matched() = 0;
  virtual bool write(uint64_t seq) = 0;
};
struct Reader {
  virtual ~Reader() = default;
  // Takes one sample if any: its sequence number and latency.
  virtual bool take(uint64_t& seq, int64_t& latency_ns) = 0;
  virtual void wait(int ms) = 0;
};

bool is_matched(fdds::DataWriter* w) {
  fdds::PublicationMatchedStatus s;
  w->get_publication_matched_status(s);
  return s.current_count > 0;
}

// saccade: the bridges' code path (dds.publish / dds.subscribe without the executor).
struct SaccadeEnd {
  std::shared_ptr<sd::Domain> domain;
  const sd::Codec* codec = nullptr;
  std::unique_ptr<sd::WireSample> sample;
  fdds::Topic* topic = nullptr;
  sd::EdgeSettings settings;
  void open(const Options& o, const PayloadKind& p, const std::string& topic_name, bool spin = false) {
    auto got = sd::Domain::get(o.domain);
    if (!got.ok()) throw std::runtime_error(got.error());
    domain = std::move(got).value();
    const EdgeQos qos = default_qos(p.saccade_type);
    // As the partitioner does on one host: a zero-copy edge.
    const sd::CodecRequest request{.zero_copy = true, .reliable = qos.reliable};
    auto chosen = sd::choose_codec(p.saccade_type, request);
    if (!chosen.ok()) throw std::runtime_error(chosen.error());
    codec = *chosen;
    settings.reliable = qos.reliable;
    settings.depth = qos.depth;
    settings.zero_copy = codec->shares_memory();
    auto made = domain->topic(topic_name, *codec);
    if (!made.ok()) throw std::runtime_error(made.error());
    topic = *made;
    sd::WireOptions options;  // as dds.publish / dds.subscribe set them on a zero-copy edge
    sd::set_mailbox(request, *codec, settings.depth, options);
    if (spin) options.reader_wait = sd::ReaderWait::kSpin;
    sample = codec->make_sample(options);
  }
};

struct SaccadeWriter final : Writer {
  SaccadeEnd end;
  fdds::DataWriter* writer = nullptr;
  std::shared_ptr<Message> message;
  // in_place: the producer creates its image with the edge's frame allocator
  // (the writer's frame ring) and the clock starts once it has written its
  // frame there, as best_in_place's does once the loan is filled.
  cv::MatAllocator* in_place = nullptr;
  cv::Mat frame;
  SaccadeWriter(const Options& o, const PayloadKind& p, const std::string& topic, bool in_place_fill) {
    end.open(o, p, topic);
    writer =
        end.domain->publisher()->create_datawriter(end.topic, sd::writer_qos(*end.domain->publisher(), end.settings));
    message = make_message(p);
    if (in_place_fill) {
      in_place = end.sample->frame_allocator();
      if (in_place == nullptr) throw std::runtime_error("the edge has no frame allocator");
      frame = static_cast<Image&>(*message).mat.clone();
    }
  }
  ~SaccadeWriter() override { end.domain->publisher()->delete_datawriter(writer); }
  bool matched() override { return is_matched(writer); }
  bool write(uint64_t seq) override {
    if (in_place != nullptr) {
      auto& image = static_cast<Image&>(*message);
      image.release_shared_buffers();  // as the producer's pool does before it reuses the message
      image.mat.allocator = in_place;
      image.mat.create(frame.size(), frame.type());
      frame.copyTo(image.mat);  // the producer's own work
    }
    message->frame_id = static_cast<int64_t>(seq);
    message->origin_ns = message->timestamp_ns = now_ns();
    bool written = false;
    Status s = end.sample->write(*writer, message.get(), written);
    return s.ok() && written;
  }
};

struct SaccadeReader final : Reader {
  SaccadeEnd end;
  fdds::DataReader* reader = nullptr;
  MessagePtr slot;
  uint64_t checksum = 0;
  SaccadeReader(const Options& o, const PayloadKind& p, const std::string& topic, bool spin) {
    end.open(o, p, topic, spin);
    reader =
        end.domain->subscriber()->create_datareader(end.topic, sd::reader_qos(*end.domain->subscriber(), end.settings));
  }
  ~SaccadeReader() override { end.domain->subscriber()->delete_datareader(reader); }
  bool take(uint64_t& seq, int64_t& latency_ns) override {
    if (end.sample->take(*reader, nullptr, 0, slot) != sd::WireSample::Taken::kMessage) return false;
    if (const auto* image = dynamic_cast<const Image*>(slot.get()); image != nullptr && !image->mat.empty())
      checksum += image->mat.data[0] + image->mat.dataend[-1];  // in place or copied, the frame is usable
    latency_ns = now_ns() - slot->origin_ns;
    seq = static_cast<uint64_t>(slot->frame_id);
    return true;
  }
  void wait(int ms) override { end.sample->wait(*reader, ms); }
};

// A participant of its own with Fast DDS' default QoS (the peers do not share saccade's).
struct PlainParticipant {
  fdds::DomainParticipant* participant = nullptr;
  fdds::Publisher* publisher = nullptr;
  fdds::Subscriber* subscriber = nullptr;
  fdds::Topic* topic = nullptr;
  PlainParticipant(int domain, fdds::TypeSupport type, const std::string& topic_name) {
    participant =
        fdds::DomainParticipantFactory::get_instance()->create_participant(domain, fdds::PARTICIPANT_QOS_DEFAULT);
    type.register_type(participant);
    topic = participant->create_topic(topic_name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
    publisher = participant->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
    subscriber = participant->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  }
  ~PlainParticipant() {
    participant->delete_contained_entities();
    fdds::DomainParticipantFactory::get_instance()->delete_participant(participant);
  }
};

// best: a plain type, data sharing (automatic for plain types on one host), loans.
template <class T, class TPubSub>
struct BestWriter final : Writer {
  PlainParticipant p;
  fdds::DataWriter* writer = nullptr;
  std::vector<uint8_t> frame;  // the application's frame, copied into the loan
  // in_place: the clock starts once the loan is filled, as if the producer
  // had written the payload there itself (no copy of the application's).
  bool in_place = false;
  BestWriter(const Options& o, const PayloadKind& k, const std::string& topic, const EdgeQos& edge, bool in_place_fill)
      : p(o.domain, fdds::TypeSupport(new TPubSub()), topic), frame(k.bytes), in_place(in_place_fill) {
    cv::Mat noise(1, static_cast<int>(frame.size()), CV_8UC1, frame.data());
    cv::randu(noise, 0, 256);
    fdds::DataWriterQos qos = p.publisher->get_default_datawriter_qos();
    // The same reliability and depth as the saccade edge of the payload's type.
    qos.reliability().kind = edge.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = edge.depth;
    qos.resource_limits().extra_samples = 3;
    qos.data_sharing().automatic();
    writer = p.publisher->create_datawriter(p.topic, qos);
  }
  bool matched() override { return is_matched(writer); }
  bool write(uint64_t seq) override {
    void* memory = nullptr;
    if (writer->loan_sample(memory) != ReturnCode_t::RETCODE_OK) return false;
    T& s = *static_cast<T*>(memory);
    const int64_t ready_ns = now_ns();
    std::memcpy(s.data().data(), frame.data(), frame.size());
    s.seq(seq);
    s.sent_ns(in_place ? now_ns() : ready_ns);
    if (writer->write(memory)) return true;
    writer->discard_loan(memory);
    return false;
  }
};

template <class T, class TPubSub>
struct BestReader final : Reader {
  PlainParticipant p;
  fdds::DataReader* reader = nullptr;
  fdds::LoanableSequence<T> samples;
  fdds::SampleInfoSeq infos;
  uint64_t checksum = 0;
  // best_copy: the payload copied out before the loan goes back, as a consumer
  // that keeps the frame must (the writer's ring reuses the sample).
  bool copy_out = false;
  bool poll = false;  // wait() returns at once: the reader polls take()
  std::vector<uint8_t> kept;
  BestReader(const Options& o, const PayloadKind& k, const std::string& topic, const EdgeQos& edge, bool copy,
             bool polls)
      : p(o.domain, fdds::TypeSupport(new TPubSub()), topic), copy_out(copy), poll(polls), kept(k.bytes) {
    fdds::DataReaderQos qos = p.subscriber->get_default_datareader_qos();
    // The same reliability and depth as the saccade edge of the payload's type.
    qos.reliability().kind = edge.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = edge.depth;
    qos.data_sharing().automatic();
    reader = p.subscriber->create_datareader(p.topic, qos);
  }
  bool take(uint64_t& seq, int64_t& latency_ns) override {
    if (reader->take(samples, infos, 1) != ReturnCode_t::RETCODE_OK) return false;
    bool ok = samples.length() == 1 && infos[0].valid_data;
    if (ok) {
      const T& s = samples[0];
      seq = s.seq();
      if (copy_out) {
        std::memcpy(kept.data(), s.data().data(), kept.size());
        checksum += kept.back();
      } else {
        checksum += s.data().front() + s.data().back();  // in place, untouched: the loan at its cheapest
      }
      latency_ns = now_ns() - s.sent_ns();
    }
    reader->return_loan(samples, infos);
    return ok;
  }
  void wait(int ms) override {
    if (!poll) reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(0, ms * 1'000'000u));
  }
};

// defaults: an unbounded type, default participant, writer and reader QoS.
struct DefaultWriter final : Writer {
  PlainParticipant p;
  fdds::DataWriter* writer = nullptr;
  bench_idl::Blob blob;
  std::vector<uint8_t> frame;
  DefaultWriter(const Options& o, const PayloadKind& k, const std::string& topic)
      : p(o.domain, fdds::TypeSupport(new bench_idl::BlobPubSubType()), topic), frame(k.bytes) {
    cv::Mat noise(1, static_cast<int>(frame.size()), CV_8UC1, frame.data());
    cv::randu(noise, 0, 256);
    writer = p.publisher->create_datawriter(p.topic, fdds::DATAWRITER_QOS_DEFAULT);
  }
  bool matched() override { return is_matched(writer); }
  bool write(uint64_t seq) override {
    blob.sent_ns(now_ns());
    blob.data().assign(frame.begin(), frame.end());
    blob.seq(seq);
    return writer->write(&blob);
  }
};

struct DefaultReader final : Reader {
  PlainParticipant p;
  fdds::DataReader* reader = nullptr;
  bench_idl::Blob blob;
  // reliable: the default reader is best effort and loses frames; defaults_rel asks for
  // reliable, which the default writer offers (Fast DDS' defaults otherwise).
  DefaultReader(const Options& o, const PayloadKind&, const std::string& topic, bool reliable)
      : p(o.domain, fdds::TypeSupport(new bench_idl::BlobPubSubType()), topic) {
    fdds::DataReaderQos qos = p.subscriber->get_default_datareader_qos();
    if (reliable) qos.reliability().kind = fdds::RELIABLE_RELIABILITY_QOS;
    reader = p.subscriber->create_datareader(p.topic, qos);
  }
  bool take(uint64_t& seq, int64_t& latency_ns) override {
    fdds::SampleInfo info;
    if (reader->take_next_sample(&blob, &info) != ReturnCode_t::RETCODE_OK || !info.valid_data) return false;
    latency_ns = now_ns() - blob.sent_ns();
    seq = blob.seq();
    return true;
  }
  void wait(int ms) override { reader->wait_for_unread_message(eprosima::fastrtps::Duration_t(0, ms * 1'000'000u)); }
};

template <class Base, template <class, class> class Best, class... Args>
std::unique_ptr<Base> make_best(std::size_t bytes, Args&&... args) {
  switch (bytes) {
    case 64: return std::make_unique<Best<bench_idl::Plain64, bench_idl::Plain64PubSubType>>(args...);
    case 3840: return std::make_unique<Best<bench_idl::Plain3840, bench_idl::Plain3840PubSubType>>(args...);
    case 786432: return std::make_unique<Best<bench_idl::Plain786432, bench_idl::Plain786432PubSubType>>(args...);
    default: return std::make_unique<Best<bench_idl::Plain2359296, bench_idl::Plain2359296PubSubType>>(args...);
  }
}

std::unique_ptr<Writer> make_writer(const Options& o, const PayloadKind& k, const std::string& spun,
                                    const std::string& topic) {
  const std::string variant = without_spin(spun);  // the writer is the same
  if (variant == "saccade" || variant == "saccade_in_place")
    return std::make_unique<SaccadeWriter>(o, k, topic, variant == "saccade_in_place");
  if (variant == "best" || variant == "best_copy" || variant == "best_in_place")
    return make_best<Writer, BestWriter>(k.bytes, o, k, topic, default_qos(k.saccade_type), variant == "best_in_place");
  return std::make_unique<DefaultWriter>(o, k, topic);
}

std::unique_ptr<Reader> make_reader(const Options& o, const PayloadKind& k, const std::string& spun,
                                    const std::string& topic) {
  const std::string variant = without_spin(spun);
  if (variant == "saccade" || variant == "saccade_in_place")
    return std::make_unique<SaccadeReader>(o, k, topic, spins(spun));
  if (variant == "best" || variant == "best_copy" || variant == "best_in_place")
    return make_best<Reader, BestReader>(k.bytes, o, k, topic, default_qos(k.saccade_type), variant == "best_copy",
                                         spins(spun));
  return std::make_unique<DefaultReader>(o, k, topic, variant == "defaults_rel");
}

const PayloadKind& payload_named(const std::string& name) {
  for (const auto& p : kPayloads)
    if (name == p.name) return p;
  throw std::runtime_error("unknown payload " + name);
}

std::string topic_of(const Options& o) { return "bench/" + o.payload + "/" + o.variant; }

// One line of the reader's results: `what` (paced: the latency phase's, as
// soon as it is over; result: everything, at the end), received, p50, p99,
// max (us), messages per second, CPU %.
void print_latency(const char* what, std::vector<int64_t> latency, int64_t cpu0, int64_t wall0, int64_t cpu1,
                   int64_t wall1, double per_s = 0.0) {
  std::sort(latency.begin(), latency.end());
  auto pct = [&](double q) {
    return latency.empty() ? 0.0
                           : latency[std::min(latency.size() - 1, static_cast<std::size_t>(q * latency.size()))] / 1e3;
  };
  const double cpu = wall1 > wall0 ? 100.0 * (cpu1 - cpu0) / (wall1 - wall0) : 0.0;
  std::printf("%s %zu %.1f %.1f %.1f %.1f %.1f\n", what, latency.size(), pct(0.5), pct(0.99),
              latency.empty() ? 0.0 : latency.back() / 1e3, per_s, cpu);
  std::fflush(stdout);
}

// The child: reads until the writer has been quiet for a second after the
// throughput phase (or 60 s pass), then prints one line of results.
int run_reader(const Options& o) {
  const PayloadKind& k = payload_named(o.payload);
  auto reader = make_reader(o, k, o.variant, topic_of(o));
  std::vector<int64_t> latency;
  latency.reserve(static_cast<std::size_t>(o.messages));
  uint64_t throughput_count = 0;
  int64_t first_ns = 0, last_ns = 0, last_seen = now_ns();
  // The reader process's CPU (all its threads) over the paced phase, as a
  // share of one core: what waiting for frames costs, sleeping or spinning.
  int64_t paced_cpu0 = -1, paced_wall0 = 0, paced_cpu1 = 0, paced_wall1 = 0;
  const int64_t give_up = now_ns() + 60'000'000'000;
  std::printf("ready\n");
  std::fflush(stdout);
  while (now_ns() < give_up) {
    uint64_t seq = 0;
    int64_t ns = 0;
    if (reader->take(seq, ns)) {
      last_seen = now_ns();
      if (seq < static_cast<uint64_t>(o.messages)) {
        latency.push_back(ns);
        if (paced_cpu0 < 0) {
          paced_cpu0 = process_cpu_ns();
          paced_wall0 = last_seen;
        }
        paced_cpu1 = process_cpu_ns();
        paced_wall1 = last_seen;
      } else {
        if (throughput_count++ == 0) {
          first_ns = last_seen;
          // The paced phase's figures now: some plain Fast DDS readers crash
          // in the back-to-back phase (docs/performance.md).
          print_latency("paced", latency, paced_cpu0, paced_wall0, paced_cpu1, paced_wall1);
        }
        last_ns = last_seen;
      }
      continue;
    }
    if ((throughput_count > 0 || !latency.empty()) && now_ns() - last_seen > 1'000'000'000) break;
    reader->wait(20);
  }
  const double span_s = (last_ns - first_ns) / 1e9;
  print_latency("result", latency, paced_cpu0, paced_wall0, paced_cpu1, paced_wall1,
                throughput_count > 1 && span_s > 0 ? (throughput_count - 1) / span_s : 0.0);
  return 0;
}

// What one payload and edge variant measured (named apart from saccade::Result).
struct CaseResult {
  std::size_t received = 0;
  double p50 = 0, p99 = 0, max = 0, per_s = 0, cpu = 0;
  bool ok = false;     // the whole run's line came
  bool paced = false;  // the latency phase's line came
  int status = 0;      // the reader's wait status
};

CaseResult run_case(const Options& o, const char* self, const PayloadKind& k, const std::string& variant) {
  Options child = o;
  child.payload = k.name;
  child.variant = variant;
  std::vector<std::string> args = {self,
                                   "--role",
                                   "reader",
                                   "--payload",
                                   k.name,
                                   "--variant",
                                   variant,
                                   "--messages",
                                   std::to_string(o.messages),
                                   "--domain",
                                   std::to_string(o.domain)};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  int out[2];
  if (pipe(out) != 0) return {};
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], STDOUT_FILENO);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  pid_t pid = 0;
  int rc = posix_spawn(&pid, self, &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  if (rc != 0) return {};
  FILE* from_child = fdopen(out[0], "r");
  char line[256] = {};
  if (std::fgets(line, sizeof line, from_child) == nullptr) return {};  // "ready": its reader exists

  CaseResult r;
  {
    auto writer = make_writer(o, k, variant, topic_of(child));
    const int64_t match_by = now_ns() + 10'000'000'000;
    while (!writer->matched() && now_ns() < match_by) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the reader's side of discovery
    // Latency: paced, so each message travels alone.
    auto next = std::chrono::steady_clock::now();
    for (int i = 0; i < o.messages; ++i) {
      writer->write(static_cast<uint64_t>(i));
      next += std::chrono::microseconds(o.period_us);
      std::this_thread::sleep_until(next);
    }
    // Throughput: back to back; the reader counts what it gets.
    const int64_t stop = now_ns() + static_cast<int64_t>(o.throughput_s * 1e9);
    for (uint64_t seq = static_cast<uint64_t>(o.messages); now_ns() < stop; ++seq) writer->write(seq);
    while (std::fgets(line, sizeof line, from_child) != nullptr) {
      if (std::sscanf(line, "result %zu %lf %lf %lf %lf %lf", &r.received, &r.p50, &r.p99, &r.max, &r.per_s, &r.cpu) ==
          6)
        r.ok = true;
      else if (std::sscanf(line, "paced %zu %lf %lf %lf %lf %lf", &r.received, &r.p50, &r.p99, &r.max, &r.per_s,
                           &r.cpu) == 6)
        r.paced = true;
    }
  }
  std::fclose(from_child);
  waitpid(pid, &r.status, 0);
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i + 1 < argc; i += 2) {
    std::string a = argv[i], v = argv[i + 1];
    if (a == "--role")
      o.role = v;
    else if (a == "--payload")
      o.payload = v;
    else if (a == "--variant")
      o.variant = v;
    else if (a == "--messages")
      o.messages = std::stoi(v);
    else if (a == "--period-us")
      o.period_us = std::stoi(v);
    else if (a == "--throughput-s")
      o.throughput_s = std::stod(v);
    else if (a == "--domain")
      o.domain = std::stoi(v);
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  try {
    if (o.role == "reader") return run_reader(o);
    std::printf("%-8s %-21s %9s %10s %10s %10s %12s %10s %8s\n", "payload", "edge", "received", "p50_us", "p99_us",
                "max_us", "msgs_per_s", "MB_per_s", "cpu_%");
    for (const auto& k : kPayloads) {
      if (o.payload != "all" && o.payload != k.name) continue;
      for (const char* variant : kVariants) {
        if ((o.variant != "all" && o.variant != variant) || !applies(variant, k)) continue;
        CaseResult r = run_case(o, argv[0], k, variant);
        const char* ended = WIFSIGNALED(r.status) ? "signal" : "exit status";
        const int code = WIFSIGNALED(r.status) ? WTERMSIG(r.status) : WEXITSTATUS(r.status);
        if (!r.ok && !r.paced) {
          std::printf("%-8s %-21s  failed: no result from the reader (%s %d)\n", k.name, variant, ended, code);
          continue;
        }
        if (!r.ok) {
          std::printf(
              "%-8s %-21s %5zu/%-4d %10.1f %10.1f %10.1f %12s %10s %8.1f  (the reader died back to back: %s %d)\n",
              k.name, variant, r.received, o.messages, r.p50, r.p99, r.max, "-", "-", r.cpu, ended, code);
          std::fflush(stdout);
          continue;
        }
        std::printf("%-8s %-21s %5zu/%-4d %10.1f %10.1f %10.1f %12.0f %10.1f %8.1f\n", k.name, variant, r.received,
                    o.messages, r.p50, r.p99, r.max, r.per_s, r.per_s * static_cast<double>(k.bytes) / 1e6, r.cpu);
        std::fflush(stdout);
      }
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "saccade_dds_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
