// Small general-purpose nodes: pass-through, recording and counting sinks, a
// counting source, a pairing join and a failure injector. Tests, benchmarks and
// graph debugging use them.
#include <chrono>
#include <thread>

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

class Record final : public Node {
 public:
  static constexpr const char* kName = "record";
  static Contract contract() {
    return Contract("Keeps every message it receives in the process-wide Recorder (for tests and embedding).")
        .input<Message>("in", "any message")
        .param_string("key", "", "Recorder key (default: the node's name)")
        .param_int("busy_us", 0, 0, 10'000'000, "sleep this long per message (a slow consumer)");
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    key_ = ctx.params().get_string("key");
    if (key_.empty()) key_ = ctx.node_name();
    busy_us_ = ctx.params().get_int("busy_us");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (busy_us_ > 0) std::this_thread::sleep_for(std::chrono::microseconds(busy_us_));
    testing::Recorder::instance().record(key_, ctx.get(in_));
    return {};
  }

 private:
  InputHandle<Message> in_;
  std::string key_;
  int64_t busy_us_ = 0;
};

class Null final : public Node {
 public:
  static constexpr const char* kName = "null";
  static Contract contract() { return Contract("Discards every message (its stats count them).").input<Message>("in", "any message"); }
  Status process(ProcessContext&) override { return {}; }
};

class Counter final : public Node {
 public:
  static constexpr const char* kName = "counter";
  static Contract contract() {
    return Contract("A source of small gray images whose pixels hold the frame number, with timestamps on a fixed step.")
        .output<Image>("image", "frame k: every pixel k mod 256")
        .param_int("count", 10, 0, 1'000'000'000, "frames before end of stream (0: endless)")
        .param_size("size", {8, 8}, "image size")
        .param_double("step_ms", 10.0, 0.0, 1e6, "timestamp step between frames")
        .param_double("offset_ms", 0.0, -1e6, 1e6, "timestamp of frame 0")
        .param_int("skip_every", 0, 0, 1'000'000, "leave out every k-th frame (k > 0) to test pairing")
        .param_double("rate_hz", 0.0, 0.0, 1e6, "pace frames in real time (0: as fast as possible)")
        .param_int("camera_id", 0, 0, 255, "camera id carried by the images");
  }
  Status open(OpenContext& ctx) override {
    out_ = ctx.output<Image>("image");
    const auto& p = ctx.params();
    count_ = p.get_int("count");
    size_ = p.get_size("size");
    step_ns_ = static_cast<int64_t>(p.get_double("step_ms") * 1e6);
    offset_ns_ = static_cast<int64_t>(p.get_double("offset_ms") * 1e6);
    skip_every_ = p.get_int("skip_every");
    rate_hz_ = p.get_double("rate_hz");
    camera_ = static_cast<int>(p.get_int("camera_id"));
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (count_ > 0 && frame_ >= count_) return Status::end_of_stream();
    int64_t k = frame_++;
    if (skip_every_ > 0 && k % skip_every_ == skip_every_ - 1) return {};
    if (rate_hz_ > 0) {
      if (start_ns_ == 0) start_ns_ = steady_now_ns();
      if (!ctx.sleep_until(start_ns_ + static_cast<int64_t>(static_cast<double>(k) * 1e9 / rate_hz_)))
        return Status::end_of_stream();
    }
    auto img = ctx.make(out_);
    img->mat.allocator = ctx.frame_allocator(out_);  // a DDS edge's frame ring: written in place
    img->mat.create(size_, CV_8UC1);
    img->mat.setTo(cv::Scalar(static_cast<double>(k % 256)));
    img->camera_id = camera_;
    img->frame_id = k;
    img->timestamp_ns = offset_ns_ + k * step_ns_;
    img->origin_ns = steady_now_ns();
    ctx.emit(out_, std::move(img));
    return {};
  }

 private:
  OutputHandle<Image> out_;
  int64_t count_ = 0, frame_ = 0, step_ns_ = 0, offset_ns_ = 0, skip_every_ = 0, start_ns_ = 0;
  double rate_hz_ = 0;
  cv::Size size_;
  int camera_ = 0;
};

class Pair final : public Node {
 public:
  static constexpr const char* kName = "pair";
  static Contract contract() {
    return Contract("Joins two inputs; emits a Region whose centre holds the two frame ids and whose label holds both timestamps (ns).")
        .input<Message>("a", "first input")
        .input<Message>("b", "second input")
        .output<Region>("pair", "center = (a.frame_id, b.frame_id), label = \"ts_a,ts_b\"");
  }
  Status open(OpenContext& ctx) override {
    a_ = ctx.input<Message>("a");
    b_ = ctx.input<Message>("b");
    out_ = ctx.output<Region>("pair");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto a = ctx.get(a_);
    auto b = ctx.get(b_);
    auto r = ctx.make(out_);
    r->center = {static_cast<double>(a->frame_id), static_cast<double>(b->frame_id)};
    r->label = std::to_string(a->timestamp_ns) + "," + std::to_string(b->timestamp_ns);
    ctx.emit(out_, std::move(r));
    return {};
  }

 private:
  InputHandle<Message> a_, b_;
  OutputHandle<Region> out_;
};

class Latch final : public Node {
 public:
  static constexpr const char* kName = "latch";
  static Contract contract() {
    return Contract("Runs on 'in' and reports which message it saw on the side input: a probe for feedback edges.")
        .input<Message>("in", "triggers a call")
        .side_input<Message>("side", "newest value seen, never triggers")
        .output<Region>("out", "center = (in.frame_id, side.frame_id or -1 when none yet)")
        .param_double("sleep_ms", 0.0, 0.0, 60'000.0,
                      "sleep this long (ProcessContext::sleep_until) before reading the side input");
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    side_ = ctx.input<Message>("side");
    out_ = ctx.output<Region>("out");
    sleep_ns_ = static_cast<int64_t>(ctx.params().get_double("sleep_ms") * 1e6);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (sleep_ns_ > 0 && !ctx.sleep_until(steady_now_ns() + sleep_ns_)) return Status::end_of_stream();
    auto side = ctx.get(side_);
    auto r = ctx.make(out_);
    r->center = {static_cast<double>(ctx.get(in_)->frame_id), side ? static_cast<double>(side->frame_id) : -1.0};
    ctx.emit(out_, std::move(r));
    return {};
  }

 private:
  InputHandle<Message> in_, side_;
  OutputHandle<Region> out_;
  int64_t sleep_ns_ = 0;
};

class Fail final : public Node {
 public:
  static constexpr const char* kName = "fail";
  static Contract contract() {
    return Contract("Forwards messages but fails (or throws) on chosen frames: exercises error handling.")
        .input<Message>("in", "any message")
        .output<Message>("out", "the same message, unless this frame fails")
        .param_int("fail_at", 3, 0, 1'000'000'000, "first call (0-based) that fails")
        .param_int("fail_every", 0, 0, 1'000'000'000, "then every k-th call fails again (0: only once)")
        .param_bool("throw", false, "throw an exception instead of returning an error");
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    out_ = ctx.output<Message>("out");
    fail_at_ = ctx.params().get_int("fail_at");
    fail_every_ = ctx.params().get_int("fail_every");
    throw_ = ctx.params().get_bool("throw");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    int64_t k = calls_++;
    bool fails = k == fail_at_ || (fail_every_ > 0 && k > fail_at_ && (k - fail_at_) % fail_every_ == 0);
    if (fails) {
      if (throw_) throw std::runtime_error("injected exception at call " + std::to_string(k));
      return Status::error("injected failure at call " + std::to_string(k));
    }
    ctx.emit(out_, ctx.get(in_));
    return {};
  }

 private:
  InputHandle<Message> in_;
  OutputHandle<Message> out_;
  int64_t fail_at_ = 0, fail_every_ = 0, calls_ = 0;
  bool throw_ = false;
};

}  // namespace

SACCADE_PLUGIN("util", Passthrough, Record, Null, Counter, Pair, Latch, Fail)
