// Rectified retina sampling for a verging head (plugins/retina/rectified.hpp,
// head_rectification.hpp) and stereo on such retinas. The verging head is
// capture.sim_head's: its cameras are the head model's ideal pinholes, so the
// true projection of any point is known exactly.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <filesystem>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "depth.hpp"
#include "camera_calibration.hpp"
#include "head_rectification.hpp"
#include "rectified.hpp"
#include "retina.hpp"
#include "retina_stereo.hpp"
#include "sim_head.hpp"
#include "saccade/testing.hpp"
#include "stereo_truth.hpp"
#include "support.hpp"

namespace saccade::retina {
namespace {

namespace fs = std::filesystem;
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
    for (cv::Point2d fovea :
         {cv::Point2d(641, 555), cv::Point2d(3, 4), cv::Point2d(1270, 1100), cv::Point2d(300, 900)}) {
      RetinaSampler sampler(config);
      Retina plain, rectified;
      sampler.sample(*frame, fovea, plain);
      ASSERT_TRUE(sample_rectified(config, *frame, map, fovea, rectified).ok());
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
  ASSERT_TRUE(map.status().ok()) << map.status().message();
  for (cv::Point2d p : {cv::Point2d(320, 240), cv::Point2d(20, 30), cv::Point2d(600, 450), cv::Point2d(100, 400)}) {
    const cv::Point2d q = map.to_rectified(p);
    cv::Point2d back;
    ASSERT_TRUE(map.to_source(q, back));
    EXPECT_NEAR(back.x, p.x, 1e-3) << p;
    EXPECT_NEAR(back.y, p.y, 1e-3) << p;
  }
  r.distortion[12] = 0.01;
  EXPECT_THAT(RectifiedMap(r).status().message(), ::testing::HasSubstr("tilted"));
}

// Where the sim's camera (0 left, 1 right) at joints q sees world point p, in
// the retina's pixel convention (pixel k spans [k, k + 1)).
cv::Point2d project(const capture::SimHeadConfig& c, int camera, const HeadJoints& q, const Eigen::Vector3d& p,
                    double* depth = nullptr) {
  const Eigen::Isometry3d pose = kinematics::optical_frame(camera == 0 ? kinematics::left_camera(c.geometry, q)
                                                                       : kinematics::right_camera(c.geometry, q));
  const Eigen::Vector3d x = pose.inverse() * p;
  if (depth) *depth = x.z();
  return {c.size.width / 2.0 + c.focal_px * x.x() / x.z() + 0.5,
          c.size.height / 2.0 + c.focal_px * x.y() / x.z() + 0.5};
}

TEST(HeadRectification, AtTheJointsZeroTheModelsParallelCamerasNeedNoTurn) {
  const capture::SimHeadConfig c;
  const Result<PairRectification> rectified =
      rectify_pair(model_calibration(c.size, c.focal_px, c.geometry), c.geometry, HeadJoints{});
  ASSERT_TRUE(rectified.ok()) << rectified.error();
  const PairRectification& pair = *rectified;
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
      const Result<PairRectification> rectified = rectify_pair(calibration, c.geometry, q);
      ASSERT_TRUE(rectified.ok()) << rectified.error();
      const PairRectification& pair = *rectified;
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
            EXPECT_NEAR(pair.left.rectified[0] * pair.left.baseline / disparity, in_rectified[2],
                        1e-6 * in_rectified[2]);
          }
        }
      }
      EXPECT_GT(seen, 8) << "vergence " << vergence;
      if (vergence != 0) { EXPECT_GT(worst_source_rows, 0.5) << "vergence " << vergence << " tilt " << tilt; }
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
  const Result<HeadJoints> gaze = kinematics::gaze_at(s.target, s.config.geometry, kinematics::HeadLimits{});
  EXPECT_TRUE(gaze.ok()) << gaze.error();
  if (gaze.ok()) s.joints = *gaze;
  cv::Mat left_bgr, right_bgr;
  s.left_view = head.render(0, s.joints, 0, left_bgr);
  s.right_view = head.render(1, s.joints, 0, right_bgr);
  cv::cvtColor(left_bgr, s.left, cv::COLOR_BGR2GRAY);
  cv::cvtColor(right_bgr, s.right, cv::COLOR_BGR2GRAY);
  return s;
}

Retina rectified_retina(const cv::Mat& frame, int camera, const Rectification& r, cv::Point2d fovea) {
  Retina out;
  const Status sampled = sample_rectified(RetinaConfig{}, frame, RectifiedMap(r), fovea, out);
  EXPECT_TRUE(sampled.ok()) << sampled.message();
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
      const Result<PairRectification> rectified = rectify_pair(
          model_calibration(s.config.size, s.config.focal_px, s.config.geometry), s.config.geometry, s.joints);
      ASSERT_TRUE(rectified.ok()) << rectified.error();
      const PairRectification& pair = *rectified;
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
      const Status matched = matcher.run(left, right, levels);
      ASSERT_TRUE(matched.ok()) << matched.message();
      const double disparity = matcher.fixation().disparity;
      ASSERT_GT(disparity, 0) << "distance " << distance << " lateral " << lateral;
      // The truth: the target's depth along the rectified left camera's axis.
      const Eigen::Isometry3d pose = kinematics::optical_frame(kinematics::left_camera(s.config.geometry, s.joints));
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
      // The fixated point in metres, in the left camera's own frame: the target's centre.
      const stereo::LocatedPoint point = stereo::locate(
          stereo::depth_model(left, {}),
          cv::Point2d(left.geometry.back().region.x + 16.0, left.geometry.back().region.y + 12.0), disparity, 0.3);
      ASSERT_TRUE(point.valid);
      EXPECT_NEAR(point.depth, depth, 1e-9);
      EXPECT_LT(cv::norm(point.point - cv::Vec3d(p.x(), p.y(), p.z())), 0.01 * p.z() + 0.003)
          << point.point << " against " << p.transpose();
      EXPECT_NEAR(point.depth_sigma, depth * depth / (pair.left.rectified[0] * pair.left.baseline) * 0.3, 1e-12);
      EXPECT_NEAR(depth, in_rectified[2], 0.01 * in_rectified[2])
          << "distance " << distance << " lateral " << lateral << " vergence " << s.joints.vergence_left;
    }
  }
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

std::shared_ptr<Image> frame_of(int camera) {
  auto image = std::make_shared<Image>();
  image->mat = test::random_image({320, 240}, 5 + camera, CV_8UC1);
  image->camera_id = camera;
  return image;
}

TEST(RectifiedRetinaNode, AtTheJointsZeroTheModelHeadsRetinaIsThePlainOne) {
  auto created = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/></node>)");
  ASSERT_TRUE(created.ok()) << created.error();
  auto rectified = std::move(created).value();
  auto plain = testing::NodeHarness::create(R"(<node plugin="retina"/>)").value_or(nullptr);
  const auto image = frame_of(0);
  rectified->set("image", image);
  plain->set("image", image);
  ASSERT_TRUE(rectified->process().ok());
  ASSERT_TRUE(plain->process().ok());
  const auto a = rectified->last<Retina>("retina");
  const auto b = plain->last<Retina>("retina");
  EXPECT_TRUE(a->rectification.enabled);
  EXPECT_FALSE(b->rectification.enabled);
  for (std::size_t k = 0; k < b->levels.size(); ++k)
    EXPECT_EQ(cv::norm(a->levels[k], b->levels[k], cv::NORM_INF), 0.0) << "level " << k;
}

TEST(RectifiedRetinaNode, TheJointsTurnTheGridAndBothCamerasShareTheRectifiedCamera) {
  auto left = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/></node>)")
                  .value_or(nullptr);
  auto right = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/></node>)")
                   .value_or(nullptr);
  ASSERT_TRUE(left && right);
  auto joints = std::make_shared<JointState>();
  joints->position = {0.1, 0.2, 0.05, -0.2, 0.05};
  left->set("joints", joints);
  right->set("joints", joints);
  left->set("image", frame_of(0));
  right->set("image", frame_of(1));
  ASSERT_TRUE(left->process().ok());
  ASSERT_TRUE(right->process().ok());
  const Rectification& l = left->last<Retina>("retina")->rectification;
  const Rectification& r = right->last<Retina>("retina")->rectification;
  EXPECT_EQ(l.rectified, r.rectified);
  EXPECT_GT(l.baseline, 0.1);
  EXPECT_GT(std::abs(l.rotation[2]), 0.05) << "the left camera turned by its vergence is turned back";
  EXPECT_NE(l.rotation, r.rotation);
}

TEST(RectifiedRetinaNode, RefusesACalibrationForAnotherImageSizeAndAThirdCamera) {
  const std::string path = (std::filesystem::temp_directory_path() / "saccade_rectified_640.yml").string();
  const capture::SimHeadConfig c;
  ASSERT_TRUE(kinematics::write_head_calibration(path, model_calibration({640, 480}, 554, c.geometry)).ok());
  auto h = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/>)"
                                        R"(<param name="calibration" value=")" +
                                        path + R"("/></node>)")
               .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  h->set("image", frame_of(0));
  Status s = h->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr(path));
  EXPECT_THAT(s.message(), ::testing::HasSubstr("640"));
  EXPECT_THAT(s.message(), ::testing::HasSubstr("320"));
  std::filesystem::remove(path);

  auto model = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/></node>)")
                   .value_or(nullptr);
  ASSERT_NE(model, nullptr);
  model->set("image", frame_of(2));
  s = model->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("camera_id is 2"));

  const auto no_file = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/>)"
                                                    R"(<param name="calibration" value="/no/such/head.yml"/></node>)");
  EXPECT_FALSE(no_file.ok());
  EXPECT_THAT(no_file.error(), ::testing::HasSubstr("/no/such/head.yml"));
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

TEST(HeadRectification, TheRotationsAreOpenCVsStereoRectifys) {
  const capture::SimHeadConfig c;
  const kinematics::HeadCalibration calibration = model_calibration(c.size, c.focal_px, c.geometry);
  for (const HeadJoints& q : {HeadJoints{0.1, 0.3, 0.1, -0.25, 0.05}, HeadJoints{-0.2, -0.1, -0.3, 0.2, 0.1},
                              HeadJoints{0, 0.35, 0, -0.35, 0}}) {
    const Result<PairRectification> rectified = rectify_pair(calibration, c.geometry, q);
    ASSERT_TRUE(rectified.ok()) << rectified.error();
    const PairRectification& pair = *rectified;
    cv::Mat r1, r2, p1, p2, reprojection;
    cv::stereoRectify(cv::Mat(calibration.left_matrix), cv::noArray(), cv::Mat(calibration.right_matrix), cv::noArray(),
                      c.size, cv::Mat(pair.rotation), cv::Mat(pair.translation), r1, r2, p1, p2, reprojection,
                      cv::CALIB_ZERO_DISPARITY);
    for (int i = 0; i < 9; ++i) {
      EXPECT_NEAR(pair.left.rotation[i], r1.at<double>(i / 3, i % 3), 1e-9);
      EXPECT_NEAR(pair.right.rotation[i], r2.at<double>(i / 3, i % 3), 1e-9);
    }
  }
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

// The stereo node on a verging head's rectified retinas: the fixated point in
// metres in the left camera's frame and in the head's, and a gaze request to
// verge on it.
TEST(RectifiedStereoNode, GivesTheFixatedPointInTheHeadsFrameAndAsksTheHeadToVergeOnIt) {
  const VergingScene s = verge_on(0.9, 0.15);
  const Result<PairRectification> rectified =
      rectify_pair(model_calibration(s.config.size, s.config.focal_px, s.config.geometry), s.config.geometry, s.joints);
  ASSERT_TRUE(rectified.ok()) << rectified.error();
  const PairRectification& pair = *rectified;
  auto left = std::make_shared<Retina>(
      rectified_retina(s.left, 0, pair.left, {s.left_view.center.x + 0.5, s.left_view.center.y + 0.5}));
  auto right = std::make_shared<Retina>(
      rectified_retina(s.right, 1, pair.right, {s.right_view.center.x + 0.5, s.right_view.center.y + 0.5}));
  auto created = testing::NodeHarness::create(R"(<node plugin="stereo"/>)");
  ASSERT_TRUE(created.ok()) << created.error();
  auto h = std::move(created).value();
  // The head's pose as the kinematics node gives it.
  const Eigen::Isometry3d camera = kinematics::optical_frame(kinematics::left_camera(s.config.geometry, s.joints));
  const Eigen::Quaterniond q(camera.linear());
  auto pose = std::make_shared<HeadPose>();
  pose->left_position = {camera.translation().x(), camera.translation().y(), camera.translation().z()};
  pose->left_rotation = {q.w(), q.x(), q.y(), q.z()};
  h->set("left", left);
  h->set("right", right);
  h->set("head", pose);
  ASSERT_TRUE(h->process().ok());
  const auto f = h->last<StereoFixation>("fixation");
  ASSERT_NE(f, nullptr);
  EXPECT_TRUE(f->rectified);
  EXPECT_TRUE(f->confirmed);
  ASSERT_GT(f->depth, 0);
  const Eigen::Vector3d in_camera = camera.inverse() * s.target;
  EXPECT_LT(cv::norm(f->point - cv::Vec3d(in_camera.x(), in_camera.y(), in_camera.z())), 0.01 * in_camera.z())
      << f->point;
  ASSERT_TRUE(f->point_head_valid);
  EXPECT_LT(cv::norm(f->point_head - cv::Vec3d(s.target.x(), s.target.y(), s.target.z())), 0.01 * in_camera.z())
      << f->point_head << " against " << s.target.transpose();
  EXPECT_GT(f->depth_sigma, 0);
  EXPECT_LT(f->depth_sigma, 0.01 * f->depth);
  const auto gaze = h->last<GazeRequest>("gaze");
  ASSERT_NE(gaze, nullptr);
  EXPECT_EQ(gaze->kind, GazeRequest::Kind::kPoint);
  EXPECT_EQ(gaze->point, f->point_head);
  // Without the head's pose: the point in the camera's frame, no gaze.
  auto alone = testing::NodeHarness::create(R"(<node plugin="stereo"/>)").value_or(nullptr);
  ASSERT_NE(alone, nullptr);
  alone->set("left", left);
  alone->set("right", right);
  ASSERT_TRUE(alone->process().ok());
  EXPECT_FALSE(alone->last<StereoFixation>("fixation")->point_head_valid);
  EXPECT_EQ(alone->last<GazeRequest>("gaze"), nullptr);
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

TEST(RectifiedBadInput, AJointThatIsNotANumberAndAStereoCalibrationForOtherImagesAreErrors) {
  auto h = testing::NodeHarness::create(R"(<node plugin="retina"><param name="rectify" value="true"/></node>)")
               .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto joints = std::make_shared<JointState>();
  joints->position = {0, std::nan(""), 0, 0, 0};
  h->set("joints", joints);
  h->set("image", frame_of(0));
  Status s = h->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr("vergence_left"));

  // saccade calibrate's file for 640x480 images; the stereo on 320x240 frames.
  const std::string path = (std::filesystem::temp_directory_path() / "saccade_stereo_640.yml").string();
  ASSERT_TRUE(
      kinematics::write_head_calibration(path, model_calibration({640, 480}, 554, capture::SimHeadConfig{}.geometry))
          .ok());
  auto created = testing::NodeHarness::create(R"(<node plugin="stereo"><param name="calibration" value=")" + path +
                                              R"("/></node>)");
  ASSERT_TRUE(created.ok()) << created.error();
  auto stereo = std::move(created).value();
  RetinaSampler sampler(RetinaConfig{});
  auto left = std::make_shared<Retina>(), right = std::make_shared<Retina>();
  sampler.sample(frame_of(0)->mat, {160, 120}, *left);
  sampler.sample(frame_of(1)->mat, {160, 120}, *right);
  stereo->set("left", left);
  stereo->set("right", right);
  s = stereo->process();
  ASSERT_TRUE(s.is_error());
  EXPECT_THAT(s.message(), ::testing::HasSubstr(path));
  EXPECT_THAT(s.message(), ::testing::HasSubstr("640x480"));
  EXPECT_THAT(s.message(), ::testing::HasSubstr("320x240"));
  std::filesystem::remove(path);
}

}  // namespace
}  // namespace saccade::retina

namespace saccade::retina {
namespace {

// A real stereo rig: opencv-doc's 13 chessboard pairs (left01..right14, 640x480),
// calibrated as `saccade calibrate` does, each pair sampled on the rectified
// grid and matched with the stereo's defaults. The board's corners, found in
// both images and taken to the rectified images, give the truth
// (bench::BoardDisparity, as `make bench-stereo` scores these pairs): they
// lie on one row in both (the rectification), and their disparities,
// interpolated across the board's squares, give the disparity under every
// fovea pixel. The left fovea sits on the board's middle; the right one on
// the same rectified point, as parallel cameras would look: the matcher
// finds the disparity itself.
bench::BoardDisparity board_disparity(const kinematics::BoardView& left, const kinematics::BoardView& right,
                                      cv::Size corners, const PairRectification& pair) {
  // The retina's pixel centres lie half a pixel on from OpenCV's.
  const auto rectified = [](const std::vector<cv::Point2f>& points, const Rectification& r) {
    const RectifiedMap map(r);
    std::vector<cv::Point2f> out;
    for (const cv::Point2f& p : points)
      out.emplace_back(cv::Point2f(map.to_rectified(cv::Point2d(p) + cv::Point2d(0.5, 0.5)) - cv::Point2d(0.5, 0.5)));
    return out;
  };
  return bench::BoardDisparity(rectified(left.points, pair.left), rectified(right.points, pair.right), corners);
}

TEST(RealStereoRig, RectifiedRetinasMatchTheChessboardPairsDisparity) {
  kinematics::CalibrationOptions options;
  options.board.size = cv::Size(9, 6);
  options.board.square = 1.0;
  // The sample's list of the pairs; their gray images read once, for the calibration and the matcher.
  Result<std::vector<kinematics::ImagePair>> listed =
      kinematics::read_image_list(test::sample_path("stereo_calib.xml"));
  ASSERT_TRUE(listed.ok()) << listed.error();
  std::vector<kinematics::ImagePair> pairs = std::move(listed).value();
  ASSERT_EQ(pairs.size(), 13u);
  for (kinematics::ImagePair& p : pairs) {
    p.left_image = cv::imread(p.left, cv::IMREAD_GRAYSCALE);
    p.right_image = cv::imread(p.right, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(p.left_image.empty() || p.right_image.empty()) << p.left;
  }
  const kinematics::CalibrationResult calibrated = kinematics::calibrate_head(pairs, options);
  ASSERT_TRUE(calibrated.status.ok()) << calibrated.status.message();
  const Result<PairRectification> rectified =
      rectify_pair(calibrated.calibration, kinematics::HeadGeometry{}, kinematics::HeadJoints{});
  ASSERT_TRUE(rectified.ok()) << rectified.error();
  const PairRectification& pair = *rectified;
  int fixations_within_1px = 0, given = 0, right = 0, known = 0, corners = 0;
  double row_error_sum = 0;
  for (const kinematics::ImagePair& files : pairs) {
    const cv::Mat &left_image = files.left_image, &right_image = files.right_image;
    const kinematics::BoardView left_board = kinematics::find_board(left_image, options.board);
    const kinematics::BoardView right_board = kinematics::find_board(right_image, options.board);
    ASSERT_TRUE(left_board.found() && right_board.found()) << files.left;
    ASSERT_EQ(left_board.points.size(), right_board.points.size());
    const bench::BoardDisparity truth = board_disparity(left_board, right_board, options.board.size, pair);
    // Rectified, a corner lies on one row in both images (to the calibration's accuracy).
    EXPECT_LT(truth.row_error_max(), 4.0) << files.left;
    row_error_sum += truth.row_error_mean() * static_cast<double>(left_board.points.size());
    corners += static_cast<int>(left_board.points.size());
    // (Retina coordinates from here on: OpenCV's plus half a pixel.)
    const cv::Point2d middle = truth.on_board(4, 2.5) + cv::Point2d(0.5, 0.5);

    cv::Point2d left_fovea, right_fovea;
    ASSERT_TRUE(RectifiedMap(pair.left).to_source(middle, left_fovea));
    ASSERT_TRUE(RectifiedMap(pair.right).to_source(middle, right_fovea));
    const Retina left = rectified_retina(left_image, 0, pair.left, left_fovea);
    const Retina right_retina = rectified_retina(right_image, 1, pair.right, right_fovea);
    stereo::RetinaStereo matcher{stereo::RetinaStereoConfig{}};
    std::vector<stereo::LevelDisparity> levels;
    const Status matched = matcher.run(left, right_retina, levels);
    ASSERT_TRUE(matched.ok()) << matched.message();
    const double fixation = matcher.fixation().disparity;
    const LevelGeometry& fovea = left.geometry.back();
    const cv::Point2d centre(fovea.region.x + fovea.region.width / 2.0, fovea.region.y + fovea.region.height / 2.0);
    const double expected = truth.at(centre - cv::Point2d(0.5, 0.5));
    fixations_within_1px += std::abs(fixation - expected) <= 1.0;
    // The fovea's pixels on the board (all of them: it sits on the board's middle).
    const cv::Mat& d = levels.back().disparity;
    int pair_given = 0, pair_right = 0;
    for (int y = 0; y < d.rows; ++y)
      for (int x = 0; x < d.cols; ++x) {
        const cv::Point2d at(fovea.region.x + x * fovea.step_x, fovea.region.y + y * fovea.step_y);
        const float v = d.at<float>(y, x);
        ++known;
        if (v < 0) continue;
        ++pair_given;
        pair_right += std::abs(v - truth.at(at)) <= 2.0;
      }
    given += pair_given, right += pair_right;
    if (std::getenv("SACCADE_TEST_VERBOSE")) {
      std::printf("  per level");
      for (double v : matcher.fixation().per_level) std::printf(" %.1f", v);
      std::printf("\n");
    }
    std::printf("%s: rows within %.2f px; fixation %.2f, truth %.2f (%s); fovea %d of %d given, %d within 2 px\n",
                fs::path(files.left).filename().c_str(), truth.row_error_max(), fixation, expected,
                matcher.fixation().confirmed ? "confirmed" : "unconfirmed", pair_given, d.rows * d.cols, pair_right);
  }
  const double density = static_cast<double>(given) / known,
               bad2 = 1.0 - static_cast<double>(right) / std::max(given, 1);
  std::printf(
      "corners' rows within %.3f px on average; fixations within 1 px: %d of %zu; fovea density %.3f, bad-2 "
      "%.3f\n",
      row_error_sum / corners, fixations_within_1px, pairs.size(), density, bad2);
  EXPECT_LT(row_error_sum / corners, 0.5) << "the rectification's rows";
  // Measured: 10 of 13 (left07's goes to the wall, 13.2 px for 110.4;
  // left12's to 75.0 for 154.4; left06's is 2.4 px off), density 0.795,
  // bad-2 0.359 (left02's fixation is right but unconfirmed, and its pixels
  // follow the level outside, which saw the wall: none right). OpenCV's SGBM
  // on these pairs: make bench-stereo STEREO_ARGS="--pair chessboards".
  EXPECT_GE(fixations_within_1px, 9);
  EXPECT_GE(density, 0.75);
  EXPECT_LE(bad2, 0.4);
}

}  // namespace
}  // namespace saccade::retina
