// Capture nodes: video file, image sequence, one image repeated, camera, a
// time-matched stereo pair, and a synthetic scene with exact ground truth.
#include <atomic>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "readers.hpp"
#include "sim_head.hpp"
#include "saccade/plugin.hpp"
#include "saccade/stats.hpp"

namespace {

using namespace saccade;
using namespace saccade::capture;

enum class ColorMode { kGray, kColor, kUnchanged };

// How every file and camera node delivers its frames (Delivery).
struct DeliveryConfig {
  bool realtime = true;  // pace at media time, else as fast as consumers allow
  double fps = 0.0;      // 0: the source's own, else 30
  bool loop = false;
  ColorMode color = ColorMode::kGray;
  cv::Size resize{0, 0};  // 0x0: keep
  int camera_id = 0;
};

// The delivery parameters of a node whose Config derives from DeliveryConfig.
template <class Config>
void bind_delivery(ParamBinder<Config>& b) {
  b.field("rate", {{"realtime", true}, {"fast", false}},
          "pace frames at their media time, or as fast as consumers allow", &Config::realtime)
      .field("fps", {0, 10000}, "frame rate for timestamps and pacing (0: the source's own, else 30)", &Config::fps)
      .field("loop", "start again at the end instead of ending the stream", &Config::loop)
      .field("color", {{"gray", ColorMode::kGray}, {"color", ColorMode::kColor}, {"unchanged", ColorMode::kUnchanged}},
             "convert frames to 8-bit gray or BGR, or keep them", &Config::color)
      .field("resize", "resize every frame to WxH (0x0: keep)", &Config::resize)
      .field("camera_id", {0, 255}, "camera id carried by the images", &Config::camera_id);
}

// Turns raw reads into pooled, stamped, paced Image messages.
class Delivery {
 public:
  void configure(const DeliveryConfig& config) { config_ = config; }
  double fps_for(const FrameReader& r) const {
    if (config_.fps > 0) return config_.fps;
    double f = r.fps();
    return f > 0 && f < 1000 ? f : 30.0;
  }

  // Reads the next frame of `reader` into `image`: ok, end_of_stream at the end
  // (unless looping), or the reader's error. With `allocator` (what the
  // consumer sends from, a DDS edge's frame ring:
  // ProcessContext::frame_allocator) the frame is decoded, or converted,
  // straight into a buffer of it.
  Status read(FrameReader& reader, Image& image, cv::MatAllocator* allocator) {
    cv::Mat& target = allocator != nullptr ? image.mat : raw_;
    image.mat.allocator = allocator;
    int64_t media = 0;
    if (Status s = reader.read(target, media); !s.ok()) {
      if (!s.is_end_of_stream() || !config_.loop || !reader.rewind()) return s;
      loop_offset_ns_ = last_media_ns_ + static_cast<int64_t>(1e9 / fps_for(reader));
      if (Status again = reader.read(target, media); !again.ok()) return again;
    }
    media += loop_offset_ns_;
    last_media_ns_ = media;
    if (allocator == nullptr) {
      convert(image.mat);
    } else if (needs_conversion(image.mat)) {
      std::swap(raw_, image.mat);
      image.mat.allocator = allocator;
      convert(image.mat);
      raw_.release();  // a buffer of the consumer's: not kept here
    }
    image.camera_id = config_.camera_id;
    image.timestamp_ns = media;
    image.origin_ns = steady_now_ns();
    return {};
  }

  // Sleeps until the frame's media time (realtime files); false when stopped.
  bool pace(ProcessContext& ctx, const FrameReader& reader, int64_t media_ns) {
    if (!config_.realtime || reader.live()) return true;
    if (first_frame_) {
      first_frame_ = false;
      start_steady_ns_ = steady_now_ns();
      start_media_ns_ = media_ns;
      return true;
    }
    return ctx.sleep_until(start_steady_ns_ + (media_ns - start_media_ns_));
  }

 private:
  bool needs_conversion(const cv::Mat& frame) const {
    return (config_.color == ColorMode::kGray && frame.channels() != 1) ||
           (config_.color == ColorMode::kColor && frame.channels() != 3) ||
           (!config_.resize.empty() && frame.size() != config_.resize);
  }

  // Converts raw_ into `out` without allocating in steady state: when no
  // conversion is needed the buffers swap, so the reader refills the old one
  // (or, for a consumer's allocator, the frame is copied into its buffer).
  void convert(cv::Mat& out) {
    cv::Mat* src = &raw_;
    if (config_.color == ColorMode::kGray && raw_.channels() != 1) {
      cv::cvtColor(raw_, tmp_, raw_.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
      src = &tmp_;
    } else if (config_.color == ColorMode::kColor && raw_.channels() != 3) {
      cv::cvtColor(raw_, tmp_, raw_.channels() == 4 ? cv::COLOR_BGRA2BGR : cv::COLOR_GRAY2BGR);
      src = &tmp_;
    }
    if (!config_.resize.empty() && src->size() != config_.resize) {
      cv::resize(*src, out, config_.resize, 0, 0, cv::INTER_AREA);
      return;
    }
    if (out.allocator != nullptr) {
      src->copyTo(out);
      return;
    }
    std::swap(out, *src);
  }

  DeliveryConfig config_;
  bool first_frame_ = true;
  cv::Mat raw_, tmp_;
  int64_t loop_offset_ns_ = 0, last_media_ns_ = 0, start_steady_ns_ = 0, start_media_ns_ = 0;
};

// A single-output capture node over one reader; Derived declares its port
// kImage, its Config (a DeliveryConfig) with bind, and opens the reader.
template <class Derived>
class SingleCapture : public Node {
 public:
  Status open(OpenContext& ctx) override {
    const typename Derived::Config config = ctx.config(&Derived::bind);
    delivery_.configure(config);
    auto reader = static_cast<Derived*>(this)->open_reader(config, ctx.params());
    if (!reader.ok()) return reader.status();
    reader_ = std::move(reader).value();
    // How many frames the stream will have, for a progress line's ETA (saccade run).
    if (!config.loop && reader_->length() > 0)
      ctx.counter("frames_total").store(static_cast<uint64_t>(reader_->length()));
    frames_unread_ = &ctx.counter("frames_unread");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.make(Derived::kImage);
    const Status read = delivery_.read(*reader_, *image, ctx.frame_allocator(Derived::kImage));
    frames_unread_->store(static_cast<uint64_t>(reader_->frames_unread()), std::memory_order_relaxed);
    if (!read.ok()) return read;
    image->frame_id = frame_++;
    if (!delivery_.pace(ctx, *reader_, image->timestamp_ns)) return Status::end_of_stream();
    image->origin_ns = steady_now_ns();  // released now: latency starts here, not before the pacing sleep
    ctx.emit(Derived::kImage, std::move(image));
    return {};
  }

 private:
  Delivery delivery_;
  std::unique_ptr<FrameReader> reader_;
  std::atomic<uint64_t>* frames_unread_ = nullptr;  // the reader's frames_unread(), in the node's stats
  int64_t frame_ = 0;
};

class Video final : public SingleCapture<Video> {
 public:
  static constexpr const char* kName = "video";
  static constexpr Out<Image> kImage{"image", "one frame"};
  using Config = DeliveryConfig;
  static void bind(ParamBinder<Config>& b) { bind_delivery(b); }
  static Contract contract() {
    return Contract(
               "Frames of a video file (any format OpenCV's FFmpeg backend reads). A video that ends before the "
               "frame count its header announces by more than a header's usual error (2 frames or 1%; cut short, "
               "or not decodable past a frame) ends there with a warning naming the file and both counts; the "
               "frames it could not give are the counter frames_unread in the node's stats.")
        .ports(kImage)
        .required_string("path", "video file")
        .params(&bind);
  }
  Result<std::unique_ptr<FrameReader>> open_reader(const Config&, const Params& p) {
    return open_video(p.get_string("path"));
  }
};

class Images final : public SingleCapture<Images> {
 public:
  static constexpr const char* kName = "images";
  static constexpr Out<Image> kImage{"image", "one image of the sequence"};
  struct Config : DeliveryConfig {
    int first = 1;
  };
  static void bind(ParamBinder<Config>& b) {
    b.field("first", {0, 1'000'000'000}, "number of the first image", &Config::first);
    bind_delivery(b);
  }
  static Contract contract() {
    return Contract(
               "An image sequence named by a printf pattern, read until the first missing number. Images numbered "
               "after a missing one are said in a warning naming the missing file, and counted in the node's "
               "frames_unread.")
        .ports(kImage)
        .required_string("pattern", "file pattern, e.g. ${SACCADE_SAMPLE_DATA}/left%02d.jpg")
        .params(&bind);
  }
  Result<std::unique_ptr<FrameReader>> open_reader(const Config& c, const Params& p) {
    return open_sequence(p.get_string("pattern"), c.first, c.fps);
  }
};

class OneImage final : public SingleCapture<OneImage> {
 public:
  static constexpr const char* kName = "image";
  static constexpr Out<Image> kImage{"image", "the image"};
  struct Config : DeliveryConfig {
    int64_t count = 1;  // 0: until stopped
  };
  static void bind(ParamBinder<Config>& b) {
    b.field("count", {0, 1'000'000'000}, "times to emit it (0: until stopped)", &Config::count);
    bind_delivery(b);
  }
  static Contract contract() {
    return Contract("One image, decoded once and emitted repeatedly without copying (a memory source).")
        .ports(kImage)
        .required_string("path", "image file")
        .params(&bind);
  }
  Result<std::unique_ptr<FrameReader>> open_reader(const Config& c, const Params& p) {
    return open_image(p.get_string("path"), c.count, c.fps);
  }
};

class Camera final : public SingleCapture<Camera> {
 public:
  static constexpr const char* kName = "camera";
  static constexpr Out<Image> kImage{"image", "one frame, stamped with its capture time"};
  struct Config : DeliveryConfig {
    std::string device = "0";
    cv::Size size{0, 0};  // 0x0: the camera's default
  };
  static void bind(ParamBinder<Config>& b) {
    b.field("device", "camera index or device path", &Config::device)
        .field("size", "requested frame size (0x0: the camera's default)", &Config::size);
    bind_delivery(b);
  }
  static Contract contract() {
    return Contract("A V4L2 camera through OpenCV, by index (0) or device path (/dev/video0).")
        .ports(kImage)
        .params(&bind);
  }
  Result<std::unique_ptr<FrameReader>> open_reader(const Config& c, const Params&) {
    return open_camera(c.device, c.size, c.fps);
  }
};

class Stereo final : public Node {
 public:
  static constexpr const char* kName = "stereo";
  static constexpr Out<Image> kLeft{"left", "left image (camera 0)"};
  static constexpr Out<Image> kRight{"right", "right image (camera 1)"};
  struct Config : DeliveryConfig {
    int64_t count = 0;  // still images: pairs to emit (0: one)
  };
  static void bind(ParamBinder<Config>& b) {
    b.field("count", {0, 1'000'000'000}, "pairs to emit for still images (0: one pair for images, all for videos)",
            &Config::count);
    bind_delivery(b);
  }
  static Contract contract() {
    return Contract(
               "Two sources read in lockstep as a stereo pair: both images of a pair carry the same timestamp "
               "and frame id. Frames a source announces and cannot give (a video cut short, as capture.video; "
               "images after a gap in a sequence, as capture.images) are said and counted, both sides' together, "
               "in frames_unread.")
        .ports(kLeft, kRight)
        .required_string("left_path", "left video, image, pattern (%d) or camera")
        .required_string("right_path", "right video, image, pattern (%d) or camera")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    const Config c = ctx.config(&bind);
    left_.configure(c);
    right_.configure(c);
    auto make = [&](const std::string& path) {
      if (classify_source(path) == SourceKind::kImage) return open_image(path, c.count > 0 ? c.count : 1, c.fps);
      return open_any(path, c.fps);
    };
    auto left = make(ctx.params().get_string("left_path"));
    if (!left.ok()) return left.status();
    auto right = make(ctx.params().get_string("right_path"));
    if (!right.ok()) return right.status();
    left_reader_ = std::move(left).value();
    right_reader_ = std::move(right).value();
    frames_unread_ = &ctx.counter("frames_unread");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.make(kLeft);
    auto r = ctx.make(kRight);
    const Status read = left_.read(*left_reader_, *l, ctx.frame_allocator(kLeft));
    const Status read_right = read.ok() ? right_.read(*right_reader_, *r, ctx.frame_allocator(kRight)) : Status();
    // Both sides' announced frames that could not be read.
    frames_unread_->store(static_cast<uint64_t>(left_reader_->frames_unread() + right_reader_->frames_unread()),
                          std::memory_order_relaxed);
    if (!read.ok()) return read;
    if (!read_right.ok()) return read_right;
    l->camera_id = 0;
    r->camera_id = 1;
    l->frame_id = r->frame_id = frame_++;
    r->timestamp_ns = l->timestamp_ns;  // one pair, one instant
    if (!left_.pace(ctx, *left_reader_, l->timestamp_ns)) return Status::end_of_stream();
    l->origin_ns = r->origin_ns = steady_now_ns();
    ctx.emit(kLeft, std::move(l));
    ctx.emit(kRight, std::move(r));
    return {};
  }

 private:
  Delivery left_, right_;
  std::unique_ptr<FrameReader> left_reader_, right_reader_;
  std::atomic<uint64_t>* frames_unread_ = nullptr;
  int64_t frame_ = 0;
};

// The synthetic node's parameters: the scene, and the frames it is seen in.
struct SyntheticConfig {
  SyntheticScene scene;  // its background comes from the file below
  std::string background = "${SACCADE_SAMPLE_DATA}/vtest.avi";
  cv::Size size{640, 480};
  int64_t count = 300;  // 0: endless
  bool realtime = false;
  double fps = 30.0;
  bool gray = true;
};

class Synthetic final : public Node {
 public:
  static constexpr const char* kName = "synthetic";
  static constexpr Out<Image> kImage{"image", "left view"};
  static constexpr Out<Image> kRight{
      "right", "right view: target shifted left by 'disparity', background by 'background_disparity'"};
  static constexpr Out<Region> kTruth{"truth",
                                      "the target's exact centre and size in the left view (the centre may be "
                                      "outside the frame); score = its disparity; label: visible, partial or "
                                      "outside"};

  static void bind(ParamBinder<SyntheticConfig>& b) {
    using C = SyntheticConfig;
    using S = SyntheticScene;
    b.field("background", "image or video whose first frame is the background", &C::background)
        .field("size", "frame size (the background is resized to it)", &C::size)
        .field("target_size", {4, 1024}, "side of the square target, pixels", &C::scene, &S::target_size)
        .field("path", {{"circle", "circle"}, {"line", "line"}, {"still", "still"}, {"bounce", "bounce"}},
               "how the target moves", &C::scene, &S::path)
        .field("radius", {0, 10000}, "circle radius or half the line's length, pixels", &C::scene, &S::radius)
        .field("period", {1, 1e9}, "frames per revolution or back-and-forth", &C::scene, &S::period_frames)
        .field("speed", {0, 10000}, "bounce: pixels per frame", &C::scene, &S::speed)
        .field("angle", {-360, 360}, "bounce: direction of the first run, degrees (y down)", &C::scene, &S::angle_deg)
        .field("overshoot", {0, 10000}, "bounce: how far beyond the frame's edges the target goes, pixels", &C::scene,
               &S::overshoot)
        .field("jump_every", {0, 1'000'000'000}, "bounce: jump to a new place every N frames (0: never)", &C::scene,
               &S::jump_every)
        .field("disparity", {-1024, 1024}, "target disparity in the right view, pixels", &C::scene, &S::disparity)
        .field("background_disparity", {-1024, 1024}, "background disparity in the right view, pixels", &C::scene,
               &S::background_disparity)
        .field("count", {0, 1'000'000'000}, "frames before end of stream (0: endless)", &C::count)
        .field("seed", {0, 1'000'000'000}, "texture seed", &C::scene, &S::seed)
        .field("rate", {{"realtime", true}, {"fast", false}}, "pace at fps, or as fast as consumers allow",
               &C::realtime)
        .field("fps", {0.1, 10000}, "frame rate of the timestamps", &C::fps)
        .field("color", {{"gray", true}, {"color", false}}, "emit gray or BGR images", &C::gray);
  }

  static Contract contract() {
    return Contract(
               "A textured square moving on a known path over a real background frame, with exact ground truth "
               "(synthetic data); optionally a right view with known disparities.")
        .ports(kImage, kRight, kTruth)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    SyntheticConfig c = ctx.config(&bind);
    right_wanted_ = ctx.connected(kRight);
    auto reader = open_any(c.background, 0);
    if (!reader.ok()) return Status::error("background: " + reader.error());
    cv::Mat bg;
    int64_t t = 0;
    if (Status s = (*reader)->read(bg, t); !s.ok())
      return Status::error("background: cannot read a frame " + s.message());
    if (bg.channels() == 1) cv::cvtColor(bg, bg, cv::COLOR_GRAY2BGR);
    if (!c.size.empty()) cv::resize(bg, bg, c.size, 0, 0, cv::INTER_AREA);
    if (c.scene.target_size > std::min(bg.cols, bg.rows)) return Status::error("target_size is larger than the frame");
    c.scene.background = bg;
    renderer_ = std::make_unique<SyntheticRenderer>(c.scene);
    count_ = c.count;
    realtime_ = c.realtime;
    fps_ = c.fps;
    gray_ = c.gray;
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (count_ > 0 && frame_ >= count_) return Status::end_of_stream();
    int64_t k = frame_++;
    int64_t ts = static_cast<int64_t>(static_cast<double>(k) * 1e9 / fps_);
    if (realtime_) {
      if (k == 0) start_ns_ = steady_now_ns();
      if (!ctx.sleep_until(start_ns_ + ts)) return Status::end_of_stream();
    }
    if (!right_wanted_)
      right_bgr_.release();
    else if (right_bgr_.empty())
      right_bgr_.create(renderer_->scene().background.size(), CV_8UC3);
    renderer_->render(k, left_bgr_, right_bgr_);
    int64_t origin = steady_now_ns();
    auto stamp = [&](Message& m) {
      m.frame_id = k;
      m.timestamp_ns = ts;
      m.origin_ns = origin;
    };
    auto left = ctx.make(kImage);
    to_output(left_bgr_, left->mat);
    left->camera_id = 0;
    stamp(*left);
    auto truth = ctx.make(kTruth);
    truth->center = renderer_->target_center(k);
    truth->size = cv::Size2d(renderer_->scene().target_size, renderer_->scene().target_size);
    truth->score = renderer_->scene().disparity;
    const double visible = renderer_->target_visible(k);
    truth->label = visible >= 1.0 ? "visible" : visible > 0.0 ? "partial" : "outside";
    stamp(*truth);
    ctx.emit(kImage, std::move(left));
    if (right_wanted_) {
      auto right = ctx.make(kRight);
      to_output(right_bgr_, right->mat);
      right->camera_id = 1;
      stamp(*right);
      ctx.emit(kRight, std::move(right));
    }
    ctx.emit(kTruth, std::move(truth));
    return {};
  }

 private:
  void to_output(const cv::Mat& bgr, cv::Mat& out) const {
    if (gray_)
      cv::cvtColor(bgr, out, cv::COLOR_BGR2GRAY);
    else
      bgr.copyTo(out);
  }
  std::unique_ptr<SyntheticRenderer> renderer_;
  cv::Mat left_bgr_, right_bgr_;
  int64_t count_ = 0, frame_ = 0, start_ns_ = 0;
  double fps_ = 30;
  bool realtime_ = false, gray_ = true, right_wanted_ = false;
};

// The sim_head node's parameters: the head's cameras and scene, and what they are read from.
struct SimHeadParams {
  std::string scene = "${SACCADE_SAMPLE_DATA}/aloeL.jpg";
  capture::SimHeadConfig head;  // its focal_px comes from hfov_deg
  double hfov_deg = 60.0;
  double fps = 25.0;
  double stop_at = -1.0, stop_for = 0.0;  // fault injection: s of the joints' time; -1: never
};

class SimHeadNode final : public Node {
 public:
  static constexpr const char* kName = "sim_head";
  static constexpr In<JointState> kState{
      "state", "the joints (the drives' encoder feedback); a frame is rendered every 1/fps of its time"};
  static constexpr Out<Image> kLeft{"left", "left camera (camera_id 0), BGR"};
  static constexpr Out<Image> kRight{"right", "right camera (camera_id 1), BGR"};
  static constexpr Out<Region> kTruth{"truth",
                                      "the target in the left image: centre, size, depth; label visible or outside"};
  static constexpr Out<Region> kTruthRight{"truth_right", "the target in the right image"};
  static constexpr Out<JointState> kJoints{
      "joints", "the joint state each pair was rendered at (stamped as the frames): for rectified retinas"};

  static void bind(ParamBinder<SimHeadParams>& b) {
    using P = SimHeadParams;
    using H = capture::SimHeadConfig;
    using G = kinematics::HeadGeometry;
    b.field("scene", "image on the wall", &P::scene)
        .field("size", "camera image size", &P::head, &H::size)
        .field("hfov", {1, 170}, "horizontal field of view, degrees", &P::hfov_deg)
        .field("fps", {0.1, 1000}, "frames per second of the joint state's time", &P::fps)
        .field("wall_distance", {0.2, 1000}, "m from the neck axis to the wall", &P::head, &H::wall_distance)
        .field("wall_width", {0.01, 1000}, "m the scene image spans", &P::head, &H::wall_width)
        .field("l1", {0, 10}, "m: the head's L1 (as the head node's)", &P::head, &H::geometry, &G::l1)
        .field("l2", {0, 10}, "m: the head's L2", &P::head, &H::geometry, &G::l2)
        .field("l3", {0, 10}, "m: the head's L3", &P::head, &H::geometry, &G::l3)
        .field("target", "draw the moving target", &P::head, &H::target)
        .field("target_radius", {0.001, 10}, "m", &P::head, &H::target_radius)
        .field("target_distance", {0.2, 1000}, "m: the target moves in the plane this far ahead", &P::head,
               &H::target_distance)
        .field("target_speed", {0, 100}, "m/s sideways, back and forth", &P::head, &H::target_speed)
        .field("target_range", {0, 1000}, "m: it turns at +-range", &P::head, &H::target_range)
        .field("target_start", {-1000, 1000}, "m: sideways position at time 0", &P::head, &H::target_start)
        .field("target_height", {-1000, 1000}, "m above the cameras", &P::head, &H::target_height)
        .field("stop_at", {-1, 1e9},
               "fault injection: the cameras stop at this time of the joints' clock, s (-1: "
               "never); the frames they miss are counted in stopped_frames",
               &P::stop_at)
        .field("stop_for", {0, 1e9}, "fault injection: and come back after this many seconds (0: never)", &P::stop_for);
  }

  static Contract contract() {
    return Contract(
               "The simulated stereo head's cameras: a wide scene on a wall in front of the head and a textured "
               "target moving between head and wall, rendered into both cameras for the joint angles the drives "
               "report, so the active vision loop runs on one machine.")
        .ports(kState, kLeft, kRight, kTruth, kTruthRight, kJoints)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    SimHeadParams p = ctx.config(&bind);
    cv::Mat scene = cv::imread(p.scene, cv::IMREAD_COLOR);
    if (scene.empty()) return Status::error("scene: cannot read image '" + p.scene + "'");
    capture::SimHeadConfig& c = p.head;
    if (c.size.width < 8 || c.size.height < 8) return Status::error("size must be at least 8x8");
    c.focal_px = (c.size.width / 2.0) / std::tan(p.hfov_deg * M_PI / 360.0);
    if (c.target_distance >= c.wall_distance) return Status::error("target_distance must be less than wall_distance");
    head_ = std::make_unique<capture::SimHead>(std::move(scene), c);
    period_ns_ = static_cast<int64_t>(1e9 / p.fps);
    stop_ = {p.stop_at, p.stop_for};
    stopped_frames_ = &ctx.counter("stopped_frames");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto state = ctx.get(kState);
    if (state->position.size() != 5)
      return Status::error("joint state for " + std::to_string(state->position.size()) + " joints, expected 5");
    // The joints' clock went back: the drives' side restarted (its clock starts
    // at 0 again). Render from the new clock at once instead of waiting as long
    // as the old one had run (issue 25).
    if (state->timestamp_ns < last_state_ns_) next_ns_ = state->timestamp_ns;
    last_state_ns_ = state->timestamp_ns;
    if (state->timestamp_ns < next_ns_) return {};
    next_ns_ += period_ns_;
    if (next_ns_ <= state->timestamp_ns) next_ns_ = state->timestamp_ns + period_ns_;  // joint states came late
    const kinematics::HeadJoints q{state->position[0], state->position[1], state->position[2], state->position[3],
                                   state->position[4]};
    const double t = static_cast<double>(state->timestamp_ns) * 1e-9;
    if (stop_.covers(t)) {
      bump(*stopped_frames_);
      return {};
    }
    // The joints first: a retina that rectifies with them takes the newest
    // when its frame arrives.
    auto joints = ctx.make(kJoints);
    *joints = *state;
    joints->frame_id = frame_;
    ctx.emit(kJoints, std::move(joints));
    const Out<Image>* outs[2] = {&kLeft, &kRight};
    const Out<Region>* truths[2] = {&kTruth, &kTruthRight};
    for (int camera = 0; camera < 2; ++camera) {
      auto image = ctx.make(*outs[camera]);
      const capture::TargetView view = head_->render(camera, q, t, image->mat);
      image->camera_id = camera;
      image->timestamp_ns = state->timestamp_ns;
      image->origin_ns = steady_now_ns();
      image->frame_id = frame_;
      auto truth = ctx.make(*truths[camera]);
      truth->stamp_from(*image);
      truth->center = view.center;
      truth->size = cv::Size2d(2 * view.radius, 2 * view.radius);
      truth->depth = view.depth;
      truth->camera_id = camera;
      truth->label = view.visible ? "visible" : "outside";
      ctx.emit(*outs[camera], std::move(image));
      ctx.emit(*truths[camera], std::move(truth));
    }
    ++frame_;
    return {};
  }

 private:
  std::unique_ptr<capture::SimHead> head_;
  int64_t period_ns_ = 40'000'000, next_ns_ = 0, frame_ = 0;
  int64_t last_state_ns_ = 0;
  capture::CameraOutage stop_;
  std::atomic<uint64_t>* stopped_frames_ = nullptr;
};

}  // namespace

SACCADE_PLUGIN("capture", Video, Images, OneImage, Camera, Stereo, Synthetic, SimHeadNode)
