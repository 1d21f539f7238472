// Small general-purpose nodes: pass-through, recording and counting sinks, a
// counting source, a pairing join, a failure injector and a JSON lines writer. Tests, benchmarks and
// graph debugging use them.
#include <chrono>
#include <thread>

#include "json_lines.hpp"
#include "saccade/plugin.hpp"
#include "saccade/testing.hpp"

namespace {

using namespace saccade;

class Passthrough final : public Node {
 public:
  static constexpr const char* kName = "passthrough";
  static Contract contract() {
    return Contract("Forwards every message unchanged (same pointer); optional busy time per message.")
        .input<Message>("in", "any message")
        .output<Message>("out", "the same message")
        .param_int("busy_us", 0, 0, 10'000'000, "sleep this long per message (simulates work)");
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    out_ = ctx.output<Message>("out");
    busy_us_ = ctx.params().get_int("busy_us");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (busy_us_ > 0) std::this_thread::sleep_for(std::chrono::microseconds(busy_us_));
    ctx.emit(out_, ctx.get(in_));
    return {};
  }

 private:
  InputHandle<Message> in_;
  OutputHandle<Message> out_;
  int64_t busy_us_ = 0;
};

struct RecordConfig {
  std::string key;  // empty: the node's name
  int64_t busy_us = 0;
};

class Record final : public Node {
 public:
  static constexpr const char* kName = "record";
  static void bind(ParamBinder<RecordConfig>& b) {
    b.field("key", "Recorder key (default: the node's name)", &RecordConfig::key)
        .field("busy_us", {0, 10'000'000}, "sleep this long per message (a slow consumer)", &RecordConfig::busy_us);
  }
  static Contract contract() {
    return Contract("Keeps every message it receives in the process-wide Recorder (for tests and embedding).")
        .input<Message>("in", "any message")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    config_ = ctx.config(&bind);
    if (config_.key.empty()) config_.key = ctx.node_name();
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (config_.busy_us > 0) std::this_thread::sleep_for(std::chrono::microseconds(config_.busy_us));
    testing::Recorder::instance().record(config_.key, ctx.get(in_));
    return {};
  }

 private:
  InputHandle<Message> in_;
  RecordConfig config_;
};

class Null final : public Node {
 public:
  static constexpr const char* kName = "null";
  static Contract contract() {
    return Contract("Discards every message (its stats count them).").input<Message>("in", "any message");
  }
  Status process(ProcessContext&) override { return {}; }
};

struct CounterConfig {
  int64_t count = 10;  // 0: endless
  cv::Size size{8, 8};
  double step_ms = 10.0;
  double offset_ms = 0.0;
  int64_t skip_every = 0;
  double rate_hz = 0.0;  // 0: unpaced
  int camera_id = 0;
};

class Counter final : public Node {
 public:
  static constexpr const char* kName = "counter";
  static constexpr Out<Image> kImage{"image", "frame k: every pixel k mod 256"};

  static void bind(ParamBinder<CounterConfig>& b) {
    using C = CounterConfig;
    b.field("count", {0, 1'000'000'000}, "frames before end of stream (0: endless)", &C::count)
        .field("size", "image size", &C::size)
        .field("step_ms", {0, 1e6}, "timestamp step between frames", &C::step_ms)
        .field("offset_ms", {-1e6, 1e6}, "timestamp of frame 0", &C::offset_ms)
        .field("skip_every", {0, 1'000'000}, "leave out every k-th frame (k > 0) to test pairing", &C::skip_every)
        .field("rate_hz", {0, 1e6}, "pace frames in real time (0: as fast as possible)", &C::rate_hz)
        .field("camera_id", {0, 255}, "camera id carried by the images", &C::camera_id);
  }
  static Contract contract() {
    return Contract(
               "A source of small gray images whose pixels hold the frame number, with timestamps on a fixed step.")
        .ports(kImage)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    config_ = ctx.config(&bind);
    step_ns_ = static_cast<int64_t>(config_.step_ms * 1e6);
    offset_ns_ = static_cast<int64_t>(config_.offset_ms * 1e6);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    const CounterConfig& c = config_;
    if (c.count > 0 && frame_ >= c.count) return Status::end_of_stream();
    int64_t k = frame_++;
    if (c.skip_every > 0 && k % c.skip_every == c.skip_every - 1) return {};
    if (c.rate_hz > 0) {
      if (start_ns_ == 0) start_ns_ = steady_now_ns();
      if (!ctx.sleep_until(start_ns_ + static_cast<int64_t>(static_cast<double>(k) * 1e9 / c.rate_hz)))
        return Status::end_of_stream();
    }
    auto img = ctx.make(kImage);
    img->mat.allocator = ctx.frame_allocator(kImage);  // a DDS edge's frame ring: written in place
    img->mat.create(c.size, CV_8UC1);
    img->mat.setTo(cv::Scalar(static_cast<double>(k % 256)));
    img->camera_id = c.camera_id;
    img->frame_id = k;
    img->timestamp_ns = offset_ns_ + k * step_ns_;
    img->origin_ns = steady_now_ns();
    ctx.emit(kImage, std::move(img));
    return {};
  }

 private:
  CounterConfig config_;
  int64_t frame_ = 0, step_ns_ = 0, offset_ns_ = 0, start_ns_ = 0;
};

class Pair final : public Node {
 public:
  static constexpr const char* kName = "pair";
  static constexpr Out<Region> kPair{"pair", "center = (a.frame_id, b.frame_id), label = \"ts_a,ts_b\""};
  static Contract contract() {
    return Contract(
               "Joins two inputs; emits a Region whose centre holds the two frame ids and whose label holds both "
               "timestamps (ns).")
        .input<Message>("a", "first input")
        .input<Message>("b", "second input")
        .ports(kPair);
  }
  Status open(OpenContext& ctx) override {
    a_ = ctx.input<Message>("a");
    b_ = ctx.input<Message>("b");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto a = ctx.get(a_);
    auto b = ctx.get(b_);
    auto r = ctx.make(kPair);
    r->center = {static_cast<double>(a->frame_id), static_cast<double>(b->frame_id)};
    r->label = std::to_string(a->timestamp_ns) + "," + std::to_string(b->timestamp_ns);
    ctx.emit(kPair, std::move(r));
    return {};
  }

 private:
  InputHandle<Message> a_, b_;
};

class Latch final : public Node {
 public:
  static constexpr const char* kName = "latch";
  static constexpr Out<Region> kOut{"out", "center = (in.frame_id, side.frame_id or -1 when none yet)"};
  static Contract contract() {
    return Contract("Runs on 'in' and reports which message it saw on the side input: a probe for feedback edges.")
        .input<Message>("in", "triggers a call")
        .side_input<Message>("side", "newest value seen, never triggers")
        .ports(kOut)
        .param_double("sleep_ms", 0.0, 0.0, 60'000.0,
                      "sleep this long (ProcessContext::sleep_until) before reading the side input");
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    side_ = ctx.input<Message>("side");
    sleep_ns_ = static_cast<int64_t>(ctx.params().get_double("sleep_ms") * 1e6);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (sleep_ns_ > 0 && !ctx.sleep_until(steady_now_ns() + sleep_ns_)) return Status::end_of_stream();
    auto side = ctx.get(side_);
    auto r = ctx.make(kOut);
    r->center = {static_cast<double>(ctx.get(in_)->frame_id), side ? static_cast<double>(side->frame_id) : -1.0};
    ctx.emit(kOut, std::move(r));
    return {};
  }

 private:
  InputHandle<Message> in_, side_;
  int64_t sleep_ns_ = 0;
};

struct FailConfig {
  int64_t fail_at = 3;     // first call (0-based) that fails
  int64_t fail_every = 0;  // 0: only once
  bool throw_exception = false;
};

class Fail final : public Node {
 public:
  static constexpr const char* kName = "fail";
  static void bind(ParamBinder<FailConfig>& b) {
    b.field("fail_at", {0, 1'000'000'000}, "first call (0-based) that fails", &FailConfig::fail_at)
        .field("fail_every", {0, 1'000'000'000}, "then every k-th call fails again (0: only once)",
               &FailConfig::fail_every)
        .field("throw", "throw an exception instead of returning an error", &FailConfig::throw_exception);
  }
  static Contract contract() {
    return Contract("Forwards messages but fails (or throws) on chosen frames: exercises error handling.")
        .input<Message>("in", "any message")
        .output<Message>("out", "the same message, unless this frame fails")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    out_ = ctx.output<Message>("out");
    config_ = ctx.config(&bind);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    const FailConfig& c = config_;
    int64_t k = calls_++;
    bool fails = k == c.fail_at || (c.fail_every > 0 && k > c.fail_at && (k - c.fail_at) % c.fail_every == 0);
    if (fails) {
      if (c.throw_exception) throw std::runtime_error("injected exception at call " + std::to_string(k));
      return Status::error("injected failure at call " + std::to_string(k));
    }
    ctx.emit(out_, ctx.get(in_));
    return {};
  }

 private:
  InputHandle<Message> in_;
  OutputHandle<Message> out_;
  FailConfig config_;
  int64_t calls_ = 0;
};

}  // namespace

SACCADE_PLUGIN("util", Passthrough, Record, Null, Counter, Pair, Latch, Fail, saccade::util::JsonLines)
