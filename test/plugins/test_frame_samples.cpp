// The box tracker's reads of the frame (frame_samples.hpp): its one-pass
// look (warp_to_gray) bit for bit what OpenCV's warpAffine and cvtColor give,
// and its vectorised cell means bit for bit the plain loop's, on a real
// photograph and on noise, for maps turned and not, magnifying and shrinking,
// reaching past every edge of the frame, from whole frames and from a region
// of one, at widths that are and are not multiples of the eight pixels a step;
// and its halving of a look's patch bit for bit OpenCV's pyrDown.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "support.hpp"
#include "frame_samples.hpp"

static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

namespace saccade {
namespace {

using namespace saccade::fovea;

cv::Mat opencv_look(const cv::Mat& frame, const cv::Matx23d& map, cv::Size size) {
  cv::Mat colour, gray;
  cv::warpAffine(frame, colour, map, size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  if (colour.channels() == 1) return colour;
  cv::cvtColor(colour, gray, colour.channels() == 4 ? cv::COLOR_BGRA2GRAY : cv::COLOR_BGR2GRAY);
  return gray;
}

// A map that samples `size` pixels centred on `center` at `step` source
// pixels a pixel, turned by `angle` (radians), as the tracker's looks do.
cv::Matx23d look_map(cv::Point2d center, double step, double angle, cv::Size size) {
  const double c = std::cos(angle) * step, s = std::sin(angle) * step;
  const double mx = (size.width - 1) / 2.0, my = (size.height - 1) / 2.0;
  return {c, -s, center.x - (c * mx - s * my), s, c, center.y - (s * mx + c * my)};
}

// Pixels that differ from OpenCV's over `looks` random looks at `frame`.
int differing_pixels(const cv::Mat& frame, int looks, uint64_t seed) {
  cv::RNG random(seed);
  cv::Mat mine, scratch;
  int differing = 0;
  for (int i = 0; i < looks; ++i) {
    const cv::Size size(random.uniform(1, 140), random.uniform(1, 140));
    const cv::Point2d center(random.uniform(-0.3, 1.3) * frame.cols, random.uniform(-0.3, 1.3) * frame.rows);
    const double step = std::exp(random.uniform(std::log(0.3), std::log(5.0)));
    const double angle = i % 3 == 0 ? 0.0 : random.uniform(-0.8, 0.8);
    const cv::Matx23d map = look_map(center, step, angle, size);
    warp_to_gray(frame, map, size, mine, scratch);
    const cv::Mat theirs = opencv_look(frame, map, size);
    EXPECT_EQ(mine.size(), theirs.size());
    EXPECT_EQ(mine.type(), CV_8UC1);
    if (mine.size() == theirs.size()) differing += cv::countNonZero(mine != theirs);
  }
  return differing;
}

TEST(WarpToGray, IsOpenCvsWarpThenGrayBitForBitOnARealPhotograph) {
  if (!warp_to_gray_in_one_pass()) GTEST_SKIP() << "no AVX2 here, or another OpenCV: its own two calls run";
  const cv::Mat photo = test::read_sample("baboon.jpg", cv::IMREAD_COLOR);
  ASSERT_EQ(photo.type(), CV_8UC3);
  EXPECT_EQ(differing_pixels(photo, 400, 1), 0);
  // A region of it: rows longer than its pixels, the parent's data beyond it.
  EXPECT_EQ(differing_pixels(photo(cv::Rect(37, 51, 201, 157)), 400, 2), 0);
  // The bottom-right corner, where a four-byte read would pass the data's end.
  EXPECT_EQ(differing_pixels(photo(cv::Rect(photo.cols - 9, photo.rows - 7, 9, 7)), 200, 3), 0);
}

TEST(WarpToGray, IsOpenCvsWarpThenGrayBitForBitOnNoiseAndTheSmallestFrame) {
  if (!warp_to_gray_in_one_pass()) GTEST_SKIP() << "no AVX2 here, or another OpenCV: its own two calls run";
  cv::Mat noise(123, 157, CV_8UC3);
  cv::randu(noise, 0, 256);
  EXPECT_EQ(differing_pixels(noise, 400, 4), 0);
  EXPECT_EQ(differing_pixels(cv::Mat(1, 1, CV_8UC3, cv::Scalar(9, 99, 199)), 50, 7), 0);
}

// Looks upright and turned (up to 12 degrees either way, as the turn
// search's are, or up to 50, as a target turned in the image's plane is
// followed), at widths of sixteen pixels and their multiples and a few
// pixels more, from magnified to a step of 6.5 source pixels of a BGR frame
// (the sixteen-pixel paths: upright up to 5.7 from one or two windows of a
// row, beyond that and turned gathered) and of 19 of a monochrome one (its
// windows hold three times the pixels: upright up to 18), anywhere on and
// past the frame: the pixels that differ from OpenCV's.
int differing_sixteen_pixel_looks(const cv::Mat& frame, int looks, uint64_t seed) {
  cv::RNG random(seed);
  cv::Mat mine, scratch;
  int differing = 0;
  for (int i = 0; i < looks; ++i) {
    const cv::Size size(16 * random.uniform(1, 10) + (i % 4 == 3 ? random.uniform(1, 16) : 0), random.uniform(1, 140));
    const cv::Point2d center(random.uniform(-0.3, 1.3) * frame.cols, random.uniform(-0.3, 1.3) * frame.rows);
    const double reach = frame.channels() == 1 ? 3.0 : 1.0;
    const double step = i % 2 == 0 ? random.uniform(0.3, 6.5 * reach) : random.uniform(0.3, 3.0 * reach);
    const double turn = i % 4 == 1 ? 12.0 : 50.0;
    const double angle = i % 2 == 0 ? 0.0 : random.uniform(-turn, turn) * CV_PI / 180;
    const cv::Matx23d map = look_map(center, step, angle, size);
    warp_to_gray(frame, map, size, mine, scratch);
    const cv::Mat theirs = opencv_look(frame, map, size);
    EXPECT_EQ(mine.size(), theirs.size());
    if (mine.size() == theirs.size()) differing += cv::countNonZero(mine != theirs);
  }
  return differing;
}

// `differing` (the pixels of its looks that differ from OpenCV's) is 0 on a
// photograph, a region of it (rows longer than its pixels, the parent's data
// beyond them), its bottom-right corner (where a read from its last pixels
// would pass the data's end), noise and a 1x1 frame, all of `photo`'s type.
void expect_same_as_opencv(int (*differing)(const cv::Mat&, int, uint64_t), const cv::Mat& photo, int looks,
                           uint64_t seed) {
  EXPECT_EQ(differing(photo, looks, seed), 0) << "the photograph";
  EXPECT_EQ(differing(photo(cv::Rect(37, 51, 201, 157)), looks, seed + 1), 0) << "a region of it";
  EXPECT_EQ(differing(photo(cv::Rect(photo.cols - 9, photo.rows - 7, 9, 7)), 200, seed + 2), 0) << "its corner";
  cv::Mat noise(123, 157, photo.type());
  cv::randu(noise, 0, 256);
  EXPECT_EQ(differing(noise, looks, seed + 3), 0) << "noise";
  EXPECT_EQ(differing(cv::Mat(1, 1, photo.type(), cv::Scalar(9, 99, 199)), 50, seed + 4), 0) << "a 1x1 frame";
}

TEST(WarpToGray, LooksTakenSixteenPixelsAStepAreOpenCvsBitForBit) {
  if (!warp_to_gray_in_one_pass()) GTEST_SKIP() << "no AVX2 here, or another OpenCV: its own two calls run";
  if (!warp_to_gray_sixteen_pixels_a_step())
    std::printf("no AVX-512 VBMI here (or SACCADE_AVX512=0): the eight-pixel path is checked instead\n");
  const cv::Mat photo = test::read_sample("baboon.jpg", cv::IMREAD_COLOR);
  ASSERT_EQ(photo.type(), CV_8UC3);
  expect_same_as_opencv(differing_sixteen_pixel_looks, photo, 600, 11);
}

TEST(WarpToGray, IsOpenCvsWarpBitForBitOnAMonochromeFrame) {
  if (!warp_to_gray_in_one_pass()) GTEST_SKIP() << "no AVX2 here, or another OpenCV: its own call runs";
  const cv::Mat photo = test::read_sample("baboon.jpg", cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(photo.type(), CV_8UC1);
  expect_same_as_opencv(differing_pixels, photo, 400, 21);
  if (!warp_to_gray_sixteen_pixels_a_step())
    std::printf("no AVX-512 VBMI here (or SACCADE_AVX512=0): the eight-pixel path is checked instead\n");
  expect_same_as_opencv(differing_sixteen_pixel_looks, photo, 600, 31);
}

// Cells whose vectorised mean differs from the plain loop's over `samples`
// random samples of `frame`: sixteen cells a step where AVX-512 VBMI is
// usable and a group's taps fit its windows (steps up to 5.2 source pixels
// of a BGR frame, 16 of a monochrome one), else eight, at steps from 0.5 to
// 20, mirrored or not.
int differing_cells(const cv::Mat& frame, int samples, uint64_t seed) {
  cv::RNG random(seed);
  std::vector<float> vectorised, plain;
  int differing = 0;
  for (int i = 0; i < samples; ++i) {
    // (A third as wide as a coarse view of a frame: many sixteen-cell groups in a row.)
    const cv::Size size(i % 3 == 0 ? random.uniform(16, 240) : random.uniform(1, 70), random.uniform(1, 50));
    const cv::Point2d center(random.uniform(-0.3, 1.3) * frame.cols, random.uniform(-0.3, 1.3) * frame.rows);
    double step_x = std::exp(random.uniform(std::log(0.5), std::log(20.0)));
    double step_y = i % 2 == 0 ? step_x : std::exp(random.uniform(std::log(0.5), std::log(20.0)));
    if (i % 5 == 1) step_x = -step_x;  // a mirrored sample reads its taps the other way round
    if (i % 7 == 1) step_y = -step_y;
    vectorised.assign(static_cast<std::size_t>(size.area()), -1.0f);
    plain.assign(static_cast<std::size_t>(size.area()), -2.0f);
    sample_cell_means(frame, center, step_x, step_y, size, vectorised.data());
    sample_cell_means(frame, center, step_x, step_y, size, plain.data(), /*vectorised=*/false);
    for (std::size_t k = 0; k < plain.size(); ++k)
      differing += std::memcmp(&plain[k], &vectorised[k], sizeof(float)) != 0;
  }
  return differing;
}

TEST(PyrDown, IsOpenCvsBitForBitOnARealPhotographNoiseAndTheSmallestSource) {
  cv::Mat photo = test::read_sample("baboon.jpg", cv::IMREAD_GRAYSCALE);
  std::vector<cv::Mat> sources{photo(cv::Rect(0, 0, 128, 128)), photo(cv::Rect(37, 51, 202, 158)),
                               photo(cv::Rect(photo.cols - 4, photo.rows - 4, 4, 4))};
  for (const cv::Size size : {cv::Size(4, 4), cv::Size(6, 8), cv::Size(64, 40), cv::Size(130, 66)})
    sources.push_back(test::random_image(size, size.area()));
  cv::Mat ours;
  for (const cv::Mat& source : sources) {
    cv::Mat theirs;
    cv::pyrDown(source, theirs, source.size() / 2);
    pyr_down(source, ours);
    ASSERT_EQ(ours.size(), theirs.size());
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0.0) << source.cols << "x" << source.rows;
  }
}

TEST(SampleCellMeans, VectorisedIsThePlainLoopBitForBit) {
  if (!frame_samples_vectorised()) GTEST_SKIP() << "no AVX2 on this CPU: the plain loop alone runs";
  if (!warp_to_gray_sixteen_pixels_a_step())
    std::printf("no AVX-512 VBMI here (or SACCADE_AVX512=0): the eight-cell path is checked alone\n");
  const cv::Mat photo = test::read_sample("baboon.jpg", cv::IMREAD_COLOR);
  EXPECT_EQ(differing_cells(photo, 400, 11), 0);
  EXPECT_EQ(differing_cells(photo(cv::Rect(37, 51, 201, 157)), 400, 12), 0);
  EXPECT_EQ(differing_cells(photo(cv::Rect(photo.cols - 9, photo.rows - 7, 9, 7)), 200, 13), 0);
  cv::Mat gray, bgra;
  cv::cvtColor(photo, gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(photo, bgra, cv::COLOR_BGR2BGRA);
  EXPECT_EQ(differing_cells(gray, 200, 14), 0);
  EXPECT_EQ(differing_cells(bgra, 200, 15), 0);
}

TEST(SampleCellMeans, AFrameUnderTwoByTwoGivesItsPixelsGray) {
  std::vector<float> cells(6, -1.0f);
  sample_cell_means(cv::Mat(1, 1, CV_8UC3, cv::Scalar(10, 20, 30)), {0.0, 0.0}, 1.0, 1.0, cv::Size(3, 2), cells.data());
  for (const float v : cells) EXPECT_FLOAT_EQ(v, 0.114f * 10 + 0.587f * 20 + 0.299f * 30);
  sample_cell_means(cv::Mat(1, 40, CV_8UC1, cv::Scalar(77)), {20.0, 0.0}, 2.0, 2.0, cv::Size(3, 2), cells.data());
  for (const float v : cells) EXPECT_FLOAT_EQ(v, 77.0f);
}

TEST(SampleCellMeans, IsTheMeanOfItsCell) {
  // A horizontal ramp: a cell's mean is the ramp at its centre, whatever its step.
  cv::Mat ramp(60, 200, CV_8UC3);
  for (int x = 0; x < ramp.cols; ++x) ramp.col(x).setTo(cv::Scalar::all(x));
  std::vector<float> cells(12 * 3);
  for (const bool vectorised : {true, false}) {
    sample_cell_means(ramp, {100.0, 30.0}, 4.0, 4.0, cv::Size(12, 3), cells.data(), vectorised);
    for (int i = 0; i < 12; ++i) EXPECT_NEAR(cells[static_cast<std::size_t>(24 + i)], 100 + (i - 5.5) * 4, 1e-3) << i;
  }
}

}  // namespace
}  // namespace saccade
