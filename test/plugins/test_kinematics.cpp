// Kinematics of the stereo head: the paper's chain read both ways, the offset
// variant, pointing the optical axis at a point, and fixation points.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Geometry>

#include "kinematics.hpp"
#include "saccade/testing.hpp"

namespace saccade::kinematics {
namespace {

constexpr double kL1 = 0.12, kL2 = 0.12, kL3 = 0.06;

Eigen::Isometry3d rz(double t) { return Eigen::Isometry3d(Eigen::AngleAxisd(t, Eigen::Vector3d::UnitZ())); }
Eigen::Isometry3d rx(double t) { return Eigen::Isometry3d(Eigen::AngleAxisd(t, Eigen::Vector3d::UnitX())); }
Eigen::Isometry3d tr(double x, double y, double z) { return Eigen::Isometry3d(Eigen::Translation3d(x, y, z)); }

TEST(PaperChain, StandardReadingIsThePapersPrintedComposition) {
  const DhChain chain = paper_camera_chain(Convention::kStandard);
  const Eigen::Isometry3d t = chain.forward({0.3, -0.1, 0.25});
  EXPECT_NEAR(t.translation().x(), 0.17641, 1e-5);
  EXPECT_NEAR(t.translation().y(), 0.03576, 1e-5);
  EXPECT_NEAR(t.translation().z(), 0.12, 1e-12);
  const double c12 = std::cos(0.2), s12 = std::sin(0.2), c3 = std::cos(0.25), s3 = std::sin(0.25);
  Eigen::Matrix3d expected;
  expected << c12, -s12 * c3, s12 * s3, s12, c12 * c3, -c12 * s3, 0, s3, c3;
  EXPECT_LT((t.linear() - expected).norm(), 1e-12);
  // T = Rz(theta12) Tx(L1) Tz(L2) Rx(theta3) Tx(L3), for any angles.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> angle(-1.5, 1.5);
  for (int i = 0; i < 50; ++i) {
    const double q0 = angle(rng), q1 = angle(rng), q2 = angle(rng);
    const Eigen::Isometry3d composed = rz(q0 + q1) * tr(kL1, 0, 0) * tr(0, 0, kL2) * rx(q2) * tr(kL3, 0, 0);
    EXPECT_LT((chain.forward({q0, q1, q2}).matrix() - composed.matrix()).norm(), 1e-12);
  }
}

TEST(PaperChain, ModifiedReadingRotatesTheL2OffsetWithTheTilt) {
  const DhChain chain = paper_camera_chain(Convention::kModified);
  const Eigen::Vector3d p = chain.forward({0.3, -0.1, 0.25}).translation();
  EXPECT_NEAR(p.x(), 0.18231, 1e-5);
  EXPECT_NEAR(p.y(), 0.00666, 1e-5);
  EXPECT_NEAR(p.z(), 0.11627, 1e-5);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> angle(-1.5, 1.5);
  for (int i = 0; i < 50; ++i) {
    const double q12 = angle(rng), q3 = angle(rng);
    const Eigen::Vector3d got = chain.forward({q12, 0.0, q3}).translation();
    const double c12 = std::cos(q12), s12 = std::sin(q12), c3 = std::cos(q3), s3 = std::sin(q3);
    const Eigen::Vector3d want((kL1 + kL3) * c12 + kL2 * s12 * s3, (kL1 + kL3) * s12 - kL2 * c12 * s3, kL2 * c3);
    EXPECT_LT((got - want).norm(), 1e-12);
  }
}

TEST(OffsetChain, TheVergenceAxisSitsL1FromTheNeck) {
  const DhChain chain = offset_camera_chain(Convention::kStandard);
  const DhChain modified = offset_camera_chain(Convention::kModified);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> angle(-1.0, 1.0);
  for (int i = 0; i < 30; ++i) {
    const double q0 = angle(rng), q1 = angle(rng), q2 = angle(rng);
    const Eigen::Isometry3d composed = rz(q0) * tr(kL1, 0, 0) * rz(q1) * tr(0, 0, kL2) * rx(q2) * tr(kL3, 0, 0);
    EXPECT_LT((chain.forward({q0, q1, q2}).matrix() - composed.matrix()).norm(), 1e-12);
    // The modified reading, as for the paper's table, tilts the L2 offset too.
    const Eigen::Isometry3d tilted = rz(q0) * tr(kL1, 0, 0) * rz(q1) * rx(q2) * tr(0, 0, kL2) * tr(kL3, 0, 0);
    EXPECT_LT((modified.forward({q0, q1, q2}).matrix() - tilted.matrix()).norm(), 1e-12);
  }
  // Turning only the vergence moves the camera around its own axis, L1 from the neck.
  const Eigen::Vector3d a = chain.forward({0, 0.5, 0}).translation(), b = chain.forward({0, -0.5, 0}).translation();
  EXPECT_NEAR((a - Eigen::Vector3d(kL1, 0, kL2)).norm(), kL3, 1e-12);
  EXPECT_NEAR((b - Eigen::Vector3d(kL1, 0, kL2)).norm(), kL3, 1e-12);
}

TEST(PaperChain, TheOtherCameraIsTheMirrorImage) {
  const Eigen::Vector3d right =
      paper_camera_chain(Convention::kStandard, kL1, kL2, kL3, 1).forward({0, 0, 0}).translation();
  const Eigen::Vector3d left =
      paper_camera_chain(Convention::kStandard, kL1, kL2, kL3, -1).forward({0, 0, 0}).translation();
  EXPECT_LT((right - Eigen::Vector3d(0.18, 0, 0.12)).norm(), 1e-12);
  EXPECT_LT((left - Eigen::Vector3d(-0.18, 0, 0.12)).norm(), 1e-12);
  EXPECT_TRUE(paper_camera_chain(Convention::kStandard).check(3).ok());
  EXPECT_THAT(paper_camera_chain(Convention::kStandard).check(2).message(), ::testing::HasSubstr("joint 2 of 2"));
}

// The cameras' poses the gaze controller and the kinematics node ask for on
// every cycle are the paper chain's, to the last bit, without building it.
TEST(PaperChain, TheCamerasPosesAreTheChainsForwardBitForBit) {
  std::mt19937 random(7);
  const auto uniform = [&](double from, double to) { return std::uniform_real_distribution<double>(from, to)(random); };
  for (int i = 0; i < 200; ++i) {
    const HeadGeometry g{uniform(0.01, 0.3), uniform(0.01, 0.3), uniform(0.0, 0.2)};
    HeadJoints q;
    for (double* joint : {&q.neck, &q.vergence_left, &q.tilt_left, &q.vergence_right, &q.tilt_right})
      *joint = uniform(-1.5, 1.5);
    const Eigen::Isometry3d left =
        paper_camera_chain(Convention::kStandard, g.l1, g.l2, g.l3, -1).forward({q.neck, q.vergence_left, q.tilt_left});
    const Eigen::Isometry3d right = paper_camera_chain(Convention::kStandard, g.l1, g.l2, g.l3, 1)
                                        .forward({q.neck, q.vergence_right, q.tilt_right});
    EXPECT_TRUE(left_camera(g, q).matrix() == left.matrix()) << i;
    EXPECT_TRUE(right_camera(g, q).matrix() == right.matrix()) << i;
  }
}

// Both readings of the paper's table: the modified one, whose tilt also turns
// the L2 offset, has its own tilt formula.
TEST(PointAt, PutsTheTargetOnTheOpticalAxisInFrontInBothReadings) {
  std::mt19937 rng(6);
  std::uniform_real_distribution<double> coord(-2.0, 2.0), ahead(0.4, 3.0);
  const JointLimits limits{-M_PI, M_PI, -1.4, 1.4};
  for (Convention convention : {Convention::kStandard, Convention::kModified})
    for (int side : {1, -1})
      for (int i = 0; i < 100; ++i) {
        const Eigen::Vector3d target(coord(rng), ahead(rng), coord(rng) * 0.5 + 0.12);
        const Result<Pointing> p = point_at(target, kL1, kL2, kL3, side, limits, convention);
        ASSERT_TRUE(p.ok()) << p.error() << " " << target.transpose();
        const Eigen::Isometry3d cam =
            paper_camera_chain(convention, kL1, kL2, kL3, side).forward({p->pan, 0.0, p->tilt});
        const Eigen::Vector3d to = target - cam.translation();
        const Eigen::Vector3d axis = optical_axis(cam);
        EXPECT_GT(to.dot(axis), 0) << "in front";
        EXPECT_LT((to - to.dot(axis) * axis).norm(), 1e-9) << "on the axis";
      }
}

TEST(PointAt, ReportsWhatItCannotReach) {
  const JointLimits limits;
  // Inside the circle the cameras sweep around the neck.
  Result<Pointing> p = point_at({0.05, 0.05, 0.2}, kL1, kL2, kL3, 1, limits);
  EXPECT_FALSE(p.ok());
  EXPECT_THAT(p.error(), ::testing::HasSubstr("circle"));
  // Straight up: a tilt beyond its limit.
  p = point_at({0.18, 0.3, 3.0}, kL1, kL2, kL3, 1, limits);
  EXPECT_FALSE(p.ok());
  EXPECT_THAT(p.error(), ::testing::HasSubstr("tilt"));
  // Behind, beyond the pan's limits.
  p = point_at({0.0, -2.0, 0.12}, kL1, kL2, kL3, 1, limits);
  EXPECT_FALSE(p.ok());
  EXPECT_THAT(p.error(), ::testing::HasSubstr("pan"));
}

TEST(Fixation, MidpointOfTheCommonPerpendicularWithItsResidual) {
  const Eigen::Vector3d target(0.1, 1.5, 0.3);
  const Eigen::Vector3d c1(-0.18, 0, 0.12), c2(0.18, 0, 0.12);
  Fixation f = fixation_point(c1, target - c1, c2, target - c2);
  ASSERT_TRUE(f.valid) << f.why;
  EXPECT_LT((f.point - target).norm(), 1e-12);
  EXPECT_NEAR(f.residual, 0.0, 1e-12);
  // Skew axes: one passes 1 cm above the other.
  f = fixation_point({0, 0, 0}, {1, 0, 0}, {0.5, -1, 0.01}, {0, 1, 0});
  ASSERT_TRUE(f.valid);
  EXPECT_LT((f.point - Eigen::Vector3d(0.5, 0, 0.005)).norm(), 1e-12);
  EXPECT_NEAR(f.residual, 0.01, 1e-12);
  // Parallel axes fixate nothing, and say so.
  f = fixation_point(c1, {0, 1, 0}, c2, {0, 2, 0});
  EXPECT_FALSE(f.valid);
  EXPECT_THAT(f.why, ::testing::HasSubstr("parallel"));
  // Diverging axes meet behind the cameras.
  f = fixation_point(c1, {-0.5, 1, 0}, c2, {0.5, 1, 0});
  EXPECT_FALSE(f.valid);
  EXPECT_THAT(f.why, ::testing::HasSubstr("behind"));
}

TEST(Gaze, BothCamerasFixateTheTargetWithSymmetricVergence) {
  const HeadGeometry g;
  const HeadLimits limits;
  std::mt19937 rng(8);
  std::uniform_real_distribution<double> x(-1.0, 1.0), y(0.8, 4.0), z(-0.5, 0.8);
  for (int i = 0; i < 100; ++i) {
    const Eigen::Vector3d target(x(rng), y(rng), z(rng));
    const Result<HeadJoints> gaze = gaze_at(target, g, limits);
    ASSERT_TRUE(gaze.ok()) << gaze.error() << " " << target.transpose();
    EXPECT_NEAR(gaze->vergence_left, -gaze->vergence_right, 1e-12) << "symmetric";
    const Eigen::Isometry3d l = left_camera(g, *gaze), r = right_camera(g, *gaze);
    const Fixation f = fixation_point(l.translation(), optical_axis(l), r.translation(), optical_axis(r));
    ASSERT_TRUE(f.valid) << f.why;
    EXPECT_LT((f.point - target).norm(), 1e-9);
    EXPECT_LT(f.residual, 1e-9);
  }
  // Too near: the vergence would pass its limit.
  const Result<HeadJoints> near = gaze_at({0.0, 0.25, 0.12}, g, limits);
  EXPECT_FALSE(near.ok());
  EXPECT_THAT(near.error(), ::testing::HasSubstr("vergence"));
}

TEST(Gaze, IndependentModeGivesEachCameraItsOwnTarget) {
  const HeadGeometry g;
  const Eigen::Vector3d a(-0.6, 2.0, 0.3), b(0.9, 2.5, -0.1);
  const Result<HeadJoints> gaze = gaze_each(a, b, g, HeadLimits{});
  ASSERT_TRUE(gaze.ok()) << gaze.error();
  for (const auto& [camera, target] : {std::pair{left_camera(g, *gaze), a}, std::pair{right_camera(g, *gaze), b}}) {
    const Eigen::Vector3d to = target - camera.translation(), axis = optical_axis(camera);
    EXPECT_GT(to.dot(axis), 0);
    EXPECT_LT((to - to.dot(axis) * axis).norm(), 1e-9);
  }
}

TEST(BackProject, PixelAndDepthToACameraPoint) {
  const Eigen::Vector3d p = back_project(420, 140, 2.0, 500, 500, 320, 240);
  EXPECT_LT((p - Eigen::Vector3d(0.4, -0.4, 2.0)).norm(), 1e-12);
}

}  // namespace
}  // namespace saccade::kinematics

namespace saccade {
namespace {

// The kinematics node on a harness: the joints that make both cameras fixate
// a point (gaze_at) give back that point as the fixation, and the cameras'
// poses are the library's.
TEST(KinematicsNode, GivesTheCamerasPosesAndTheFixationPointOfAJointState) {
  auto h = testing::NodeHarness::create(R"(<node plugin="kinematics"/>)").value_or(nullptr);
  ASSERT_TRUE(h);
  const kinematics::HeadGeometry g;
  const Eigen::Vector3d target(0.3, 1.2, 0.25);
  const Result<kinematics::HeadJoints> gaze = kinematics::gaze_at(target, g, kinematics::HeadLimits());
  ASSERT_TRUE(gaze.ok()) << gaze.error();
  auto state = std::make_shared<JointState>();
  const kinematics::HeadJoints& q = *gaze;
  state->position = {q.neck, q.vergence_left, q.tilt_left, q.vergence_right, q.tilt_right};
  h->set("state", state);
  ASSERT_TRUE(h->process().ok());
  auto pose = h->last<HeadPose>("pose");
  ASSERT_TRUE(pose);
  EXPECT_TRUE(pose->fixation_valid);
  EXPECT_NEAR(cv::norm(pose->fixation - cv::Vec3d(target.x(), target.y(), target.z())), 0.0, 1e-6);
  EXPECT_NEAR(pose->fixation_gap, 0.0, 1e-6);
  const Eigen::Vector3d left = kinematics::left_camera(g, q).translation();
  EXPECT_NEAR(cv::norm(pose->left_position - cv::Vec3d(left.x(), left.y(), left.z())), 0.0, 1e-12);
  // The left optical frame's z (the rotation applied to (0, 0, 1)) points at the target.
  const cv::Vec4d r = pose->left_rotation;
  const Eigen::Quaterniond rotation(r[0], r[1], r[2], r[3]);
  EXPECT_NEAR(cv::norm(r), 1.0, 1e-12);
  const Eigen::Vector3d axis = rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis.dot((target - left).normalized()), 1.0, 1e-9);

  // Not a head's joints: counted, nothing emitted.
  h->clear_outputs();
  state = std::make_shared<JointState>();
  state->position = {0.1, 0.2};
  h->set("state", state);
  ASSERT_TRUE(h->process().ok());
  EXPECT_TRUE(h->outputs("pose").empty());
  EXPECT_EQ(h->counter("short_states"), 1u);
}

}  // namespace
}  // namespace saccade
