// Rectified retina sampling for a verging head (plugins/retina/rectified.hpp,
// head_rectification.hpp) and stereo on such retinas. The verging head is
// capture.sim_head's: its cameras are the head model's ideal pinholes, so the
// true projection of any point is known exactly.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "head_rectification.hpp"
#include "rectified.hpp"
#include "retina.hpp"
#include "retina_stereo.hpp"
#include "sim_head.hpp"
#include "support.hpp"

namespace saccade::retina {
namespace {

using kinematics::HeadGeometry;
using kinematics::HeadJoints;

Rectification identity(cv::Size size, double focal) {
  Rectification r;
  r.enabled = true;
  r.camera = {focal, 0, size.width / 2.0, 0, focal, size.height / 2.0, 0, 0, 1};
  r.rectified = r.camera;
  return r;
}

TEST(RectifiedSampling, TheIdentityIsThePlainRetinaBitForBit) {
  const cv::Mat color = cv::imread(test::sample_path("aloeL.jpg"), cv::IMREAD_COLOR);
  ASSERT_FALSE(color.empty()) << test::sample_path("aloeL.jpg");
  cv::Mat gray;
  cv::cvtColor(color, gray, cv::COLOR_BGR2GRAY);
  RetinaConfig config;
  for (const cv::Mat* frame : std::vector<const cv::Mat*>{&gray, &color}) {
    const RectifiedMap map(identity(frame->size(), 900));
    for (cv::Point2d fovea : {cv::Point2d(641, 555), cv::Point2d(3, 4), cv::Point2d(1270, 1100), cv::Point2d(300, 900)}) {
      RetinaSampler sampler(config);
      Retina plain, rectified;
      sampler.sample(*frame, fovea, plain);
      ASSERT_EQ(sample_rectified(config, *frame, map, fovea, rectified), "");
      EXPECT_TRUE(rectified.rectification.enabled);
      EXPECT_EQ(rectified.fovea, plain.fovea);
      ASSERT_EQ(rectified.levels.size(), plain.levels.size());
      for (std::size_t k = 0; k < plain.levels.size(); ++k) {
        EXPECT_EQ(rectified.geometry[k].region, plain.geometry[k].region);
        EXPECT_EQ(cv::norm(rectified.levels[k], plain.levels[k], cv::NORM_INF), 0.0)
            << "level " << k << " at " << fovea << ", " << frame->channels() << " channels";
      }
    }
  }
}

TEST(RectifiedSampling, SourceAndRectifiedPointsMapBackAndForthThroughADistortedLens) {
  Rectification r = identity({640, 480}, 530);
  // A real lens's coefficients (the order of magnitude of OpenCV's sample
  // cameras): radial, tangential and the rational model's denominator.
  const double d[] = {-0.28, 0.09, 0.001, -0.0005, -0.01, 0.02, 0.003, 0.001};
  for (int i = 0; i < 8; ++i) r.distortion[i] = d[i];
  const double a = 10 * CV_PI / 180;
  const cv::Matx33d turn(std::cos(a), 0, std::sin(a), 0, 1, 0, -std::sin(a), 0, std::cos(a));
  for (int i = 0; i < 9; ++i) r.rotation[i] = turn.val[i];
  const RectifiedMap map(r);
  ASSERT_EQ(map.problem(), "");
  for (cv::Point2d p : {cv::Point2d(320, 240), cv::Point2d(20, 30), cv::Point2d(600, 450), cv::Point2d(100, 400)}) {
    const cv::Point2d q = map.to_rectified(p);
    cv::Point2d back;
    ASSERT_TRUE(map.to_source(q, back));
    EXPECT_NEAR(back.x, p.x, 1e-3) << p;
    EXPECT_NEAR(back.y, p.y, 1e-3) << p;
  }
  r.distortion[12] = 0.01;
  EXPECT_NE(RectifiedMap(r).problem().find("tilted"), std::string::npos);
}

// Where the sim's camera (0 left, 1 right) at joints q sees world point p, in
// the retina's pixel convention (pixel k spans [k, k + 1)).
cv::Point2d project(const capture::SimHeadConfig& c, int camera, const HeadJoints& q, const Eigen::Vector3d& p,
                    double* depth = nullptr) {
  const Eigen::Isometry3d pose = kinematics::optical_frame(camera == 0 ? kinematics::left_camera(c.geometry, q)
                                                                       : kinematics::right_camera(c.geometry, q));
  const Eigen::Vector3d x = pose.inverse() * p;
  if (depth) *depth = x.z();
  return {c.size.width / 2.0 + c.focal_px * x.x() / x.z() + 0.5, c.size.height / 2.0 + c.focal_px * x.y() / x.z() + 0.5};
}

TEST(HeadRectification, AtTheJointsZeroTheModelsParallelCamerasNeedNoTurn) {
  const capture::SimHeadConfig c;
  PairRectification pair;
  ASSERT_EQ(rectify_pair(model_calibration(c.size, c.focal_px, c.geometry), c.geometry, HeadJoints{}, pair), "");
  for (int i = 0; i < 9; ++i) {
    EXPECT_NEAR(pair.left.rotation[i], i % 4 == 0 ? 1.0 : 0.0, 1e-9);
    EXPECT_NEAR(pair.right.rotation[i], i % 4 == 0 ? 1.0 : 0.0, 1e-9);
  }
  EXPECT_GT(pair.left.baseline, 0.1);
}

// Points on a verging, tilting head: in the source images their rows differ
// (vertical disparity, which the matcher cannot search); on the rectified
// grids they agree, and the rectified disparity gives their depth.
TEST(HeadRectification, RowsAreEpipolarLinesAtAnyVergenceAndDisparityGivesDepth) {
  const capture::SimHeadConfig c;
  const kinematics::HeadCalibration calibration = model_calibration(c.size, c.focal_px, c.geometry);
  for (double vergence : {-0.35, -0.15, 0.0, 0.2, 0.35}) {
    for (double tilt : {0.0, 0.2}) {
      const HeadJoints q{0.1, vergence, tilt, -vergence, tilt};
      PairRectification pair;
      ASSERT_EQ(rectify_pair(calibration, c.geometry, q, pair), "");
      const RectifiedMap left(pair.left), right(pair.right);
      double worst_source_rows = 0;
      int seen = 0;
      for (double x : {-0.6, -0.2, 0.0, 0.3, 0.7}) {
        for (double z : {-0.3, 0.0, 0.4}) {
          for (double distance : {0.6, 1.5, 3.0}) {
            // In front of the head, turned by the neck so that both cameras see it.
            const Eigen::Vector3d p(x * distance / 1.5, distance, c.geometry.l2 + z * distance / 1.5 + tilt * distance);
            double depth_left = 0, depth_right = 0;
            const cv::Point2d pl = project(c, 0, q, p, &depth_left), pr = project(c, 1, q, p, &depth_right);
            if (depth_left <= 0.1 || depth_right <= 0.1) continue;
            const cv::Rect image(0, 0, c.size.width, c.size.height);
            if (!image.contains(pl) || !image.contains(pr)) continue;
            ++seen;
            worst_source_rows = std::max(worst_source_rows, std::abs(pl.y - pr.y));
            const cv::Point2d rl = left.to_rectified(pl), rr = right.to_rectified(pr);
            EXPECT_NEAR(rl.y, rr.y, 0.01) << "vergence " << vergence << " tilt " << tilt << " point " << p.transpose();
            // Depth along the rectified left axis: the point in the left camera
            // frame, turned into the rectified frame.
            const cv::Matx33d r1(pair.left.rotation.val);
            const Eigen::Isometry3d pose = kinematics::optical_frame(kinematics::left_camera(c.geometry, q));
            const Eigen::Vector3d in_left = pose.inverse() * p;
            const cv::Vec3d in_rectified = r1 * cv::Vec3d(in_left.x(), in_left.y(), in_left.z());
            const double disparity = rl.x - rr.x;
            ASSERT_GT(disparity, 0);
            EXPECT_NEAR(pair.left.rectified[0] * pair.left.baseline / disparity, in_rectified[2], 1e-6 * in_rectified[2]);
          }
        }
      }
      EXPECT_GT(seen, 8) << "vergence " << vergence;
      if (vergence != 0) {
        EXPECT_GT(worst_source_rows, 0.5) << "vergence " << vergence << " tilt " << tilt;
      }
    }
  }
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

// A verging head fixating a target: both retinas rectified for the joints,
// the stereo's fixation disparity gives the target's depth.
struct VergingScene {
  capture::SimHeadConfig config;
  HeadJoints joints;
  cv::Mat left, right;
  capture::TargetView left_view, right_view;
  Eigen::Vector3d target;
};

VergingScene verge_on(double distance, double lateral) {
  VergingScene s;
  s.config.target_distance = distance;
  s.config.target_start = lateral;
  s.config.target_speed = 0;
  const cv::Mat wall = cv::imread(test::sample_path("aloeL.jpg"), cv::IMREAD_COLOR);
  capture::SimHead head(wall, s.config);
  s.target = head.target_at(0);
  const kinematics::Gaze gaze = kinematics::gaze_at(s.target, s.config.geometry, kinematics::HeadLimits{});
  s.joints = gaze.joints;
  cv::Mat left_bgr, right_bgr;
  s.left_view = head.render(0, s.joints, 0, left_bgr);
  s.right_view = head.render(1, s.joints, 0, right_bgr);
  cv::cvtColor(left_bgr, s.left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, s.right, cv::COLOR_BGR2GRAY);
  return s;
}

Retina rectified_retina(const cv::Mat& frame, int camera, const Rectification& r, cv::Point2d fovea) {
  Retina out;
  EXPECT_EQ(sample_rectified(RetinaConfig{}, frame, RectifiedMap(r), fovea, out), "");
  auto image = std::make_shared<Image>();
  image->mat = frame;
  image->camera_id = camera;
  out.source = image;
  out.camera_id = camera;
  return out;
}

TEST(RectifiedStereo, AVergingHeadMeasuresItsTargetsDepthWithinOnePercent) {
  for (double distance : {0.6, 1.2, 1.8}) {
    for (double lateral : {-0.25, 0.0, 0.2}) {
      const VergingScene s = verge_on(distance, lateral);
      ASSERT_TRUE(s.left_view.visible && s.right_view.visible);
      PairRectification pair;
      ASSERT_EQ(rectify_pair(model_calibration(s.config.size, s.config.focal_px, s.config.geometry),
                             s.config.geometry, s.joints, pair),
                "");
      // The sim's target centre is in OpenCV's convention; the retina's is half a pixel on.
      const cv::Point2d at(s.left_view.center.x + 0.5, s.left_view.center.y + 0.5);
      const Retina left = rectified_retina(s.left, 0, pair.left, at);
      const Retina right =
          rectified_retina(s.right, 1, pair.right, {s.right_view.center.x + 0.5, s.right_view.center.y + 0.5});
      stereo::RetinaStereoConfig config;
      config.vergence = true;
      config.max_disparity = 256;
      stereo::RetinaStereo matcher(config);
      std::vector<stereo::LevelDisparity> levels;
      ASSERT_EQ(matcher.run(left, right, levels), "");
      const double disparity = matcher.fixation().disparity;
      ASSERT_GT(disparity, 0) << "distance " << distance << " lateral " << lateral;
      // The truth: the target's depth along the rectified left camera's axis.
      const Eigen::Isometry3d pose =
          kinematics::optical_frame(kinematics::left_camera(s.config.geometry, s.joints));
      const Eigen::Vector3d p = pose.inverse() * s.target;
      const cv::Vec3d in_rectified = cv::Matx33d(pair.left.rotation.val) * cv::Vec3d(p.x(), p.y(), p.z());
      const double depth = pair.left.rectified[0] * pair.left.baseline / disparity;
      if (std::getenv("SACCADE_TEST_VERBOSE")) {
        std::printf("distance %.2f lateral %.2f: f %.1f B %.3f truth d %.2f found %.2f; per level", distance, lateral,
                    pair.left.rectified[0], pair.left.baseline,
                    pair.left.rectified[0] * pair.left.baseline / in_rectified[2], disparity);
        for (double d : matcher.fixation().per_level) std::printf(" %.1f", d);
        const cv::Point2d rl = RectifiedMap(pair.left).to_rectified(at);
        std::printf("; left fovea %d,%d (target %.1f,%.1f)\n", left.fovea.x, left.fovea.y, rl.x, rl.y);
      }
      EXPECT_NEAR(depth, in_rectified[2], 0.01 * in_rectified[2])
          << "distance " << distance << " lateral " << lateral << " vergence " << s.joints.vergence_left;
    }
  }
}

}  // namespace
}  // namespace saccade::retina
