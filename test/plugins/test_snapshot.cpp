#include <gtest/gtest.h>

#include <filesystem>
#include <limits>

#include <opencv2/imgcodecs.hpp>

#include "mosaic.hpp"
#include "support.hpp"

namespace saccade {
namespace {

namespace fs = std::filesystem;

TEST(Snapshot, WritesMosaicsForImagesRetinasAndFeatureMaps) {
  fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "snapshot";
  fs::remove_all(dir);
  auto h = testing::NodeHarness::create("<node plugin=\"snapshot\" name=\"s\"><param name=\"dir\" value=\"" +
                                        dir.string() + "\"/><param name=\"every\" value=\"2\"/></node>")
               .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto image = std::make_shared<Image>();
  image->mat = cv::Mat(120, 160, CV_8UC1, cv::Scalar(100));
  auto retina = std::make_shared<Retina>();
  retina->source = image;
  retina->source_size = image->mat.size();
  for (int k = 0; k < 3; ++k) {
    retina->levels.push_back(cv::Mat(24, 32, CV_8UC1, cv::Scalar(50 * k)));
    int w = 160 - k * 64, hgt = 120 - k * 48;
    retina->geometry.push_back({cv::Rect((160 - w) / 2, (120 - hgt) / 2, w, hgt), w / 32.0, hgt / 24.0});
  }
  auto maps = std::make_shared<FeatureMaps>();
  maps->retina = retina;
  maps->names = {"sobel_x"};
  maps->maps = {{cv::Mat(24, 32, CV_32F, cv::Scalar(-3)), cv::Mat(24, 32, CV_32F, cv::Scalar(4)),
                 cv::Mat(24, 32, CV_32F, cv::Scalar(0))}};
  int64_t frame = 0;
  for (MessagePtr m : std::vector<MessagePtr>{image, retina, maps}) {
    auto copy = m;
    const_cast<Message*>(copy.get())->frame_id = frame;
    frame += 2;
    h->set("in", copy);
    ASSERT_TRUE(h->process().ok());
  }
  for (const char* f : {"s_000000_frame.png", "s_000002_source.png", "s_000002_levels.png", "s_000002_foveated.png",
                        "s_000004_features.png", "s_000004_sobel_x.png", "s_000004_source.png"})
    EXPECT_TRUE(fs::exists(dir / f)) << f;
  cv::Mat fov = cv::imread((dir / "s_000002_foveated.png").string());
  EXPECT_EQ(fov.size(), cv::Size(160, 120));
  // Frame 3 is skipped by every=2.
  auto odd = std::make_shared<Image>(*image);
  odd->frame_id = 3;
  h->set("in", odd);
  ASSERT_TRUE(h->process().ok());
  EXPECT_FALSE(fs::exists(dir / "s_000003_frame.png"));
}

TEST(Snapshot, DisparityIsColorMappedAndSavedAs16Bit) {
  fs::path dir = fs::path(SACCADE_BINARY_DIR) / "test_out" / "snapshot_disparity";
  fs::remove_all(dir);
  auto h = testing::NodeHarness::create("<node plugin=\"snapshot\" name=\"d\"><param name=\"dir\" value=\"" +
                                        dir.string() + "\"/><param name=\"disparity_png16\" value=\"true\"/></node>")
               .value_or(nullptr);
  ASSERT_NE(h, nullptr);
  auto maps = std::make_shared<FeatureMaps>();
  cv::Mat d(24, 32, CV_32F, cv::Scalar(12.5f));
  d(cv::Rect(0, 0, 4, 4)).setTo(-1);  // invalid
  d.at<float>(5, 5) = 0.0f;           // a valid 0
  d.at<float>(6, 6) = 300.25f;        // beyond 256
  d.at<float>(7, 7) = 2000.0f;        // beyond what 16 bits hold at 1/64 px
  d.at<float>(8, 8) = std::numeric_limits<float>::quiet_NaN();
  d.at<float>(9, 9) = 17.3f;  // not a multiple of 1/64
  maps->names = {"disparity_lr"};
  maps->maps = {{d}};
  h->set("in", maps);
  ASSERT_TRUE(h->process().ok());
  cv::Mat png16 = cv::imread((dir / "d_000000_disparity_lr_L0_16.png").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(png16.type(), CV_16UC1);
  EXPECT_EQ(png16.at<uint16_t>(10, 10), 12.5 * 64 + 1);
  EXPECT_EQ(png16.at<uint16_t>(1, 1), 0) << "invalid";
  EXPECT_EQ(png16.at<uint16_t>(5, 5), 1) << "a valid 0 is not invalid";
  EXPECT_EQ(png16.at<uint16_t>(6, 6), 300.25 * 64 + 1) << "no saturation at 256";
  EXPECT_EQ(png16.at<uint16_t>(7, 7), 65535) << "clamped";
  EXPECT_EQ(png16.at<uint16_t>(8, 8), 0) << "NaN is invalid";
  const cv::Mat back = snapshot::disparity_from_png16(png16);
  EXPECT_FLOAT_EQ(back.at<float>(10, 10), 12.5f);
  EXPECT_FLOAT_EQ(back.at<float>(5, 5), 0.0f);
  EXPECT_FLOAT_EQ(back.at<float>(1, 1), -1.0f);
  EXPECT_NEAR(back.at<float>(9, 9), 17.3f, 0.5 / 64);
  // The PFM beside it: the floats exactly, +infinity where invalid, the rows in their order.
  const cv::Mat pfm = snapshot::read_pfm((dir / "d_000000_disparity_lr_L0.pfm").string());
  ASSERT_EQ(pfm.size(), d.size());
  EXPECT_EQ(pfm.at<float>(10, 10), 12.5f);
  EXPECT_EQ(pfm.at<float>(9, 9), 17.3f);
  EXPECT_EQ(pfm.at<float>(6, 6), 300.25f);
  EXPECT_EQ(pfm.at<float>(5, 5), 0.0f);
  EXPECT_EQ(pfm.at<float>(1, 1), std::numeric_limits<float>::infinity());
  EXPECT_EQ(pfm.at<float>(8, 8), std::numeric_limits<float>::infinity());
  // OpenCV reads it the same (its own PFM reader: the header and byte order are standard).
  const cv::Mat by_opencv = cv::imread((dir / "d_000000_disparity_lr_L0.pfm").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(by_opencv.type(), CV_32FC1);
  EXPECT_EQ(by_opencv.at<float>(9, 9), 17.3f);
  EXPECT_EQ(by_opencv.at<float>(0, 0), std::numeric_limits<float>::infinity());
  cv::Mat color = cv::imread((dir / "d_000000_disparity_lr.png").string());
  ASSERT_FALSE(color.empty());
  // Invalid pixels are black; valid ones are coloured (not gray).
  cv::Vec3b invalid = color.at<cv::Vec3b>(20, 2), valid = color.at<cv::Vec3b>(100, 150);
  EXPECT_EQ(invalid, cv::Vec3b(0, 0, 0));
  EXPECT_FALSE(valid[0] == valid[1] && valid[1] == valid[2]);
}

}  // namespace
}  // namespace saccade
