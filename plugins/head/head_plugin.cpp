// The `head` node: gaze requests -> inverse kinematics -> trajectories ->
// joint targets, once per joint state (the control rate), with the fault
// handling of GazeController. Thin: the work is in gaze_controller.cpp.
#include <cmath>

#include "gaze_controller.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"
#include "saccade/stats.hpp"

namespace {

using namespace saccade;

constexpr double kDeg = M_PI / 180.0;

// The head node's parameters in the units users write (degrees, ms);
// to_config turns them into the controller's (radians, s).
struct HeadParams {
  kinematics::HeadGeometry geometry;
  cv::Point2d neck_limits{-90, 90};  // degrees: min,max
  cv::Point2d vergence_limits{-35, 35};
  cv::Point2d tilt_limits{-45, 45};
  double velocity_deg = 170.0;
  double acceleration_deg = 1700.0;
  double saccade_threshold_deg = 2.0;
  double pursuit_ms = 120.0;
  double following_error_deg = 11.5;
  double feedback_timeout_ms = 50.0;
  double default_depth = 1.5;
  double focal_px = 0.0;  // 0: from hfov
  double hfov_deg = 60.0;
};

// The controller's configuration, or an error when a joint range is not min < max.
Result<head::HeadConfig> to_config(const HeadParams& p) {
  const auto range = [](const cv::Point2d& r, double& lo, double& hi) {
    lo = r.x * kDeg;
    hi = r.y * kDeg;
    return r.x < r.y;
  };
  head::HeadConfig c;
  c.geometry = p.geometry;
  c.velocity = p.velocity_deg * kDeg;
  c.acceleration = p.acceleration_deg * kDeg;
  c.saccade_threshold = p.saccade_threshold_deg * kDeg;
  c.pursuit_time = p.pursuit_ms * 1e-3;
  c.following_error = p.following_error_deg * kDeg;
  c.feedback_timeout = p.feedback_timeout_ms * 1e-3;
  c.default_depth = p.default_depth;
  if (!range(p.neck_limits, c.limits.neck_min, c.limits.neck_max) ||
      !range(p.vergence_limits, c.limits.vergence_min, c.limits.vergence_max) ||
      !range(p.tilt_limits, c.limits.tilt_min, c.limits.tilt_max))
    return Status::error("joint limits must be min,max with min < max");
  return c;
}

class HeadNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<JointState> kState{"state",
                                         "the joints as the drives report them; one control cycle per message"};
  static constexpr SideIn<GazeRequest> kGaze{"gaze", "where to look (each new request is taken once)"};
  static constexpr Out<JointTargets> kTargets{"targets", "joint targets for the driver, every cycle"};
  static constexpr Out<Region> kMoved{"moved",
                                      "when a request from an image is taken: the pixel the head turns to "
                                      "bring to the centre (for the fovea's 'head' input)"};

  static void bind(ParamBinder<HeadParams>& b) {
    using P = HeadParams;
    using G = kinematics::HeadGeometry;
    b.field("l1", {0, 10}, "m: neck axis to the vergence axis (the paper's L1)", &P::geometry, &G::l1)
        .field("l2", {0, 10}, "m: height of the tilt axis (L2)", &P::geometry, &G::l2)
        .field("l3", {0, 10}, "m: tilt axis to the camera (L3)", &P::geometry, &G::l3)
        .field("neck_limits", "degrees: min,max of the neck pan", &P::neck_limits)
        .field("vergence_limits", "degrees: min,max of each vergence joint", &P::vergence_limits)
        .field("tilt_limits", "degrees: min,max of each tilt joint", &P::tilt_limits)
        .field("velocity", {1, 10000}, "degrees/s: every joint's velocity limit", &P::velocity_deg)
        .field("acceleration", {1, 1e6}, "degrees/s^2: every joint's acceleration limit", &P::acceleration_deg)
        .field("saccade_threshold", {0, 180},
               "degrees: a larger change of any joint is a saccade, smaller ones pursuit", &P::saccade_threshold_deg)
        .field("pursuit_ms", {0, 10000}, "the shortest re-planned pursuit move", &P::pursuit_ms)
        .field("following_error", {0.01, 360}, "degrees between commanded and measured that hold the head",
               &P::following_error_deg)
        .field("feedback_timeout_ms", {1, 1e6}, "a joint without a new position this long holds the head",
               &P::feedback_timeout_ms)
        .field("default_depth", {0.01, 1000}, "m: depth of a request without one when no fixation point is known",
               &P::default_depth)
        .field("focal", {0, 1e6}, "focal length in pixels for pixel requests that carry none (0: from hfov)",
               &P::focal_px)
        .field("hfov", {1, 179}, "horizontal field of view, degrees (when focal is 0 and the request has none)",
               &P::hfov_deg);
  }

  static Contract contract() {
    return Contract(
               "The gaze controller of the 5-DOF stereo head: gaze requests (a point, a camera direction or pixel "
               "with or without depth, a stereo pixel pair, a relative turn, the fovea's requests) become joint "
               "targets along minimum-jerk saccades or re-planned pursuit within the joints' limits. A drive "
               "fault, a silent drive, stale feedback or a following error hold the head until 'reset'.")
        .ports(kState, kGaze)
        .side_input<Message>("reset", "any new message clears a hold")
        .ports(kTargets, kMoved)
        .params(&bind);
  }

  Status open(OpenContext& ctx) override {
    reset_ = ctx.input<Message>("reset");
    capture_to_taken_ = &ctx.timing("gaze_capture_to_taken");
    const HeadParams p = ctx.config(&bind);
    Result<head::HeadConfig> config = to_config(p);
    if (!config.ok()) return config.status();
    focal_ = p.focal_px;
    hfov_ = p.hfov_deg * kDeg;
    controller_ = std::make_unique<head::GazeController>(std::move(config).value());
    readings_.resize(head::kJoints);
    return {};
  }

  Status process(ProcessContext& ctx) override {
    auto state = ctx.get(kState);
    if (state->position.size() != static_cast<std::size_t>(head::kJoints) ||
        state->health.size() != state->position.size())
      return Status::error("joint state for " + std::to_string(state->position.size()) + " joints, expected " +
                           std::to_string(head::kJoints));
    for (std::size_t j = 0; j < readings_.size(); ++j) {
      head::JointReading& r = readings_[j];
      r.position = state->position[j];
      r.velocity = state->velocity.size() > j ? state->velocity[j] : 0.0;
      r.updated_ns = state->updated_ns.size() > j ? state->updated_ns[j] : state->timestamp_ns;
      switch (state->health[j]) {
        case JointState::Health::kReady: r.health = head::JointReading::Health::kReady; break;
        case JointState::Health::kFault: r.health = head::JointReading::Health::kFault; break;
        case JointState::Health::kSilent: r.health = head::JointReading::Health::kSilent; break;
        case JointState::Health::kStarting: r.health = head::JointReading::Health::kStarting; break;
      }
    }
    if (auto reset = ctx.get(reset_); reset && reset != last_reset_) {
      last_reset_ = reset;
      controller_->reset();
    }
    // A new request first, so that this cycle's targets already head for it
    // (taken after the cycle, it waited one control period more).
    Cause answered;
    if (auto gaze = ctx.get(kGaze); gaze && gaze != last_gaze_) {
      last_gaze_ = gaze;
      if (const Status taken = request(*gaze); !taken.ok()) {
        log().info("{}: gaze request ({}) not taken: {}", ctx.node_name(), to_string(gaze->kind), taken.message());
      } else {
        answered = {gaze->origin_ns, steady_now_ns()};
        if (gaze->origin_ns > 0 && answered.taken_ns >= gaze->origin_ns)
          capture_to_taken_->record(answered.taken_ns - gaze->origin_ns);
        if (gaze->kind != GazeRequest::Kind::kPoint && gaze->kind != GazeRequest::Kind::kRelative) {
          auto moved = ctx.make(kMoved);
          moved->stamp_from(*gaze);
          moved->center = gaze->pixel;
          moved->camera_id = gaze->camera_id;
          moved->label = gaze->reason;
          ctx.emit(kMoved, std::move(moved));
        }
      }
    }
    const bool was_holding = controller_->holding();
    const head::HeadCommand& command = controller_->cycle(state->timestamp_ns, readings_);
    if (command.hold && !was_holding)
      log().warn("{}: holding: {}{}{}", ctx.node_name(), command.fault,
                 state->detail.empty() ? "" : "; the driver: ", state->detail);
    auto targets = ctx.make(kTargets);
    targets->position = command.position;
    targets->velocity = command.velocity;
    targets->hold = command.hold;
    targets->reset = command.reset;
    targets->fault = command.fault;
    targets->cause_origin_ns = answered.origin_ns;
    targets->cause_taken_ns = answered.taken_ns;
    ctx.emit(kTargets, std::move(targets));
    return {};
  }

 private:
  // The request in the controller's terms; ok when taken, else why not.
  Status request(const GazeRequest& g) {
    const double focal = g.focal_px > 0 ? g.focal_px
                         : focal_ > 0   ? focal_
                                        : (g.image_size.width / 2.0) / std::tan(hfov_ / 2);
    const double cx = g.image_size.width / 2.0, cy = g.image_size.height / 2.0;
    switch (g.kind) {
      case GazeRequest::Kind::kDirection:
        return controller_->look_along(g.camera_id, {g.direction[0], g.direction[1], g.direction[2]}, g.depth);
      case GazeRequest::Kind::kPixelDepth:
        if (g.image_size.width <= 0) return Status::error("pixel request without its image size");
        return controller_->look_along(g.camera_id, {(g.pixel.x - cx) / focal, (g.pixel.y - cy) / focal, 1.0}, g.depth);
      case GazeRequest::Kind::kPixelDisparity:
        if (g.image_size.width <= 0) return Status::error("pixel request without its image size");
        return controller_->look_at_stereo(g.pixel.x, g.pixel.y, g.disparity, focal, cx, cy);
      case GazeRequest::Kind::kPoint: return controller_->look_at({g.point[0], g.point[1], g.point[2]});
      case GazeRequest::Kind::kRelative: return controller_->turn(g.azimuth, g.elevation);
    }
    return Status::error("unknown request kind");
  }

  InputHandle<Message> reset_;
  std::unique_ptr<head::GazeController> controller_;
  std::vector<head::JointReading> readings_;
  std::shared_ptr<const GazeRequest> last_gaze_;
  Histogram* capture_to_taken_ = nullptr;  // a request's camera frame -> this node takes it
  // The gaze request this cycle's targets answer (JointTargets::cause_*).
  struct Cause {
    int64_t origin_ns = 0, taken_ns = 0;
  };
  MessagePtr last_reset_;
  double focal_ = 0, hfov_ = 1;
};

}  // namespace

SACCADE_PLUGIN("head", HeadNode)
