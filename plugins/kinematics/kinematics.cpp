#include "kinematics.hpp"

#include <array>
#include <cmath>
#include <iterator>

namespace saccade::kinematics {

namespace {

Eigen::Isometry3d rot_z(double t) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return m;
}
Eigen::Isometry3d rot_x(double t) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.linear() = Eigen::AngleAxisd(t, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return m;
}
Eigen::Isometry3d trans(double x, double y, double z) {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  m.translation() = Eigen::Vector3d(x, y, z);
  return m;
}

// `t` followed by one row's transform, `theta` and `alpha` with their joints
// added (multiplied in this order: a product of transforms rounds by its order).
void follow_row(Eigen::Isometry3d& t, Convention convention, const DhRow& r, double theta, double alpha) {
  if (convention == Convention::kStandard)
    t = t * rot_z(theta) * trans(0, 0, r.d) * trans(r.a, 0, 0) * rot_x(alpha);
  else
    t = t * rot_x(alpha) * trans(r.a, 0, 0) * rot_z(theta) * trans(0, 0, r.d);
}

// The paper's table for one camera (paper_camera_chain), its joints left out:
// row 0's theta takes the neck and the vergence, row 2's alpha the tilt.
std::array<DhRow, 4> paper_rows(double l1, double l2, double l3, int side) {
  const double s = side < 0 ? -1.0 : 1.0;
  return {{{0, 0, 0, 0, {}, {}}, {s * l1, 0, 0, 0, {}, {}}, {0, 0, l2, 0, {}, {}}, {s * l3, 0, 0, 0, {}, {}}}};
}

// paper_camera_chain(kStandard, l1, l2, l3, side).forward({neck, vergence,
// tilt}), the same operations in the same order (so the same pose to the
// last bit) without building the chain, which allocates: the gaze controller
// and the kinematics node ask for the cameras' poses on every cycle.
Eigen::Isometry3d paper_camera(double l1, double l2, double l3, int side, double neck, double vergence, double tilt) {
  const std::array<DhRow, 4> rows = paper_rows(l1, l2, l3, side);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  follow_row(t, Convention::kStandard, rows[0], rows[0].theta + neck + vergence, rows[0].alpha);
  follow_row(t, Convention::kStandard, rows[1], rows[1].theta, rows[1].alpha);
  follow_row(t, Convention::kStandard, rows[2], rows[2].theta, rows[2].alpha + tilt);
  follow_row(t, Convention::kStandard, rows[3], rows[3].theta, rows[3].alpha);
  return t;
}

}  // namespace

Status DhChain::check(std::size_t joint_count) const {
  for (std::size_t i = 0; i < rows_.size(); ++i)
    for (const auto* joints : {&rows_[i].theta_joints, &rows_[i].alpha_joints})
      for (int j : *joints)
        if (j < 0 || static_cast<std::size_t>(j) >= joint_count)
          return Status::error("row " + std::to_string(i) + " names joint " + std::to_string(j) + " of " +
                               std::to_string(joint_count));
  return {};
}

Eigen::Isometry3d DhChain::forward(const std::vector<double>& q) const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  for (const DhRow& r : rows_) {
    double theta = r.theta, alpha = r.alpha;
    for (int j : r.theta_joints) theta += q.at(static_cast<std::size_t>(j));
    for (int j : r.alpha_joints) alpha += q.at(static_cast<std::size_t>(j));
    follow_row(t, convention_, r, theta, alpha);
  }
  return t;
}

DhChain paper_camera_chain(Convention convention, double l1, double l2, double l3, int side) {
  std::array<DhRow, 4> rows = paper_rows(l1, l2, l3, side);
  rows[0].theta_joints = {0, 1};
  rows[2].alpha_joints = {2};
  return DhChain({std::make_move_iterator(rows.begin()), std::make_move_iterator(rows.end())}, convention);
}

DhChain offset_camera_chain(Convention convention, double l1, double l2, double l3, int side) {
  const double s = side < 0 ? -1.0 : 1.0;
  std::vector<DhRow> rows;
  if (convention == Convention::kModified)
    rows = {{0, 0, 0, 0, {0}, {}}, {s * l1, 0, 0, 0, {1}, {}}, {0, 0, l2, 0, {}, {2}}, {s * l3, 0, 0, 0, {}, {}}};
  else
    rows = {{s * l1, 0, 0, 0, {0}, {}}, {0, 0, l2, 0, {1}, {2}}, {s * l3, 0, 0, 0, {}, {}}};
  return DhChain(std::move(rows), convention);
}

Result<Pointing> point_at(const Eigen::Vector3d& target, double l1, double l2, double l3, int side,
                          const JointLimits& limits, Convention convention) {
  // T = Rz(pan) Tx(R) Tz(L2) Rx(tilt) Tx(R3): the centre is Rz(pan) (R, 0, L2)
  // with R = s (L1 + L3), the axis Rz(pan) (0, cos tilt, sin tilt). In the
  // frame turned by -pan the target must lie at x' = R, in front (y' > 0).
  const double r = (side < 0 ? -1.0 : 1.0) * (l1 + l3);
  const double rho = std::hypot(target.x(), target.y());
  if (rho < std::abs(r) + 1e-12)
    return Status::error("the target is within the cameras' circle around the neck (" + std::to_string(rho) +
                         " m from the axis)");
  const double phi = std::atan2(target.y(), target.x());
  const double delta = std::acos(r / rho);
  Pointing p;
  bool reachable = false;
  for (double pan : {phi - delta, phi + delta}) {
    pan = std::remainder(pan, 2 * M_PI);
    const double y = -target.x() * std::sin(pan) + target.y() * std::cos(pan);
    if (y <= 0) continue;  // behind the camera: the other root
    p.pan = pan;
    if (convention == Convention::kStandard) {
      p.tilt = std::atan2(target.z() - l2, y);
    } else {
      // Modified: the centre is Rz(pan) (R, -L2 sin t, L2 cos t), so the
      // target is on the axis when y' sin t - z' cos t + L2 = 0, i.e.
      // sin(t - psi) = -L2 / r with (y', z') = r (cos psi, sin psi); of the two
      // roots, the one with the target in front.
      const double rr = std::hypot(y, target.z());
      if (rr < l2) continue;
      const double psi = std::atan2(target.z(), y), a = std::asin(-l2 / rr);
      bool found = false;
      for (double tilt : {psi + a, psi + M_PI - a}) {
        tilt = std::remainder(tilt, 2 * M_PI);
        const double ahead =
            (y + l2 * std::sin(tilt)) * std::cos(tilt) + (target.z() - l2 * std::cos(tilt)) * std::sin(tilt);
        if (ahead > 0) {
          p.tilt = tilt;
          found = true;
          break;
        }
      }
      if (!found) continue;
    }
    reachable = true;
    break;
  }
  if (!reachable) return Status::error("no pan puts the target in front of the camera");
  if (p.pan < limits.pan_min || p.pan > limits.pan_max)
    return Status::error("pan " + std::to_string(p.pan) + " rad is beyond its limits");
  if (p.tilt < limits.tilt_min || p.tilt > limits.tilt_max)
    return Status::error("tilt " + std::to_string(p.tilt) + " rad is beyond its limits");
  return p;
}

Eigen::Isometry3d left_camera(const HeadGeometry& g, const HeadJoints& q) {
  return paper_camera(g.l1, g.l2, g.l3, -1, q.neck, q.vergence_left, q.tilt_left);
}

Eigen::Isometry3d right_camera(const HeadGeometry& g, const HeadJoints& q) {
  return paper_camera(g.l1, g.l2, g.l3, 1, q.neck, q.vergence_right, q.tilt_right);
}

Result<HeadJoints> gaze_each(const Eigen::Vector3d& left_target, const Eigen::Vector3d& right_target,
                             const HeadGeometry& g, const HeadLimits& limits) {
  // Each camera's own pan and tilt, with limits wide enough not to cut the
  // sum (neck + vergence); the head's own limits are checked after the split.
  const JointLimits open{-M_PI, M_PI, limits.tilt_min, limits.tilt_max};
  const Result<Pointing> l = point_at(left_target, g.l1, g.l2, g.l3, -1, open);
  if (!l.ok()) return Status::error("left camera: " + l.error());
  const Result<Pointing> r = point_at(right_target, g.l1, g.l2, g.l3, 1, open);
  if (!r.ok()) return Status::error("right camera: " + r.error());
  HeadJoints q;
  q.neck = 0.5 * (l->pan + r->pan);
  q.vergence_left = l->pan - q.neck;
  q.vergence_right = r->pan - q.neck;
  q.tilt_left = l->tilt;
  q.tilt_right = r->tilt;
  if (q.neck < limits.neck_min || q.neck > limits.neck_max)
    return Status::error("neck " + std::to_string(q.neck) + " rad is beyond its limits");
  for (double v : {q.vergence_left, q.vergence_right})
    if (v < limits.vergence_min || v > limits.vergence_max)
      return Status::error("vergence " + std::to_string(v) + " rad is beyond its limits (the target is too near)");
  return q;
}

Result<HeadJoints> gaze_at(const Eigen::Vector3d& target, const HeadGeometry& g, const HeadLimits& limits) {
  return gaze_each(target, target, g, limits);
}

Fixation fixation_point(const Eigen::Vector3d& c1, const Eigen::Vector3d& d1, const Eigen::Vector3d& c2,
                        const Eigen::Vector3d& d2) {
  Fixation f;
  const Eigen::Vector3d u = d1.normalized(), v = d2.normalized(), w = c1 - c2;
  const double b = u.dot(v), d = u.dot(w), e = v.dot(w);
  const double denom = 1.0 - b * b;
  if (denom < 1e-12) {
    f.why = "the optical axes are parallel: they fixate no point";
    return f;
  }
  const double s = (b * e - d) / denom, t = (e - b * d) / denom;
  const Eigen::Vector3d p1 = c1 + s * u, p2 = c2 + t * v;
  f.point = 0.5 * (p1 + p2);
  f.residual = (p1 - p2).norm();
  f.valid = true;
  if (s < 0 || t < 0) {
    f.valid = false;
    f.why = "the axes come closest behind a camera";
  }
  return f;
}

Eigen::Vector3d back_project(double u, double v, double depth, double fx, double fy, double cx, double cy) {
  return Eigen::Vector3d((u - cx) / fx * depth, (v - cy) / fy * depth, depth);
}

}  // namespace saccade::kinematics
