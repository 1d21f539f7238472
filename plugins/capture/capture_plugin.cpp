// Capture nodes: video file, image sequence, one image repeated, camera, a
// time-matched stereo pair, and a synthetic scene with exact ground truth.
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "readers.hpp"
#include "sim_head.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::capture;

Contract& common_params(Contract& c) {
  return c.param_enum("rate", "realtime", {"realtime", "fast"}, "pace frames at their media time, or as fast as consumers allow")
      .param_double("fps", 0.0, 0.0, 10000.0, "frame rate for timestamps and pacing (0: the source's own, else 30)")
      .param_bool("loop", false, "start again at the end instead of ending the stream")
      .param_enum("color", "gray", {"gray", "color", "unchanged"}, "convert frames to 8-bit gray or BGR, or keep them")
      .param_size("resize", {0, 0}, "resize every frame to WxH (0x0: keep)")
      .param_int("camera_id", 0, 0, 255, "camera id carried by the images");
}

// Turns raw reads into pooled, stamped, paced Image messages.
class Delivery {
 public:
  void configure(const Params& p) {
    realtime_ = p.get_string("rate") == "realtime";
    fps_ = p.get_double("fps");
    loop_ = p.get_bool("loop");
    color_ = p.get_string("color");
    resize_ = p.get_size("resize");
    camera_ = static_cast<int>(p.get_int("camera_id"));
  }
  double fps_for(const FrameReader& r) const {
    if (fps_ > 0) return fps_;
    double f = r.fps();
    return f > 0 && f < 1000 ? f : 30.0;
  }

  // Reads the next frame of `reader` into `image`; false at end (error set on
  // failure). With `allocator` (what the consumer sends from, a DDS edge's
  // frame ring: ProcessContext::frame_allocator) the frame is decoded, or
  // converted, straight into a buffer of it.
  bool read(FrameReader& reader, Image& image, cv::MatAllocator* allocator, std::string* error) {
    cv::Mat& target = allocator != nullptr ? image.mat : raw_;
    image.mat.allocator = allocator;
    int64_t media = 0;
    error->clear();
    if (!reader.read(target, media, error)) {
      if (!error->empty() || !loop_ || !reader.rewind()) return false;
      loop_offset_ns_ = last_media_ns_ + static_cast<int64_t>(1e9 / fps_for(reader));
      if (!reader.read(target, media, error)) return false;
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
    image.camera_id = camera_;
    image.timestamp_ns = media;
    image.origin_ns = steady_now_ns();
    return true;
  }

  // Sleeps until the frame's media time (realtime files); false when stopped.
  bool pace(ProcessContext& ctx, const FrameReader& reader, int64_t media_ns) {
    if (!realtime_ || reader.live()) return true;
    if (first_frame_) {
      first_frame_ = false;
      start_steady_ns_ = steady_now_ns();
      start_media_ns_ = media_ns;
      return true;
    }
    return ctx.sleep_until(start_steady_ns_ + (media_ns - start_media_ns_));
  }

  int camera_id() const { return camera_; }

 private:
  bool needs_conversion(const cv::Mat& frame) const {
    return (color_ == "gray" && frame.channels() != 1) || (color_ == "color" && frame.channels() != 3) ||
           (resize_.area() > 0 && frame.size() != resize_);
  }

  // Converts raw_ into `out` without allocating in steady state: when no
  // conversion is needed the buffers swap, so the reader refills the old one
  // (or, for a consumer's allocator, the frame is copied into its buffer).
  void convert(cv::Mat& out) {
    cv::Mat* src = &raw_;
    if (color_ == "gray" && raw_.channels() != 1) {
      cv::cvtColor(raw_, tmp_, raw_.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
      src = &tmp_;
    } else if (color_ == "color" && raw_.channels() != 3) {
      cv::cvtColor(raw_, tmp_, raw_.channels() == 4 ? cv::COLOR_BGRA2BGR : cv::COLOR_GRAY2BGR);
      src = &tmp_;
    }
    if (resize_.area() > 0 && src->size() != resize_) {
      cv::resize(*src, out, resize_, 0, 0, cv::INTER_AREA);
      return;
    }
    if (out.allocator != nullptr) {
      src->copyTo(out);
      return;
    }
    std::swap(out, *src);
  }

  bool realtime_ = true, loop_ = false, first_frame_ = true;
  double fps_ = 0;
  std::string color_;
  cv::Size resize_;
  int camera_ = 0;
  cv::Mat raw_, tmp_;
  int64_t loop_offset_ns_ = 0, last_media_ns_ = 0, start_steady_ns_ = 0, start_media_ns_ = 0;
};

// A single-output capture node over one reader; Derived opens the reader.
template <class Derived>
class SingleCapture : public Node {
 public:
  Status open(OpenContext& ctx) override {
    out_ = ctx.output<Image>("image");
    delivery_.configure(ctx.params());
    std::string error;
    reader_ = static_cast<Derived*>(this)->open_reader(ctx.params(), &error);
    if (!reader_) return Status::error(error);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto image = ctx.make(out_);
    if (!delivery_.read(*reader_, *image, ctx.frame_allocator(out_), &error_))
      return error_.empty() ? Status::end_of_stream() : Status::error(error_);
    image->frame_id = frame_++;
    if (!delivery_.pace(ctx, *reader_, image->timestamp_ns)) return Status::end_of_stream();
    image->origin_ns = steady_now_ns();  // released now: latency starts here, not before the pacing sleep
    ctx.emit(out_, std::move(image));
    return {};
  }

 protected:
  Delivery delivery_;

 private:
  OutputHandle<Image> out_;
  std::unique_ptr<FrameReader> reader_;
  std::string error_;
  int64_t frame_ = 0;
};

class Video final : public SingleCapture<Video> {
 public:
  static constexpr const char* kName = "video";
  static Contract contract() {
    Contract c("Frames of a video file (any format OpenCV's FFmpeg backend reads).");
    c.output<Image>("image", "one frame").required_string("path", "video file");
    return common_params(c);
  }
  std::unique_ptr<FrameReader> open_reader(const Params& p, std::string* error) {
    return open_video(p.get_string("path"), error);
  }
};

class Images final : public SingleCapture<Images> {
 public:
  static constexpr const char* kName = "images";
  static Contract contract() {
    Contract c("An image sequence named by a printf pattern, read until the first missing number.");
    c.output<Image>("image", "one image of the sequence")
        .required_string("pattern", "file pattern, e.g. ${SACCADE_SAMPLE_DATA}/left%02d.jpg")
        .param_int("first", 1, 0, 1'000'000'000, "number of the first image");
    return common_params(c);
  }
  std::unique_ptr<FrameReader> open_reader(const Params& p, std::string* error) {
    return open_sequence(p.get_string("pattern"), static_cast<int>(p.get_int("first")), p.get_double("fps"), error);
  }
};

class OneImage final : public SingleCapture<OneImage> {
 public:
  static constexpr const char* kName = "image";
  static Contract contract() {
    Contract c("One image, decoded once and emitted repeatedly without copying (a memory source).");
    c.output<Image>("image", "the image")
        .required_string("path", "image file")
        .param_int("count", 1, 0, 1'000'000'000, "times to emit it (0: until stopped)");
    return common_params(c);
  }
  std::unique_ptr<FrameReader> open_reader(const Params& p, std::string* error) {
    return open_image(p.get_string("path"), p.get_int("count"), p.get_double("fps"), error);
  }
};

class Camera final : public SingleCapture<Camera> {
 public:
  static constexpr const char* kName = "camera";
  static Contract contract() {
    Contract c("A V4L2 camera through OpenCV, by index (0) or device path (/dev/video0).");
    c.output<Image>("image", "one frame, stamped with its capture time")
        .param_string("device", "0", "camera index or device path")
        .param_size("size", {0, 0}, "requested frame size (0x0: the camera's default)");
    return common_params(c);
  }
  std::unique_ptr<FrameReader> open_reader(const Params& p, std::string* error) {
    return open_camera(p.get_string("device"), p.get_size("size"), p.get_double("fps"), error);
  }
};

class Stereo final : public Node {
 public:
  static constexpr const char* kName = "stereo";
  static Contract contract() {
    Contract c("Two sources read in lockstep as a stereo pair: both images of a pair carry the same timestamp and frame id.");
    c.output<Image>("left", "left image (camera 0)")
        .output<Image>("right", "right image (camera 1)")
        .required_string("left_path", "left video, image, pattern (%d) or camera")
        .required_string("right_path", "right video, image, pattern (%d) or camera")
        .param_int("count", 0, 0, 1'000'000'000, "pairs to emit for still images (0: one pair for images, all for videos)");
    return common_params(c);
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    left_out_ = ctx.output<Image>("left");
    right_out_ = ctx.output<Image>("right");
    left_.configure(p);
    right_.configure(p);
    std::string error;
    int64_t count = p.get_int("count");
    auto make = [&](const std::string& path) -> std::unique_ptr<FrameReader> {
      if (classify_source(path) == SourceKind::kImage) return open_image(path, count > 0 ? count : 1, p.get_double("fps"), &error);
      return open_any(path, p.get_double("fps"), &error);
    };
    left_reader_ = make(p.get_string("left_path"));
    if (!left_reader_) return Status::error(error);
    right_reader_ = make(p.get_string("right_path"));
    if (!right_reader_) return Status::error(error);
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto l = ctx.make(left_out_);
    auto r = ctx.make(right_out_);
    if (!left_.read(*left_reader_, *l, ctx.frame_allocator(left_out_), &error_) ||
        !right_.read(*right_reader_, *r, ctx.frame_allocator(right_out_), &error_))
      return error_.empty() ? Status::end_of_stream() : Status::error(error_);
    l->camera_id = 0;
    r->camera_id = 1;
    l->frame_id = r->frame_id = frame_++;
    r->timestamp_ns = l->timestamp_ns;  // one pair, one instant
    if (!left_.pace(ctx, *left_reader_, l->timestamp_ns)) return Status::end_of_stream();
    l->origin_ns = r->origin_ns = steady_now_ns();
    ctx.emit(left_out_, std::move(l));
    ctx.emit(right_out_, std::move(r));
    return {};
  }

 private:
  OutputHandle<Image> left_out_, right_out_;
  Delivery left_, right_;
  std::unique_ptr<FrameReader> left_reader_, right_reader_;
  std::string error_;
  int64_t frame_ = 0;
};

class Synthetic final : public Node {
 public:
  static constexpr const char* kName = "synthetic";
  static Contract contract() {
    Contract c("A textured square moving on a known path over a real background frame, with exact ground truth "
               "(synthetic data); optionally a right view with known disparities.");
    c.output<Image>("image", "left view")
        .output<Image>("right", "right view: target shifted left by 'disparity', background by 'background_disparity'")
        .output<Region>("truth", "the target's exact centre and size in the left view (the centre may be outside the "
                                 "frame); score = its disparity; label: visible, partial or outside")
        .param_string("background", "${SACCADE_SAMPLE_DATA}/vtest.avi", "image or video whose first frame is the background")
        .param_size("size", {640, 480}, "frame size (the background is resized to it)")
        .param_int("target_size", 48, 4, 1024, "side of the square target, pixels")
        .param_enum("path", "circle", {"circle", "line", "still", "bounce"}, "how the target moves")
        .param_double("radius", 120.0, 0.0, 10000.0, "circle radius or half the line's length, pixels")
        .param_double("period", 120.0, 1.0, 1e9, "frames per revolution or back-and-forth")
        .param_double("speed", 4.0, 0.0, 10000.0, "bounce: pixels per frame")
        .param_double("angle", 30.0, -360.0, 360.0, "bounce: direction of the first run, degrees (y down)")
        .param_double("overshoot", 0.0, 0.0, 10000.0, "bounce: how far beyond the frame's edges the target goes, pixels")
        .param_int("jump_every", 0, 0, 1'000'000'000, "bounce: jump to a new place every N frames (0: never)")
        .param_int("disparity", 0, -1024, 1024, "target disparity in the right view, pixels")
        .param_int("background_disparity", 0, -1024, 1024, "background disparity in the right view, pixels")
        .param_int("count", 300, 0, 1'000'000'000, "frames before end of stream (0: endless)")
        .param_int("seed", 1, 0, 1'000'000'000, "texture seed")
        .param_enum("rate", "fast", {"realtime", "fast"}, "pace at fps, or as fast as consumers allow")
        .param_double("fps", 30.0, 0.1, 10000.0, "frame rate of the timestamps")
        .param_enum("color", "gray", {"gray", "color"}, "emit gray or BGR images");
    return c;
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    image_out_ = ctx.output<Image>("image");
    right_out_ = ctx.output<Image>("right");
    truth_out_ = ctx.output<Region>("truth");
    right_wanted_ = ctx.connected(right_out_);
    std::string error;
    auto reader = open_any(p.get_string("background"), 0, &error);
    if (!reader) return Status::error("background: " + error);
    cv::Mat bg;
    int64_t t = 0;
    if (!reader->read(bg, t, &error)) return Status::error("background: cannot read a frame " + error);
    if (bg.channels() == 1) cv::cvtColor(bg, bg, cv::COLOR_GRAY2BGR);
    cv::Size size = p.get_size("size");
    if (size.area() > 0) cv::resize(bg, bg, size, 0, 0, cv::INTER_AREA);
    SyntheticScene scene;
    scene.background = bg;
    scene.target_size = static_cast<int>(p.get_int("target_size"));
    if (scene.target_size > std::min(bg.cols, bg.rows)) return Status::error("target_size is larger than the frame");
    scene.path = p.get_string("path");
    scene.radius = p.get_double("radius");
    scene.period_frames = p.get_double("period");
    scene.speed = p.get_double("speed");
    scene.angle_deg = p.get_double("angle");
    scene.overshoot = p.get_double("overshoot");
    scene.jump_every = static_cast<int>(p.get_int("jump_every"));
    scene.disparity = static_cast<int>(p.get_int("disparity"));
    scene.background_disparity = static_cast<int>(p.get_int("background_disparity"));
    scene.seed = static_cast<uint64_t>(p.get_int("seed"));
    renderer_ = std::make_unique<SyntheticRenderer>(scene);
    count_ = p.get_int("count");
    realtime_ = p.get_string("rate") == "realtime";
    fps_ = p.get_double("fps");
    gray_ = p.get_string("color") == "gray";
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
    if (!right_wanted_) right_bgr_.release();
    else if (right_bgr_.empty()) right_bgr_.create(renderer_->scene().background.size(), CV_8UC3);
    renderer_->render(k, left_bgr_, right_bgr_);
    int64_t origin = steady_now_ns();
    auto stamp = [&](Message& m) {
      m.frame_id = k;
      m.timestamp_ns = ts;
      m.origin_ns = origin;
    };
    auto left = ctx.make(image_out_);
    to_output(left_bgr_, left->mat);
    left->camera_id = 0;
    stamp(*left);
    auto truth = ctx.make(truth_out_);
    truth->center = renderer_->target_center(k);
    truth->size = cv::Size2d(renderer_->scene().target_size, renderer_->scene().target_size);
    truth->score = renderer_->scene().disparity;
    const double visible = renderer_->target_visible(k);
    truth->label = visible >= 1.0 ? "visible" : visible > 0.0 ? "partial" : "outside";
    stamp(*truth);
    ctx.emit(image_out_, std::move(left));
    if (right_wanted_) {
      auto right = ctx.make(right_out_);
      to_output(right_bgr_, right->mat);
      right->camera_id = 1;
      stamp(*right);
      ctx.emit(right_out_, std::move(right));
    }
    ctx.emit(truth_out_, std::move(truth));
    return {};
  }

 private:
  void to_output(const cv::Mat& bgr, cv::Mat& out) const {
    if (gray_) cv::cvtColor(bgr, out, cv::COLOR_BGR2GRAY);
    else bgr.copyTo(out);
  }
  OutputHandle<Image> image_out_, right_out_;
  OutputHandle<Region> truth_out_;
  std::unique_ptr<SyntheticRenderer> renderer_;
  cv::Mat left_bgr_, right_bgr_;
  int64_t count_ = 0, frame_ = 0, start_ns_ = 0;
  double fps_ = 30;
  bool realtime_ = false, gray_ = true, right_wanted_ = false;
};

class SimHeadNode final : public Node {
 public:
  static constexpr const char* kName = "sim_head";
  static Contract contract() {
    return Contract("The simulated stereo head's cameras: a wide scene on a wall in front of the head and a textured "
                    "target moving between head and wall, rendered into both cameras for the joint angles the drives "
                    "report, so the active vision loop runs on one machine.")
        .input<JointState>("state", "the joints (the drives' encoder feedback); a frame is rendered every 1/fps of its time")
        .output<Image>("left", "left camera (camera_id 0), BGR")
        .output<Image>("right", "right camera (camera_id 1), BGR")
        .output<Region>("truth", "the target in the left image: centre, size, depth; label visible or outside")
        .output<Region>("truth_right", "the target in the right image")
        .param_string("scene", "${SACCADE_SAMPLE_DATA}/aloeL.jpg", "image on the wall")
        .param_size("size", {320, 240}, "camera image size")
        .param_double("hfov", 60.0, 1.0, 170.0, "horizontal field of view, degrees")
        .param_double("fps", 25.0, 0.1, 1000.0, "frames per second of the joint state's time")
        .param_double("wall_distance", 2.0, 0.2, 1000.0, "m from the neck axis to the wall")
        .param_double("wall_width", 4.0, 0.01, 1000.0, "m the scene image spans")
        .param_double("l1", 0.12, 0.0, 10.0, "m: the head's L1 (as the head node's)")
        .param_double("l2", 0.12, 0.0, 10.0, "m: the head's L2")
        .param_double("l3", 0.06, 0.0, 10.0, "m: the head's L3")
        .param_bool("target", true, "draw the moving target")
        .param_double("target_radius", 0.08, 0.001, 10.0, "m")
        .param_double("target_distance", 1.6, 0.2, 1000.0, "m: the target moves in the plane this far ahead")
        .param_double("target_speed", 0.3, 0.0, 100.0, "m/s sideways, back and forth")
        .param_double("target_range", 1.5, 0.0, 1000.0, "m: it turns at +-range")
        .param_double("target_start", 0.0, -1000.0, 1000.0, "m: sideways position at time 0")
        .param_double("target_height", 0.0, -1000.0, 1000.0, "m above the cameras");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    state_ = ctx.input<JointState>("state");
    left_ = ctx.output<Image>("left");
    right_ = ctx.output<Image>("right");
    truth_ = ctx.output<Region>("truth");
    truth_right_ = ctx.output<Region>("truth_right");
    cv::Mat scene = cv::imread(p.get_string("scene"), cv::IMREAD_COLOR);
    if (scene.empty()) return Status::error("scene: cannot read image '" + p.get_string("scene") + "'");
    capture::SimHeadConfig c;
    c.size = p.get_size("size");
    if (c.size.width < 8 || c.size.height < 8) return Status::error("size must be at least 8x8");
    c.focal_px = (c.size.width / 2.0) / std::tan(p.get_double("hfov") * M_PI / 360.0);
    c.wall_distance = p.get_double("wall_distance");
    c.wall_width = p.get_double("wall_width");
    c.geometry = {p.get_double("l1"), p.get_double("l2"), p.get_double("l3")};
    c.target = p.get_bool("target");
    c.target_radius = p.get_double("target_radius");
    c.target_distance = p.get_double("target_distance");
    c.target_speed = p.get_double("target_speed");
    c.target_range = p.get_double("target_range");
    c.target_start = p.get_double("target_start");
    c.target_height = p.get_double("target_height");
    if (c.target_distance >= c.wall_distance) return Status::error("target_distance must be less than wall_distance");
    head_ = std::make_unique<capture::SimHead>(std::move(scene), c);
    period_ns_ = static_cast<int64_t>(1e9 / p.get_double("fps"));
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto state = ctx.get(state_);
    if (state->position.size() != 5) return Status::error("joint state for " + std::to_string(state->position.size()) + " joints, expected 5");
    if (state->timestamp_ns < next_ns_) return {};
    next_ns_ += period_ns_;
    if (next_ns_ <= state->timestamp_ns) next_ns_ = state->timestamp_ns + period_ns_;  // joint states came late
    const kinematics::HeadJoints q{state->position[0], state->position[1], state->position[2], state->position[3],
                                   state->position[4]};
    const double t = static_cast<double>(state->timestamp_ns) * 1e-9;
    OutputHandle<Image> outs[2] = {left_, right_};
    OutputHandle<Region> truths[2] = {truth_, truth_right_};
    for (int camera = 0; camera < 2; ++camera) {
      auto image = ctx.make(outs[camera]);
      const capture::TargetView view = head_->render(camera, q, t, image->mat);
      image->camera_id = camera;
      image->timestamp_ns = state->timestamp_ns;
      image->origin_ns = steady_now_ns();
      image->frame_id = frame_;
      auto truth = ctx.make(truths[camera]);
      truth->stamp_from(*image);
      truth->center = view.center;
      truth->size = cv::Size2d(2 * view.radius, 2 * view.radius);
      truth->depth = view.depth;
      truth->camera_id = camera;
      truth->label = view.visible ? "visible" : "outside";
      ctx.emit(outs[camera], std::move(image));
      ctx.emit(truths[camera], std::move(truth));
    }
    ++frame_;
    return {};
  }

 private:
  InputHandle<JointState> state_;
  OutputHandle<Image> left_, right_;
  OutputHandle<Region> truth_, truth_right_;
  std::unique_ptr<capture::SimHead> head_;
  int64_t period_ns_ = 40'000'000, next_ns_ = 0, frame_ = 0;
};

}  // namespace

SACCADE_PLUGIN("capture", Video, Images, OneImage, Camera, Stereo, Synthetic, SimHeadNode)
