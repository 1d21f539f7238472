#pragma once
// Kinematics of the stereo head: Denavit-Hartenberg chains in Eigen (standard
// and modified conventions, a joint variable in theta or in alpha), the
// paper's chain for one camera, forward kinematics, closed-form pointing of a
// camera's optical axis at a point, and the fixation point of two optical
// axes. Plain code: the head plugin (issue 4) builds on it.
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "saccade/status.hpp"

namespace saccade::kinematics {

enum class Convention {
  kStandard,  // T_i = Rz(theta_i) Tz(d_i) Tx(a_i) Rx(alpha_i)
  kModified,  // Craig: T_i = Rx(alpha_{i-1}) Tx(a_{i-1}) Rz(theta_i) Tz(d_i), the row holding a_{i-1}, alpha_{i-1}
};

// One row: constants, and the joints (indices into the joint vector) added to
// theta and to alpha; a sum of joints (neck + vergence on one axis) is
// written as two indices.
struct DhRow {
  double a = 0, alpha = 0, d = 0, theta = 0;  // metres, radians
  std::vector<int> theta_joints, alpha_joints;
};

class DhChain {
 public:
  DhChain(std::vector<DhRow> rows, Convention convention) : rows_(std::move(rows)), convention_(convention) {}
  // Pose of the last frame in the base frame for joint values q.
  Eigen::Isometry3d forward(const std::vector<double>& q) const;
  // Ok, or an error saying what is wrong (a joint index beyond the joint vector).
  Status check(std::size_t joint_count) const;
  const std::vector<DhRow>& rows() const { return rows_; }
  Convention convention() const { return convention_; }

 private:
  std::vector<DhRow> rows_;
  Convention convention_;
};

// The paper's table for one camera, rows (a, alpha, d, theta):
// (0, 0, 0, q0 + q1), (L1, 0, 0, 0), (0, q2, L2, 0), (L3, 0, 0, 0); joints
// q = (neck pan, vergence, tilt). `side` = -1 mirrors it (the other camera: L1
// and L3 on the other side of the neck).
DhChain paper_camera_chain(Convention convention, double l1 = 0.12, double l2 = 0.12, double l3 = 0.06, int side = 1);
// The physically offset variant: the vergence axis L1 from the neck axis. In
// the modified convention the rows are (0, 0, 0, q0), (L1, 0, 0, q1),
// (0, q2, L2, 0), (L3, 0, 0, 0); in the standard one (L1, 0, 0, q0),
// (0, q2, L2, q1), (L3, 0, 0, 0), so that both give the neck, the offset, then
// the vergence: Rz(q0) Tx(L1) Rz(q1) ... (each convention then places L2 as
// its reading of the paper's table does).
DhChain offset_camera_chain(Convention convention, double l1 = 0.12, double l2 = 0.12, double l3 = 0.06, int side = 1);

// The camera's optical axis in its last frame: +y (at zero joints it looks
// along the base's +y, the pan rotates it about z, the tilt raises it).
inline Eigen::Vector3d optical_axis(const Eigen::Isometry3d& camera) { return camera.linear().col(1); }
// The camera's optical frame as images use it (x right, y down, z along the
// optical axis), in the base frame, from the chain's last frame (+x right,
// +y the optical axis, +z up).
inline Eigen::Isometry3d optical_frame(const Eigen::Isometry3d& camera) {
  Eigen::Matrix3d m;
  m << 1, 0, 0, 0, 0, 1, 0, -1, 0;
  Eigen::Isometry3d out = camera;
  out.linear() = camera.linear() * m;
  return out;
}

struct JointLimits {
  double pan_min = -1.6, pan_max = 1.6;  // the summed pan (neck + vergence) of the paper's chain
  double tilt_min = -0.8, tilt_max = 0.8;
};

struct Pointing {
  double pan = 0, tilt = 0;  // the paper's chain: q0 + q1 (neck + vergence), q2
};

// Closed form for the paper's chain: the pan and tilt that put `target`
// (base frame) on the camera's optical axis, in front of it; the root in
// front is chosen; limits are respected (a target beyond them, or one no pan
// puts in front, is an error saying why). The modified reading, whose tilt
// also turns the L2 offset, has its own tilt formula.
Result<Pointing> point_at(const Eigen::Vector3d& target, double l1, double l2, double l3, int side,
                          const JointLimits& limits, Convention convention = Convention::kStandard);

// The whole head with the paper's chain for each camera: the left camera on
// the -x side (side -1), the right on +x, each turning about the neck axis by
// neck + its vergence, and tilting on its own.
struct HeadGeometry {
  double l1 = 0.12, l2 = 0.12, l3 = 0.06;
};
struct HeadJoints {
  double neck = 0, vergence_left = 0, tilt_left = 0, vergence_right = 0, tilt_right = 0;
};
struct HeadLimits {
  double neck_min = -1.6, neck_max = 1.6;
  double vergence_min = -0.6, vergence_max = 0.6;
  double tilt_min = -0.8, tilt_max = 0.8;
};
// Camera poses (base frame) of the head at `q`.
Eigen::Isometry3d left_camera(const HeadGeometry& g, const HeadJoints& q);
Eigen::Isometry3d right_camera(const HeadGeometry& g, const HeadJoints& q);

// Dependent mode: the joints that make both cameras fixate `target`; the
// neck takes the mean of the two pans so that the vergence is symmetric (left
// = -right). An error says why the head cannot (a camera cannot point there,
// a joint beyond its limits).
Result<HeadJoints> gaze_at(const Eigen::Vector3d& target, const HeadGeometry& g, const HeadLimits& limits);
// Independent mode: each camera its own target; the neck again the mean pan.
Result<HeadJoints> gaze_each(const Eigen::Vector3d& left_target, const Eigen::Vector3d& right_target,
                             const HeadGeometry& g, const HeadLimits& limits);

// The fixation point of two rays (camera centres c1, c2 and directions d1,
// d2): the midpoint of their common perpendicular, and its length (the
// residual: 0 when the rays meet). No point for (nearly) parallel rays.
struct Fixation {
  bool valid = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double residual = 0;
  const char* why = "";  // a literal: every frame of parallel cameras is invalid, and says why without allocating
};
Fixation fixation_point(const Eigen::Vector3d& c1, const Eigen::Vector3d& d1, const Eigen::Vector3d& c2,
                        const Eigen::Vector3d& d2);

// A pixel with its depth (metres along the optical axis) to a point in the
// camera frame of a pinhole camera (fx, fy, cx, cy); camera frame: x right,
// y down, z along the optical axis.
Eigen::Vector3d back_project(double u, double v, double depth, double fx, double fy, double cx, double cy);

}  // namespace saccade::kinematics
