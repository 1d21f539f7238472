// The `kinematics` node: a joint state in, where the cameras are and the point
// they fixate out (HeadPose), for whoever needs the head's geometry per frame
// (rectified sampling, depth in the head's frame, a viewer). Thin: the work is
// in kinematics.cpp.
#include <Eigen/Geometry>

#include "kinematics.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;

cv::Vec3d to_cv(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

cv::Vec4d rotation_of(const Eigen::Isometry3d& pose) {
  const Eigen::Quaterniond q(pose.linear());
  return {q.w(), q.x(), q.y(), q.z()};
}

class KinematicsNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<JointState> kState{
      "state", "the joints (neck, vergence left, tilt left, vergence right, tilt right), radians"};
  static constexpr Out<HeadPose> kPose{"pose", "each camera's optical frame in the base frame, and the fixation point"};

  static void bind(ParamBinder<kinematics::HeadGeometry>& b) {
    using G = kinematics::HeadGeometry;
    b.field("l1", {0, 10}, "m: neck axis to the vergence axis (the paper's L1)", &G::l1)
        .field("l2", {0, 10}, "m: height of the tilt axis (L2)", &G::l2)
        .field("l3", {0, 10}, "m: tilt axis to the camera (L3)", &G::l3);
  }
  static Contract contract() {
    return Contract(
               "The stereo head's forward kinematics: from each joint state, the two cameras' poses and the "
               "point their optical axes meet (the paper's chain, docs/head.md).")
        .ports(kState, kPose)
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    geometry_ = ctx.config(&bind);
    short_states_ = &ctx.counter("short_states");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto state = ctx.get(kState);
    const std::vector<double>& p = state->position;
    if (p.size() < 5) {  // not a head's joints: nothing to say about this frame
      short_states_->fetch_add(1, std::memory_order_relaxed);
      return {};
    }
    const kinematics::HeadJoints q{p[0], p[1], p[2], p[3], p[4]};
    const Eigen::Isometry3d left = kinematics::left_camera(geometry_, q);
    const Eigen::Isometry3d right = kinematics::right_camera(geometry_, q);
    const kinematics::Fixation f = kinematics::fixation_point(left.translation(), kinematics::optical_axis(left),
                                                              right.translation(), kinematics::optical_axis(right));
    auto pose = ctx.make(kPose);
    pose->left_position = to_cv(left.translation());
    pose->right_position = to_cv(right.translation());
    pose->left_rotation = rotation_of(kinematics::optical_frame(left));
    pose->right_rotation = rotation_of(kinematics::optical_frame(right));
    pose->fixation_valid = f.valid;
    pose->fixation = f.valid ? to_cv(f.point) : cv::Vec3d();
    pose->fixation_gap = f.valid ? f.residual : 0.0;
    ctx.emit(kPose, std::move(pose));
    return {};
  }

 private:
  kinematics::HeadGeometry geometry_;
  std::atomic<uint64_t>* short_states_ = nullptr;
};

}  // namespace

SACCADE_PLUGIN("kinematics", KinematicsNode)
