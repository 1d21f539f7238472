// Stereo pairs with truth read from the public benchmarks' files (the stereo
// benchmark's --middlebury and --stereo-pair) and written in Middlebury's 2014
// layout (its --export): each year's layout on files written here, Aloe from
// opencv-doc among them, and every error naming the file at fault.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "stereo_files.hpp"
#include "support.hpp"
#include "unique_names.hpp"

namespace saccade::bench {
namespace {

namespace fs = std::filesystem;

// Each test in a fresh folder, removed with it.
class StereoFiles : public ::testing::Test {
 protected:
  std::string path(const std::string& name) const { return (dir_.path() / name).string(); }
  std::string dir() const { return dir_.path().string(); }

  // A small textured pair and its truth: 20 px and a pixel more each row
  // down on the left half, 5.5 on the right, unknown in the first column.
  static StereoPairImages small_pair() {
    StereoPairImages p;
    p.left.create(6, 32, CV_8U);
    cv::randu(p.left, 0, 256);
    p.right = p.left.clone();
    p.truth.create(6, 32, CV_32F);
    for (int y = 0; y < 6; ++y)
      for (int x = 0; x < 32; ++x)
        p.truth.at<float>(y, x) = x == 0 ? -1.0f : x < 16 ? 20.0f + static_cast<float>(y) : 5.5f;
    return p;
  }

 private:
  const test::TempDir dir_{"saccade_stereo_files"};
};

void expect_same(const cv::Mat& a, const cv::Mat& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.type(), b.type());
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
}

TEST_F(StereoFiles, ReadsBackAMiddlebury2014FolderItWroteExactly) {
  const StereoPairImages written = small_pair();
  ASSERT_TRUE(write_middlebury_pair(path("Scene"), written).ok());
  std::ifstream calib(path("Scene/calib.txt"));
  const std::string text((std::istreambuf_iterator<char>(calib)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "width=32\nheight=6\nndisp=32\n");
  // As the format says, for other tools to read: little-endian, the bottom row first.
  std::ifstream pfm(path("Scene/disp0.pfm"), std::ios::binary);
  std::string kind, size, scale;
  std::getline(pfm, kind), std::getline(pfm, size), std::getline(pfm, scale);
  ASSERT_EQ(kind + "|" + size + "|" + scale, "Pf|32 6|-1");
  float first[2];
  pfm.read(reinterpret_cast<char*>(first), sizeof first);
  EXPECT_TRUE(std::isinf(first[0]));
  EXPECT_EQ(first[1], 25.0f);

  const Result<StereoPairFiles> files = find_middlebury_pair(path("Scene"));
  ASSERT_TRUE(files.ok()) << files.error();
  EXPECT_EQ(files->name, "Scene");
  EXPECT_EQ(files->left, path("Scene/im0.png"));
  EXPECT_EQ(files->truth, path("Scene/disp0.pfm"));
  EXPECT_TRUE(files->note.empty());
  const Result<StereoPairImages> read = read_stereo_pair(*files);
  ASSERT_TRUE(read.ok()) << read.error();
  expect_same(read->left, written.left);
  expect_same(read->right, written.right);
  expect_same(read->truth, written.truth);  // the unknown column back as -1 (infinity in the file)
}

// PFM stores its rows bottom first; a scale of -1 says little-endian.
TEST_F(StereoFiles, ReadsAPfmsRowsBottomFirstAsTheFormatSays) {
  std::ofstream pfm(path("disp0.pfm"), std::ios::binary);
  pfm << "Pf\n3 2\n-1\n";
  const float bottom[3] = {0.7f, 0.8f, std::numeric_limits<float>::infinity()}, top[3] = {0.1f, 0.2f, 0.3f};
  pfm.write(reinterpret_cast<const char*>(bottom), sizeof bottom);
  pfm.write(reinterpret_cast<const char*>(top), sizeof top);
  pfm.close();
  const cv::Mat image(2, 3, CV_8U, cv::Scalar(100));  // (disparities under its width: the truth's sanity check)
  ASSERT_TRUE(cv::imwrite(path("im0.png"), image) && cv::imwrite(path("im1.png"), image));

  const Result<StereoPairFiles> files = find_middlebury_pair(dir());
  ASSERT_TRUE(files.ok()) << files.error();
  const Result<StereoPairImages> read = read_stereo_pair(*files);
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_FLOAT_EQ(read->truth.at<float>(0, 0), 0.1f);
  EXPECT_FLOAT_EQ(read->truth.at<float>(0, 2), 0.3f);
  EXPECT_FLOAT_EQ(read->truth.at<float>(1, 1), 0.8f);
  EXPECT_FLOAT_EQ(read->truth.at<float>(1, 2), -1);
}

// opencv-doc's Aloe is Middlebury 2006's full size: its 8-bit truth is the
// disparity itself. Third size, the same truth is three times the disparity.
TEST_F(StereoFiles, TakesA2006FoldersScaleFromItsWidthUnlessGiven) {
  const cv::Mat left = test::read_sample("aloeL.jpg", cv::IMREAD_GRAYSCALE),
                right = test::read_sample("aloeR.jpg", cv::IMREAD_GRAYSCALE),
                truth = test::read_sample("aloeGT.png", cv::IMREAD_GRAYSCALE);
  fs::create_directories(path("Full"));
  ASSERT_TRUE(cv::imwrite(path("Full/view1.png"), left) && cv::imwrite(path("Full/view5.png"), right) &&
              cv::imwrite(path("Full/disp1.png"), truth));
  Result<StereoPairFiles> full = find_middlebury_pair(path("Full"));
  ASSERT_TRUE(full.ok()) << full.error();
  EXPECT_EQ(full->scale, 1);
  EXPECT_NE(full->note.find("scale taken as 1"), std::string::npos) << full->note;
  Result<StereoPairImages> read = read_stereo_pair(*full);
  ASSERT_TRUE(read.ok()) << read.error();
  cv::Mat expected;
  truth.convertTo(expected, CV_32F);
  expected.setTo(-1, truth == 0);
  expect_same(read->truth, expected);

  // A third of the size: 427 px wide, the truth's 8 bits still the full size's disparity.
  fs::create_directories(path("Third"));
  cv::Mat small, small_truth;
  cv::resize(left, small, left.size() / 3, 0, 0, cv::INTER_AREA);
  cv::resize(truth, small_truth, left.size() / 3, 0, 0, cv::INTER_NEAREST);
  ASSERT_TRUE(cv::imwrite(path("Third/view1.png"), small) && cv::imwrite(path("Third/view5.png"), small) &&
              cv::imwrite(path("Third/disp1.png"), small_truth));
  Result<StereoPairFiles> third = find_middlebury_pair(path("Third"));
  ASSERT_TRUE(third.ok()) << third.error();
  EXPECT_EQ(third->scale, 3);
  read = read_stereo_pair(*third);
  ASSERT_TRUE(read.ok()) << read.error();
  const cv::Point p(200, 150);
  ASSERT_GT(small_truth.at<uint8_t>(p), 0);
  EXPECT_FLOAT_EQ(read->truth.at<float>(p), small_truth.at<uint8_t>(p) / 3.0f);

  // Given, the scale is the one given, and nothing is assumed.
  Result<StereoPairFiles> given = find_middlebury_pair(path("Third") + ":2");
  ASSERT_TRUE(given.ok()) << given.error();
  EXPECT_EQ(given->scale, 2);
  EXPECT_TRUE(given->note.empty());
}

// A positive scale says big-endian; its size is no factor the benchmarks' files mean.
TEST_F(StereoFiles, ReadsABigEndianPfm) {
  std::ofstream pfm(path("disp0.pfm"), std::ios::binary);
  pfm << "Pf\n2 1\n2.0\n";  // (its disparities under the width of 2)
  for (const float v : {1.25f, std::numeric_limits<float>::infinity()}) {
    char bytes[4];
    std::memcpy(bytes, &v, 4);
    std::reverse(bytes, bytes + 4);
    pfm.write(bytes, 4);
  }
  pfm.close();
  const cv::Mat image(1, 2, CV_8U, cv::Scalar(100));
  ASSERT_TRUE(cv::imwrite(path("im0.png"), image) && cv::imwrite(path("im1.png"), image));
  const Result<StereoPairImages> read = read_stereo_pair(*find_middlebury_pair(dir()));
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_EQ(read->truth.at<float>(0, 0), 1.25f);
  EXPECT_EQ(read->truth.at<float>(0, 1), -1.0f);
}

// 2006's half size (641 px for Aloe): its truth is twice its own disparity.
TEST_F(StereoFiles, TakesAHalfSizeFoldersScaleAsTwo) {
  const StereoPairImages p = small_pair();
  cv::Mat left, truth8;
  cv::resize(p.left, left, cv::Size(641, 555), 0, 0, cv::INTER_NEAREST);
  cv::resize(p.truth, truth8, cv::Size(641, 555), 0, 0, cv::INTER_NEAREST);
  truth8.convertTo(truth8, CV_8U, 2.0);
  ASSERT_TRUE(cv::imwrite(path("view1.png"), left) && cv::imwrite(path("view5.png"), left) &&
              cv::imwrite(path("disp1.png"), truth8));
  const Result<StereoPairFiles> files = find_middlebury_pair(dir());
  ASSERT_TRUE(files.ok()) << files.error();
  EXPECT_EQ(files->scale, 2);
  EXPECT_NE(files->note.find("taken as 2 from the images' width"), std::string::npos) << files->note;
  const Result<StereoPairImages> read = read_stereo_pair(*files);
  ASSERT_TRUE(read.ok()) << read.error();
  EXPECT_FLOAT_EQ(read->truth.at<float>(300, 100), truth8.at<uint8_t>(300, 100) / 2.0f);
}

// A 2001 scene's nine views are im0..im8: its im0 and im1 are no 2014 pair.
TEST_F(StereoFiles, AWholeLayoutWinsOverAnotherYearsNamesInPart) {
  const StereoPairImages p = small_pair();
  cv::Mat truth8;
  p.truth.convertTo(truth8, CV_8U, 8.0);
  for (const char* view : {"im0.png", "im1.png", "im2.png", "im6.png"}) ASSERT_TRUE(cv::imwrite(path(view), p.left));
  ASSERT_TRUE(cv::imwrite(path("disp2.png"), truth8));
  const Result<StereoPairFiles> files = find_middlebury_pair(dir() + ":8");
  ASSERT_TRUE(files.ok()) << files.error();
  EXPECT_EQ(files->left, path("im2.png"));
  EXPECT_EQ(files->truth, path("disp2.png"));
}

TEST_F(StereoFiles, AFolderGivenAsDotOrWithASlashIsNamedAsItIs) {
  ASSERT_TRUE(write_middlebury_pair(path("Venus"), small_pair()).ok());
  const std::string cwd = fs::current_path().string();
  fs::current_path(path("Venus"));
  const Result<StereoPairFiles> here = find_middlebury_pair(".");
  fs::current_path(cwd);
  ASSERT_TRUE(here.ok()) << here.error();
  EXPECT_EQ(here->name, "Venus");
  EXPECT_EQ(find_middlebury_pair(path("Venus") + "/")->name, "Venus");
}

TEST(UniqueNames, ARepeatedNameGetsANumber) {
  std::vector<std::string> names{"Aloe", "Teddy", "Aloe", "Aloe", "Aloe_2"};
  make_names_unique(names, [](std::string& n) -> std::string& { return n; });
  EXPECT_EQ(names, (std::vector<std::string>{"Aloe", "Teddy", "Aloe_2", "Aloe_3", "Aloe_2_2"}));
}

TEST_F(StereoFiles, A2003FolderNeedsItsScale) {
  const StereoPairImages p = small_pair();
  cv::Mat truth8;
  p.truth.convertTo(truth8, CV_8U, 4.0);  // Teddy's and Cones' convention; -1 saturates to 0, unknown
  ASSERT_TRUE(cv::imwrite(path("im2.png"), p.left) && cv::imwrite(path("im6.png"), p.right) &&
              cv::imwrite(path("disp2.png"), truth8));
  const Result<StereoPairFiles> unscaled = find_middlebury_pair(dir());
  ASSERT_FALSE(unscaled.ok());
  EXPECT_NE(unscaled.error().find("give it as DIR:SCALE"), std::string::npos) << unscaled.error();
  EXPECT_NE(unscaled.error().find(dir()), std::string::npos) << unscaled.error();

  const Result<StereoPairFiles> files = find_middlebury_pair(dir() + ":4");
  ASSERT_TRUE(files.ok()) << files.error();
  EXPECT_EQ(files->left, path("im2.png"));
  const Result<StereoPairImages> read = read_stereo_pair(*files);
  ASSERT_TRUE(read.ok()) << read.error();
  expect_same(read->truth, p.truth);
}

// KITTI's truth: 16 bits, 256 a pixel, 0 where its laser saw nothing.
TEST_F(StereoFiles, ReadsA16BitTruthByTheScaleGiven) {
  const StereoPairImages p = small_pair();
  cv::Mat truth16;
  p.truth.convertTo(truth16, CV_16U, 256.0);
  ASSERT_TRUE(cv::imwrite(path("left.png"), p.left) && cv::imwrite(path("right.png"), p.right) &&
              cv::imwrite(path("truth.png"), truth16));
  const std::string files = path("left.png") + "," + path("right.png") + "," + path("truth.png");
  const Result<StereoPairFiles> given = parse_stereo_pair(files + ",256");
  ASSERT_TRUE(given.ok()) << given.error();
  EXPECT_EQ(given->name, fs::path(dir()).filename().string() + "/left");
  const Result<StereoPairImages> read = read_stereo_pair(*given);
  ASSERT_TRUE(read.ok()) << read.error();
  expect_same(read->truth, p.truth);

  const Result<StereoPairFiles> unscaled = parse_stereo_pair(files);
  ASSERT_TRUE(unscaled.ok()) << unscaled.error();
  const Result<StereoPairImages> refused = read_stereo_pair(*unscaled);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.error().find(path("truth.png") + ": an integer disparity map needs its scale"), std::string::npos)
      << refused.error();
}

TEST_F(StereoFiles, BadSpecsAndFoldersAreErrorsNamingThem) {
  EXPECT_NE(parse_stereo_pair("l.png,r.png").error().find("expected LEFT,RIGHT,TRUTH"), std::string::npos);
  EXPECT_NE(parse_stereo_pair("l.png,r.png,t.png,x").error().find("the scale 'x' is not a positive number"),
            std::string::npos);
  EXPECT_NE(parse_stereo_pair("l.png,,t.png").error().find("an empty file name"), std::string::npos);
  EXPECT_NE(find_middlebury_pair(path("nowhere")).error().find(path("nowhere") + ": no such folder"),
            std::string::npos);
  EXPECT_NE(find_middlebury_pair(dir() + ":-3").error().find("the scale '-3' is not a positive number"),
            std::string::npos);
  const Result<StereoPairFiles> empty = find_middlebury_pair(dir());
  EXPECT_NE(empty.error().find(dir() + ": no Middlebury pair: looked for im0.png"), std::string::npos) << empty.error();
  const cv::Mat image(6, 32, CV_8U, cv::Scalar(9));
  ASSERT_TRUE(cv::imwrite(path("im0.png"), image) && cv::imwrite(path("im1.png"), image));
  const Result<StereoPairFiles> partial = find_middlebury_pair(dir());
  EXPECT_NE(partial.error().find("a Middlebury 2014, 2021 folder without disp0.pfm or disp0GT.pfm"), std::string::npos)
      << partial.error();
}

TEST_F(StereoFiles, FilesThatAreNotThePairTheyShouldBeAreErrorsNamingThem) {
  const StereoPairImages p = small_pair();
  ASSERT_TRUE(write_middlebury_pair(dir(), p).ok());
  const StereoPairFiles files{"scene", path("im0.png"), path("im1.png"), path("disp0.pfm"), 1, {}};
  // The error of the pair with one of its files replaced by `image` (none: not written) saved as `name`.
  const auto error_with = [&](std::string StereoPairFiles::*file, const std::string& name, const cv::Mat& image) {
    if (!image.empty()) { EXPECT_TRUE(cv::imwrite(path(name), image)); }
    StereoPairFiles changed = files;
    changed.*file = path(name);
    return read_stereo_pair(changed).error();
  };
  const auto right = &StereoPairFiles::right, truth = &StereoPairFiles::truth;
  EXPECT_EQ(error_with(right, "none.png", {}), path("none.png") + ": cannot be read as an image");
  EXPECT_EQ(error_with(right, "wider.png", cv::Mat(6, 33, CV_8U, cv::Scalar(1))),
            path("wider.png") + ": 33x6, but " + path("im0.png") + " is 32x6");
  EXPECT_EQ(error_with(truth, "colour.pfm", cv::Mat(6, 32, CV_32FC3, cv::Scalar(1, 2, 3))),
            path("colour.pfm") + ": cannot be read as a one-channel PFM (\"Pf\")");
  EXPECT_EQ(error_with(truth, "other.pfm", cv::Mat(6, 33, CV_32F, cv::Scalar(3))),
            path("other.pfm") + ": 33x6, but " + path("im0.png") + " is 32x6");
  EXPECT_EQ(error_with(&StereoPairFiles::left, "deep.png", cv::Mat(6, 32, CV_16U, cv::Scalar(4000))),
            path("deep.png") + ": not an 8-bit image; the matchers take 8 bits (convert it, scaled as it should be)");
  // KITTI's 16 bits read with a scale of 1: 6400 px in an image 32 px wide.
  cv::Mat kitti;
  p.truth.convertTo(kitti, CV_16U, 256.0);
  EXPECT_EQ(error_with(truth, "kitti.png", kitti),
            path("kitti.png") + ": a disparity of 6400 px in an image 32 px wide (is its scale 1 right?)");
  EXPECT_EQ(error_with(truth, "unknown.pfm", cv::Mat(6, 32, CV_32F, cv::Scalar(INFINITY))),
            path("unknown.pfm") + ": no pixel of known disparity");
}

}  // namespace
}  // namespace saccade::bench
