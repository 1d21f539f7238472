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

class HeadNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static Contract contract() {
    return Contract("The gaze controller of the 5-DOF stereo head: gaze requests (a point, a camera direction or pixel "
                    "with or without depth, a stereo pixel pair, a relative turn, the fovea's requests) become joint "
                    "targets along minimum-jerk saccades or re-planned pursuit within the joints' limits. A drive "
                    "fault, a silent drive, stale feedback or a following error hold the head until 'reset'.")
        .input<JointState>("state", "the joints as the drives report them; one control cycle per message")
        .side_input<GazeRequest>("gaze", "where to look (each new request is taken once)")
        .side_input<Message>("reset", "any new message clears a hold")
        .output<JointTargets>("targets", "joint targets for the driver, every cycle")
        .output<Region>("moved", "when a request from an image is taken: the pixel the head turns to bring to the centre (for the fovea's 'head' input)")
        .param_double("l1", 0.12, 0.0, 10.0, "m: neck axis to the vergence axis (the paper's L1)")
        .param_double("l2", 0.12, 0.0, 10.0, "m: height of the tilt axis (L2)")
        .param_double("l3", 0.06, 0.0, 10.0, "m: tilt axis to the camera (L3)")
        .param_point("neck_limits", cv::Point2d(-90, 90), "degrees: min,max of the neck pan")
        .param_point("vergence_limits", cv::Point2d(-35, 35), "degrees: min,max of each vergence joint")
        .param_point("tilt_limits", cv::Point2d(-45, 45), "degrees: min,max of each tilt joint")
        .param_double("velocity", 170.0, 1.0, 10000.0, "degrees/s: every joint's velocity limit")
        .param_double("acceleration", 1700.0, 1.0, 1e6, "degrees/s^2: every joint's acceleration limit")
        .param_double("saccade_threshold", 2.0, 0.0, 180.0, "degrees: a larger change of any joint is a saccade, smaller ones pursuit")
        .param_double("pursuit_ms", 120.0, 0.0, 10000.0, "the shortest re-planned pursuit move")
        .param_double("following_error", 11.5, 0.01, 360.0, "degrees between commanded and measured that hold the head")
        .param_double("feedback_timeout_ms", 50.0, 1.0, 1e6, "a joint without a new position this long holds the head")
        .param_double("default_depth", 1.5, 0.01, 1000.0, "m: depth of a request without one when no fixation point is known")
        .param_double("focal", 0.0, 0.0, 1e6, "focal length in pixels for pixel requests that carry none (0: from hfov)")
        .param_double("hfov", 60.0, 1.0, 179.0, "horizontal field of view, degrees (when focal is 0 and the request has none)");
  }

  Status open(OpenContext& ctx) override {
    state_ = ctx.input<JointState>("state");
    gaze_ = ctx.input<GazeRequest>("gaze");
    reset_ = ctx.input<Message>("reset");
    targets_ = ctx.output<JointTargets>("targets");
    moved_ = ctx.output<Region>("moved");
    capture_to_taken_ = &ctx.timing("gaze_capture_to_taken");
    const Params& p = ctx.params();
    head::HeadConfig c;
    c.geometry = {p.get_double("l1"), p.get_double("l2"), p.get_double("l3")};
    const auto range = [&](const char* name, double& lo, double& hi) {
      const cv::Point2d r = p.get_point(name);
      lo = r.x * kDeg;
      hi = r.y * kDeg;
      return r.x < r.y;
    };
    if (!range("neck_limits", c.limits.neck_min, c.limits.neck_max) ||
        !range("vergence_limits", c.limits.vergence_min, c.limits.vergence_max) ||
        !range("tilt_limits", c.limits.tilt_min, c.limits.tilt_max))
      return Status::error("joint limits must be min,max with min < max");
    c.velocity = p.get_double("velocity") * kDeg;
    c.acceleration = p.get_double("acceleration") * kDeg;
    c.saccade_threshold = p.get_double("saccade_threshold") * kDeg;
    c.pursuit_time = p.get_double("pursuit_ms") * 1e-3;
    c.following_error = p.get_double("following_error") * kDeg;
    c.feedback_timeout = p.get_double("feedback_timeout_ms") * 1e-3;
    c.default_depth = p.get_double("default_depth");
    focal_ = p.get_double("focal");
    hfov_ = p.get_double("hfov") * kDeg;
    controller_ = std::make_unique<head::GazeController>(c);
    readings_.resize(head::kJoints);
    return {};
  }

  Status process(ProcessContext& ctx) override {
    auto state = ctx.get(state_);
    if (state->position.size() != static_cast<std::size_t>(head::kJoints) || state->health.size() != state->position.size())
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
    if (auto gaze = ctx.get(gaze_); gaze && gaze != last_gaze_) {
      last_gaze_ = gaze;
      const std::string why = request(*gaze);
      if (!why.empty()) {
        log().info("{}: gaze request ({}) not taken: {}", ctx.node_name(), to_string(gaze->kind), why);
      } else {
        answered = {gaze->origin_ns, steady_now_ns()};
        if (gaze->origin_ns > 0 && answered.taken_ns >= gaze->origin_ns)
          capture_to_taken_->record(answered.taken_ns - gaze->origin_ns);
        if (gaze->kind != GazeRequest::Kind::kPoint && gaze->kind != GazeRequest::Kind::kRelative) {
          auto moved = ctx.make(moved_);
          moved->stamp_from(*gaze);
          moved->center = gaze->pixel;
          moved->camera_id = gaze->camera_id;
          moved->label = gaze->reason;
          ctx.emit(moved_, std::move(moved));
        }
      }
    }
    const bool was_holding = controller_->holding();
    const head::HeadCommand& command = controller_->cycle(state->timestamp_ns, readings_);
    if (command.hold && !was_holding)
      log().warn("{}: holding: {}{}{}", ctx.node_name(), command.fault, state->detail.empty() ? "" : "; the driver: ",
                 state->detail);
    auto targets = ctx.make(targets_);
    targets->position = command.position;
    targets->velocity = command.velocity;
    targets->hold = command.hold;
    targets->reset = command.reset;
    targets->fault = command.fault;
    targets->cause_origin_ns = answered.origin_ns;
    targets->cause_taken_ns = answered.taken_ns;
    ctx.emit(targets_, std::move(targets));
    return {};
  }

 private:
  // The request in the controller's terms; "" when taken.
  std::string request(const GazeRequest& g) {
    const double focal = g.focal_px > 0 ? g.focal_px
                         : focal_ > 0  ? focal_
                                       : (g.image_size.width / 2.0) / std::tan(hfov_ / 2);
    const double cx = g.image_size.width / 2.0, cy = g.image_size.height / 2.0;
    switch (g.kind) {
      case GazeRequest::Kind::kDirection:
        return controller_->look_along(g.camera_id, {g.direction[0], g.direction[1], g.direction[2]}, g.depth);
      case GazeRequest::Kind::kPixelDepth:
        if (g.image_size.width <= 0) return "pixel request without its image size";
        return controller_->look_along(g.camera_id, {(g.pixel.x - cx) / focal, (g.pixel.y - cy) / focal, 1.0}, g.depth);
      case GazeRequest::Kind::kPixelDisparity:
        if (g.image_size.width <= 0) return "pixel request without its image size";
        return controller_->look_at_stereo(g.pixel.x, g.pixel.y, g.disparity, focal, cx, cy);
      case GazeRequest::Kind::kPoint: return controller_->look_at({g.point[0], g.point[1], g.point[2]});
      case GazeRequest::Kind::kRelative: return controller_->turn(g.azimuth, g.elevation);
    }
    return "unknown request kind";
  }

  InputHandle<JointState> state_;
  InputHandle<GazeRequest> gaze_;
  InputHandle<Message> reset_;
  OutputHandle<JointTargets> targets_;
  OutputHandle<Region> moved_;
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
