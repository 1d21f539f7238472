// The tracking benchmark's data: OTB and VOT readers, the sequence generator
// (deterministic, enough sequences, truth that matches what it renders) and
// the OTB/VOT measures on hand-made tracks.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>
#include <utility>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "support.hpp"
#include "tracking_data.hpp"

// OpenCV's own parallel loops run on TBB, whose synchronisation ThreadSanitizer
// cannot see; these tests do not need them.
static const bool kOpenCvSingleThread = (cv::setNumThreads(1), true);

namespace saccade::bench {
namespace {

namespace fs = std::filesystem;

// A fresh folder for the running test, removed afterwards.
struct TempDir : test::TempDir {
  TempDir() : test::TempDir("saccade_tracking_data") {}
};

void write_file(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

// Images `first`..`first + count - 1`, image i's blue channel 10 i.
void write_frames(const fs::path& folder, int count, int digits, int first = 1) {
  fs::create_directories(folder);
  for (int i = first; i < first + count; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%0*d.jpg", digits, i);
    cv::Mat frame(48, 64, CV_8UC3, cv::Scalar(10 * i, 20, 30));
    ASSERT_TRUE(cv::imwrite((folder / name).string(), frame));
  }
}

// The value, failing the test (and giving a default one) when there is none.
template <class T>
T value_of(Result<T> result) {
  EXPECT_TRUE(result.ok()) << result.error();
  return std::move(result).value_or(T{});
}

void expect_box(const cv::Rect2d& box, double x, double y, double w, double h) {
  EXPECT_DOUBLE_EQ(box.x, x);
  EXPECT_DOUBLE_EQ(box.y, y);
  EXPECT_DOUBLE_EQ(box.width, w);
  EXPECT_DOUBLE_EQ(box.height, h);
}

// ------------------------------------------------------------------ readers

TEST(OtbReader, ReadsCommaTabSpaceAndCrlfRows) {
  TempDir dir;
  write_frames(dir.path() / "img", 4, 4);
  write_file(dir.path() / "groundtruth_rect.txt", "10,20,30,40\r\n11\t21\t31\t41\r\n12 22  32 42\nNaN,NaN,NaN,NaN\n\n");
  const Sequence s = value_of(read_otb(dir.path().string()));
  ASSERT_EQ(s.size(), 4);
  expect_box(s.truth[0], 10, 20, 30, 40);
  expect_box(s.truth[1], 11, 21, 31, 41);
  expect_box(s.truth[2], 12, 22, 32, 42);
  EXPECT_EQ(s.visible, (std::vector<bool>{true, true, true, false}));
  EXPECT_EQ(s.frame_size, cv::Size(64, 48));
  EXPECT_EQ(s.name, dir.path().filename().string());
  const cv::Mat third = value_of(s.frame(2));
  ASSERT_EQ(third.type(), CV_8UC3);
  EXPECT_NEAR(third.at<cv::Vec3b>(10, 10)[0], 30, 3);  // image 0003.jpg
}

TEST(OtbReader, NamesAMissingImage) {
  TempDir dir;
  write_frames(dir.path() / "img", 2, 4);
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n1,2,3,4\n1,2,3,4\n");
  const std::string error = read_otb(dir.path().string()).error();
  EXPECT_THAT(error, ::testing::HasSubstr("img/0003.jpg: missing"));
}

TEST(OtbReader, NamesTheFileAndLineOfAMalformedRow) {
  TempDir dir;
  write_frames(dir.path() / "img", 3, 4);
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n1,2,3\n1,2,3,4\n");
  std::string error = read_otb(dir.path().string()).error();
  EXPECT_THAT(error, ::testing::HasSubstr("groundtruth_rect.txt:2: expected 4 numbers"));
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n1,2,3,4\n1,2,x3,4\n");
  error = read_otb(dir.path().string()).error();
  EXPECT_THAT(error, ::testing::HasSubstr("groundtruth_rect.txt:3: 'x3' is not a number"));
  error = read_otb((dir.path() / "nowhere").string()).error();
  EXPECT_THAT(error, ::testing::HasSubstr("nowhere: not a folder"));
}

// The image a sequence's frame came from (write_frames' blue channel).
int image_number(const Sequence& s, int frame) {
  const cv::Mat image = value_of(s.frame(frame));
  return image.empty() ? -1 : static_cast<int>(std::lround(image.at<cv::Vec3b>(10, 10)[0] / 10.0));
}

TEST(OtbReader, TakesTheImagesInTheOrderOfTheirNumbersWhateverTheirDigitsAndFirst) {
  TempDir dir;
  write_frames(dir.path() / "img", 3, 5, 20);  // 00020.jpg ... as OTB's Board (five digits), BlurCar1 (from 0247)
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n1,2,3,4\n1,2,3,4\n");
  const Sequence s = value_of(read_otb(dir.path().string()));
  ASSERT_EQ(s.size(), 3);
  EXPECT_EQ(image_number(s, 0), 20);
  EXPECT_EQ(image_number(s, 2), 22);
}

TEST(OtbReader, FewerRowsThanImagesBelongToTheImagesFromTheFirstOneGiven) {
  TempDir dir;
  write_frames(dir.path() / "img", 5, 4);
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n1,2,3,4\n");
  Sequence s = value_of(read_otb(dir.path().string()));  // as OTB's Football1: from the first
  ASSERT_EQ(s.size(), 2);
  EXPECT_EQ(image_number(s, 0), 1);
  EXPECT_EQ(image_number(s, 1), 2);
  EXPECT_THAT(s.note,
              ::testing::HasSubstr("groundtruth_rect.txt has 2 rows for 5 images: taken as 0001.jpg to 0002.jpg's"));
  s = value_of(read_otb(dir.path().string(), 4));  // as OTB's David: from 300
  EXPECT_EQ(s.note, "");
  ASSERT_EQ(s.size(), 2);
  EXPECT_EQ(image_number(s, 0), 4);
  EXPECT_EQ(image_number(s, 1), 5);
  EXPECT_THAT(read_otb(dir.path().string(), 5).error(),
              ::testing::HasSubstr("img/0006.jpg: missing (groundtruth_rect.txt has 2 rows from image 5)"));
  EXPECT_THAT(read_otb(dir.path().string(), 9).error(),
              ::testing::HasSubstr("img/0009.jpg: missing (the truth starts there; img/ holds 0001.jpg to 0005.jpg)"));
}

TEST(OtbReader, NamesAGapInTheImages) {
  TempDir dir;
  write_frames(dir.path() / "img", 2, 4);
  write_frames(dir.path() / "img", 1, 4, 4);
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n");
  EXPECT_THAT(
      read_otb(dir.path().string()).error(),
      ::testing::HasSubstr("img/0002.jpg: the next image is 0004.jpg (the images must be numbered without gaps)"));
  fs::remove_all(dir.path() / "img");
  fs::create_directories(dir.path() / "img");
  EXPECT_THAT(read_otb(dir.path().string()).error(), ::testing::HasSubstr("img: no numbered .jpg or .png images"));
}

TEST(OtbReader, ReadsEveryTargetOfAFolderWithSeveral) {
  TempDir dir;
  write_frames(dir.path() / "img", 3, 4);
  write_file(dir.path() / "groundtruth_rect.1.txt", "1,2,3,4\n1,2,3,4\n1,2,3,4\n");
  write_file(dir.path() / "groundtruth_rect.2.txt", "5,6,7,8\n5,6,7,8\n");
  const std::vector<Sequence> targets = value_of(read_otb_targets(dir.path().string()));
  ASSERT_EQ(targets.size(), 2u);
  const std::string name = dir.path().filename().string();
  EXPECT_EQ(targets[0].name, name + ".1");
  EXPECT_EQ(targets[0].size(), 3);
  EXPECT_EQ(targets[1].name, name + ".2");
  ASSERT_EQ(targets[1].size(), 2);
  expect_box(targets[1].truth[0], 5, 6, 7, 8);
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n");  // one target: that file alone
  ASSERT_EQ(value_of(read_otb_targets(dir.path().string())).size(), 1u);
  for (const char* file : {"groundtruth_rect.txt", "groundtruth_rect.1.txt", "groundtruth_rect.2.txt"})
    fs::remove(dir.path() / file);
  EXPECT_THAT(read_otb_targets(dir.path().string()).error(),
              ::testing::HasSubstr("groundtruth_rect.txt (nor groundtruth_rect.1.txt"));
}

TEST(OtbReader, NamesTwoImagesOfOneNumber) {
  TempDir dir;
  write_frames(dir.path() / "img", 2, 4);
  write_frames(dir.path() / "img", 1, 5, 2);  // 00002.jpg beside 0002.jpg
  write_file(dir.path() / "groundtruth_rect.txt", "1,2,3,4\n");
  EXPECT_THAT(read_otb(dir.path().string()).error(), ::testing::HasSubstr(": two images of one number"));
}

TEST(OtbFolderSpec, ReadsDirOrDirAndTheFirstImage) {
  TempDir dir;
  const std::string d = dir.path().string();
  OtbFolder f = value_of(parse_otb_folder(d));
  EXPECT_EQ(f.dir, d);
  EXPECT_EQ(f.first_image, 0);
  f = value_of(parse_otb_folder(d + ":300"));
  EXPECT_EQ(f.dir, d);
  EXPECT_EQ(f.first_image, 300);
  fs::create_directories(dir.path() / "run_12:30");  // a folder's own name ending in ':' and digits
  f = value_of(parse_otb_folder((dir.path() / "run_12:30").string()));
  EXPECT_EQ(f.dir, (dir.path() / "run_12:30").string());
  EXPECT_EQ(f.first_image, 0);
  f = value_of(parse_otb_folder((dir.path() / "run_12:30").string() + ":7"));
  EXPECT_EQ(f.first_image, 7);
  EXPECT_EQ(value_of(parse_otb_folder(d + ":x")).dir, d + ":x");  // not a number: a folder name
  EXPECT_THAT(parse_otb_folder(d + ":0").error(), ::testing::HasSubstr(":0: expected DIR or DIR:FIRST"));
  EXPECT_THAT(parse_otb_folder(d + ":99999999999").error(), ::testing::HasSubstr("FIRST an image number from 1"));
}

TEST(VideoTarget, ReadsFileFirstBoxAndCountOrNamesTheFault) {
  VideoTarget t = value_of(parse_video_target("/data/vtest.avi:60:504,195,32,104"));
  EXPECT_EQ(t.path, "/data/vtest.avi");
  EXPECT_EQ(t.first_frame, 60);
  EXPECT_EQ(t.box, cv::Rect2d(504, 195, 32, 104));
  EXPECT_EQ(t.frames, 0);
  t = value_of(parse_video_target("clip:1.avi:0:1.5,2,30,40:150"));  // a ':' in the path
  EXPECT_EQ(t.path, "clip:1.avi");
  EXPECT_EQ(t.first_frame, 0);
  EXPECT_EQ(t.box, cv::Rect2d(1.5, 2, 30, 40));
  EXPECT_EQ(t.frames, 150);
  for (const char* bad : {"vtest.avi", "vtest.avi:60", "vtest.avi:504,195,32,104", ":60:504,195,32,104",
                          "vtest.avi:-1:504,195,32,104", "vtest.avi:x:504,195,32,104"})
    EXPECT_THAT(parse_video_target(bad).error(), ::testing::HasSubstr("expected FILE:FIRST:x,y,w,h")) << bad;
  EXPECT_THAT(parse_video_target("v.avi:0:1,2,30,40:1").error(), ::testing::HasSubstr("COUNT must be"));
  EXPECT_THAT(parse_video_target("v.avi:2000000000:1,2,30,40:2000000000").error(),
              ::testing::HasSubstr("COUNT must be"));
  for (const char* bad : {"v.avi:0:1,2,30", "v.avi:0:1,2,30,40:", "v.avi:0:1,2,3,4,5,6,7,8"})
    EXPECT_THAT(parse_video_target(bad).error(), ::testing::HasSubstr("expected FILE:FIRST:x,y,w,h")) << bad;
  EXPECT_THAT(parse_video_target("v.avi:0:1,2,inf,40").error(), ::testing::HasSubstr("must be finite"));
  EXPECT_THAT(parse_video_target("v.avi:0:1,2,0,40").error(), ::testing::HasSubstr("a width and a height"));
}

// opencv-doc's vtest.avi (795 frames, 768x576), followed from frame 60.
TEST(VideoReader, GivesTheFramesFromTheFirstOnInAnyOrderAndNamesWhatIsMissing) {
  const std::string path = test::sample_path("vtest.avi");
  const Sequence s = value_of(read_video({path, 60, {504, 195, 32, 104}, 5}));
  EXPECT_EQ(s.name, "vtest@60+504+195+32+104");
  EXPECT_TRUE(s.note.empty());
  EXPECT_EQ(s.size(), 5);
  EXPECT_EQ(s.frame_size, cv::Size(768, 576));
  EXPECT_FALSE(s.truth_known);
  EXPECT_EQ(s.truth.front(), cv::Rect2d(504, 195, 32, 104));
  cv::VideoCapture direct(path);
  std::vector<cv::Mat> expected;
  for (int i = 0; i <= 64; ++i) {
    cv::Mat frame;
    ASSERT_TRUE(direct.read(frame));
    if (i >= 60) expected.push_back(frame);
  }
  for (int i : {0, 3, 4, 1, 2}) {  // backwards opens the video again
    const cv::Mat frame = value_of(s.frame(i));
    EXPECT_EQ(cv::norm(frame, expected[static_cast<std::size_t>(i)], cv::NORM_INF), 0) << "frame " << i;
  }
  EXPECT_THAT(s.frame(5).error(), ::testing::HasSubstr("no frame 5"));
  EXPECT_EQ(value_of(read_video({path, 790, {504, 195, 32, 104}, 0})).size(), 5) << "to the video's end";
  const Sequence cut = value_of(read_video({path, 790, {504, 195, 32, 104}, 150}));
  EXPECT_EQ(cut.size(), 5);
  EXPECT_THAT(cut.note, ::testing::HasSubstr("the video ends 5 frames after frame 790, not 150"));
  EXPECT_THAT(read_video({path, 794, {504, 195, 32, 104}, 0}).error(),
              ::testing::HasSubstr("has 795 frames: none after frame 794"));
  EXPECT_THAT(read_video({path, 0, {800, 195, 32, 104}, 0}).error(),
              ::testing::HasSubstr("lies outside its 768x576 frames"));
  EXPECT_THAT(read_video({"/no/such.avi", 0, {1, 1, 10, 10}, 0}).error(),
              ::testing::HasSubstr("cannot open video /no/such.avi: no such file"));
  EXPECT_THAT(read_video({"/", 0, {1, 1, 10, 10}, 0}).error(), ::testing::HasSubstr("cannot open video /: not a file"));
}

// A video that holds fewer frames than its header announces is followed to
// its last frame, and the table's note says how many were missing.
TEST(VideoReader, NotesAVideoCutShortOfWhatItsHeaderAnnounces) {
  const std::string path =
      (std::filesystem::temp_directory_path() / ("saccade_cut_short_bench_" + std::to_string(getpid()) + ".avi"))
          .string();
  ASSERT_TRUE(test::write_cut_short_video(path, 60));
  const Sequence s = value_of(read_video({path, 0, {20, 10, 16, 16}, 0}));
  EXPECT_GT(s.size(), 1);
  EXPECT_LT(s.size(), 58);
  EXPECT_THAT(s.note, ::testing::HasSubstr("only " + std::to_string(s.size()) + " of the 60 frames its header"));
  std::filesystem::remove(path);
}

TEST(WitnessScore, CountsClaimedFramesJumpsAndAgreement) {
  std::vector<TrackedFrame> a(5), b(5);
  for (int i = 0; i < 5; ++i) {
    a[static_cast<std::size_t>(i)] = {cv::Rect2d(100 + 2 * i, 100, 20, 40), true, 1.0};
    b[static_cast<std::size_t>(i)] = a[static_cast<std::size_t>(i)];
  }
  a[3] = {cv::Rect2d(130, 100, 20, 40), false, 1.0};  // 26 px from frame 2's: under 0.75 x 40, no jump
  b[3] = {cv::Rect2d(140, 131, 20, 40), true, 1.0};   // 48 px: a jump, and 45 px back on frame 4: another
  const WitnessScore wa = witness_score(a), wb = witness_score(b);
  EXPECT_EQ(wa.frames, 4);
  EXPECT_DOUBLE_EQ(wa.claimed, 0.75);
  EXPECT_EQ(wa.jumps, 0);
  EXPECT_EQ(wb.jumps, 2);
  EXPECT_DOUBLE_EQ(wb.ms_per_frame, 1.0);
  EXPECT_DOUBLE_EQ(agreement(a, b), 0.75);  // frame 3: 33 px apart
  EXPECT_DOUBLE_EQ(agreement(a, b, 40), 1.0);
  EXPECT_EQ(agreement(a, std::vector<TrackedFrame>(4)), 0) << "tracks of different sequences";
}

TEST(FrameTimes, GivesTheMeanMedianNearestRankP99SlowestAndTheUntrackedFramesMean) {
  // Frame 0 (the initialisation) is not counted; 200 frames after it take
  // 1..200 ms, out of order, and the frames of 191 ms and up are not claimed.
  std::vector<TrackedFrame> track(201);
  track[0].ms = 1000;
  for (int i = 1; i <= 200; ++i) {
    TrackedFrame& f = track[static_cast<std::size_t>(i)];
    f.ms = (i * 37) % 200 + 1;  // 37 and 200 share no factor: each of 1..200 once
    f.tracking = f.ms < 191;
  }
  const FrameTimes t = frame_times(track);
  EXPECT_EQ(t.frames, 200);
  EXPECT_DOUBLE_EQ(t.mean, 100.5);
  EXPECT_DOUBLE_EQ(t.median, 100.5);
  EXPECT_DOUBLE_EQ(t.p99, 198);  // the 198th of 200: 99% of the frames at or under it
  EXPECT_DOUBLE_EQ(t.max, 200);
  EXPECT_EQ(t.untracked_frames, 10);
  EXPECT_DOUBLE_EQ(t.untracked_mean, 195.5);

  const FrameTimes few = frame_times({{}, {{}, true, 3.0}, {{}, true, 1.0}, {{}, true, 2.0}});
  EXPECT_DOUBLE_EQ(few.median, 2.0);
  EXPECT_DOUBLE_EQ(few.p99, 3.0) << "under 100 frames the 99th percentile is the slowest";
  EXPECT_EQ(few.untracked_frames, 0);
  EXPECT_DOUBLE_EQ(few.untracked_mean, -1);
  EXPECT_EQ(frame_times(std::vector<TrackedFrame>(1)).frames, 0) << "no frame after the first";
}

TEST(VotReader, PolygonsBecomeTheirBoundingBoxesAndNanRowsInvisible) {
  TempDir dir;
  write_frames(dir.path() / "color", 3, 8);
  write_file(dir.path() / "groundtruth.txt",
             "10.5,20,40.5,22,38,50,8,48\n"  // a slightly rotated quadrilateral
             "nan,nan,nan,nan\n"
             "5,6,7,8\n");
  const Sequence s = value_of(read_vot(dir.path().string()));
  ASSERT_EQ(s.size(), 3);
  expect_box(s.truth[0], 8, 20, 32.5, 30);
  EXPECT_EQ(s.visible, (std::vector<bool>{true, false, true}));
  expect_box(s.truth[2], 5, 6, 7, 8);
  EXPECT_FALSE(value_of(s.frame(1)).empty());
  const Result<cv::Mat> past_the_end = s.frame(3);
  ASSERT_FALSE(past_the_end.ok());
  EXPECT_EQ(past_the_end.error(), "no frame 3 (the sequence has 3)");
}

TEST(VotReader, ReadsFramesBesideTheTruthAndNamesBadRows) {
  TempDir dir;
  write_frames(dir.path(), 2, 8);
  write_file(dir.path() / "groundtruth.txt", "1,2,3,4,5,6\n1,2,3,4\n");
  const std::string error = read_vot(dir.path().string()).error();
  EXPECT_THAT(error, ::testing::HasSubstr("groundtruth.txt:1: expected 4 numbers (x,y,w,h) or 8"));
  write_file(dir.path() / "groundtruth.txt", "1,2,3,4\n1,2,3,4\n");
  EXPECT_EQ(value_of(read_vot(dir.path().string())).size(), 2);
  write_file(dir.path() / "groundtruth.txt", "\n\n");
  EXPECT_THAT(read_vot(dir.path().string()).error(), ::testing::HasSubstr("groundtruth.txt: no ground-truth rows"));
  fs::remove(dir.path() / "groundtruth.txt");
  EXPECT_THAT(read_vot(dir.path().string()).error(), ::testing::HasSubstr("cannot open "));
}

TEST(VotReader, ReadsLasotsImgFolderAndNamesAMissingFrame) {
  TempDir dir;
  write_frames(dir.path() / "img", 3, 8);  // LaSOT: img/00000001.jpg ...; an absent target is 0,0,0,0
  write_file(dir.path() / "groundtruth.txt", "1,2,3,4\n0,0,0,0\n5,6,7,8\n");
  const Sequence s = value_of(read_vot(dir.path().string()));
  ASSERT_EQ(s.size(), 3);
  EXPECT_EQ(s.visible, (std::vector<bool>{true, false, true}));
  EXPECT_EQ(image_number(s, 2), 3);
  write_file(dir.path() / "groundtruth.txt", "1,2,3,4\n1,2,3,4\n1,2,3,4\n1,2,3,4\n");
  EXPECT_THAT(read_vot(dir.path().string()).error(),
              ::testing::HasSubstr("img/00000004.jpg: missing (groundtruth.txt has 4 rows from image 1)"));
}

TEST(TruthRow, GivesTheBoxAndVisibilityOrNamesTheFault) {
  const Result<TruthRow> row = parse_truth_row("1,2,3,4", "f:1");
  ASSERT_TRUE(row.ok()) << row.error();
  expect_box(row->box, 1, 2, 3, 4);
  EXPECT_TRUE(row->visible);
  EXPECT_FALSE(value_of(parse_truth_row("NaN,1,2,3", "f:2")).visible);
  EXPECT_FALSE(value_of(parse_truth_row("5,6,0,0", "f:3")).visible);  // an empty box: no target
  EXPECT_EQ(parse_truth_row("1,2,-3,4", "f:4").error(), "f:4: negative width or height");
  EXPECT_EQ(parse_truth_row("1,2,3", "f:5").error(),
            "f:5: expected 4 numbers (x,y,w,h) or 8 (a polygon x1,y1,...,x4,y4), got 3");
}

// ------------------------------------------------------------------ generator

TEST(Generator, HasEnoughLongSequencesWithInvisibleFrames) {
  const std::vector<SyntheticScript> scripts = standard_scripts();
  const std::vector<Sequence> all = value_of(generate_sequences(test::sample_dir()));
  ASSERT_EQ(all.size(), scripts.size());
  int small = 0, large = 0;
  std::set<std::string> names;
  for (const Sequence& s : all) {
    names.insert(s.name);
    EXPECT_GE(s.size(), 300) << s.name;
    EXPECT_EQ(s.visible.size(), s.truth.size());
    EXPECT_TRUE(s.visible.front()) << s.name;
    small += s.frame_size == cv::Size(320, 240);
    large += s.frame_size == cv::Size(640, 480);
  }
  EXPECT_EQ(names.size(), all.size());
  EXPECT_GE(small, 8);
  EXPECT_GE(large, 1);
  // Occlusion and leaving the view both hide the target for a while.
  for (const Sequence& s : all) {
    const auto hidden = std::count(s.visible.begin(), s.visible.end(), false);
    if (s.name == "occlusion" || s.name == "out_of_view") { EXPECT_GE(hidden, 20) << s.name; }
    if (s.name == "scale" || s.name == "rotation") { EXPECT_EQ(hidden, 0) << s.name; }
  }
}

// The held-out set: each standard script's motions with another target, over
// another background, from another seed, so a setting fitted to the standard
// set shows there. Each target is the picture its crop says (an object, not
// the photograph's background: its centre differs from its border).
TEST(Generator, TheHeldOutSetIsTheStandardScriptsWithOtherPictures) {
  const std::vector<SyntheticScript> standard = standard_scripts(), held_out = holdout_scripts();
  ASSERT_EQ(held_out.size(), standard.size());
  const std::vector<Sequence> all = value_of(generate_sequences(test::sample_dir(), held_out));
  ASSERT_EQ(all.size(), held_out.size());
  for (std::size_t i = 0; i < held_out.size(); ++i) {
    const SyntheticScript &h = held_out[i], &s = standard[i];
    EXPECT_EQ(h.name, "holdout_" + s.name);
    EXPECT_EQ(all[i].name, h.name);
    EXPECT_NE(h.seed, s.seed) << h.name;
    EXPECT_FALSE(h.background == s.background && h.target_image == s.target_image) << h.name;
    EXPECT_EQ(h.frames, s.frames) << h.name;
    EXPECT_EQ(h.frame_size, s.frame_size) << h.name;
    EXPECT_EQ(h.occlusions.size(), s.occlusions.size()) << h.name;
    EXPECT_EQ(h.excursions.size(), s.excursions.size()) << h.name;
    EXPECT_EQ(all[i].size(), s.frames) << h.name;
    const cv::Mat target = value_of(target_appearance(h, test::sample_dir()));
    cv::Scalar mean, deviation;
    cv::meanStdDev(target, mean, deviation);
    EXPECT_GT(deviation[0] + deviation[1] + deviation[2], 20) << h.name << ": a flat target";
  }
}

// Fresh sets: each standard script's motions with a target and a background
// drawn by the set's number, the same on every call, another draw for another
// number, never a target over its own photograph; every picture renders.
TEST(Generator, FreshSetsDrawOtherPicturesForEachNumber) {
  const std::vector<SyntheticScript> standard = standard_scripts();
  std::set<std::string> pairs_seen;
  for (int set = 1; set <= 6; ++set) {
    const std::vector<SyntheticScript> fresh = fresh_scripts(set), again = fresh_scripts(set);
    ASSERT_EQ(fresh.size(), standard.size());
    for (std::size_t i = 0; i < fresh.size(); ++i) {
      const SyntheticScript &f = fresh[i], &s = standard[i];
      EXPECT_EQ(f.name, "fresh" + std::to_string(set) + "_" + s.name);
      EXPECT_EQ(f.background, again[i].background);
      EXPECT_EQ(f.target_image, again[i].target_image);
      EXPECT_EQ(f.seed, again[i].seed);
      EXPECT_NE(f.seed, s.seed) << f.name;
      EXPECT_NE(f.background, f.target_image) << f.name;
      EXPECT_EQ(f.frames, s.frames) << f.name;
      EXPECT_EQ(f.frame_size, s.frame_size) << f.name;
      EXPECT_EQ(f.occlusions.size(), s.occlusions.size()) << f.name;
      EXPECT_EQ(f.distractor, s.distractor) << f.name;
      pairs_seen.insert(f.background + " " + f.target_image);
    }
  }
  // 60 scripts: the draws vary (a fixed pairing would give 10).
  EXPECT_GT(pairs_seen.size(), 40u);
  EXPECT_NE(fresh_scripts(1)[0].seed, fresh_scripts(2)[0].seed);
  // Every picture the sets draw from is there and renders (a few frames of each).
  for (int set = 1; set <= 3; ++set) {
    std::vector<SyntheticScript> fresh = fresh_scripts(set);
    for (SyntheticScript& s : fresh) s.frames = 3;
    const std::vector<Sequence> all = value_of(generate_sequences(test::sample_dir(), fresh));
    EXPECT_EQ(all.size(), fresh.size());
  }
}

TEST(Generator, IsDeterministic) {
  const std::vector<Sequence> a = value_of(generate_sequences(test::sample_dir()));
  const std::vector<Sequence> b = value_of(generate_sequences(test::sample_dir()));
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ASSERT_EQ(a[k].truth.size(), b[k].truth.size());
    for (int i = 0; i < a[k].size(); ++i) {
      EXPECT_EQ(a[k].truth[i], b[k].truth[i]);
      EXPECT_EQ(a[k].visible[i], b[k].visible[i]);
    }
    // Frames in a different order in the second run: each renders on its own.
    for (int i = 0; i < a[k].size(); i += 37) {
      const int j = a[k].size() - 1 - i;
      const cv::Mat fa = value_of(a[k].frame(j)), fb = value_of(b[k].frame(j));
      ASSERT_EQ(fa.size(), a[k].frame_size);
      ASSERT_EQ(fa.type(), CV_8UC3);
      EXPECT_EQ(frame_hash(fa), frame_hash(fb)) << a[k].name << " frame " << j;
    }
  }
  EXPECT_NE(frame_hash(value_of(a[0].frame(1))), frame_hash(value_of(a[0].frame(2))));
  // One sequence with everything (blur, lighting, noise, occluder) frame by frame.
  const auto mixed = std::find_if(a.begin(), a.end(), [](const Sequence& s) { return s.name == "mixed"; });
  ASSERT_NE(mixed, a.end());
  const Sequence& again = b[static_cast<std::size_t>(mixed - a.begin())];
  for (int i = 0; i < mixed->size(); ++i)
    EXPECT_EQ(frame_hash(value_of(mixed->frame(i))), frame_hash(value_of(again.frame(i)))) << i;
  EXPECT_EQ(a[0].frame(a[0].size()).error(),
            "no frame " + std::to_string(a[0].size()) + " (the sequence has " + std::to_string(a[0].size()) + ")");
}

TEST(Generator, NamesAMissingImageABadCropAndAnInvalidScript) {
  SyntheticScript script = standard_scripts().front();
  EXPECT_EQ(generate_sequence(script, "/nonexistent").error(), "cannot read image /nonexistent/" + script.background);
  EXPECT_EQ(target_appearance(script, "/nonexistent").error(), "cannot read image /nonexistent/" + script.target_image);
  script.target_crop = cv::Rect(0, 0, 100000, 10);
  EXPECT_EQ(generate_sequence(script, test::sample_dir()).error(),
            script.target_image + ": crop rectangle outside the image");
  EXPECT_EQ(target_appearance(script, test::sample_dir()).error(),
            script.target_image + ": crop rectangle outside the image");
  script.frames = 0;
  EXPECT_EQ(generate_sequence(script, test::sample_dir()).error(), script.name + ": invalid script");
}

// Where the target's picture, scaled to the truth box, matches the frame best
// within `margin` pixels of the box, relative to the box; `peak` is the
// normalised correlation there.
cv::Point best_match_offset(const cv::Mat& frame, const cv::Rect& box, const cv::Mat& target, int margin,
                            double& peak) {
  cv::Mat area, picture, score;
  cv::cvtColor(frame(box + cv::Size(2 * margin, 2 * margin) - cv::Point(margin, margin)), area, cv::COLOR_BGR2GRAY);
  cv::resize(target, picture, box.size(), 0, 0, cv::INTER_AREA);
  cv::cvtColor(picture, picture, cv::COLOR_BGR2GRAY);
  cv::matchTemplate(area, picture, score, cv::TM_CCOEFF_NORMED);
  cv::Point at;
  cv::minMaxLoc(score, nullptr, &peak, nullptr, &at);
  return at - cv::Point(margin, margin);
}

TEST(Generator, TruthBoxesFrameTheRenderedTarget) {
  constexpr int kMargin = 8;
  for (const SyntheticScript& script : standard_scripts()) {
    if (script.name != "scale" && script.name != "distractor") continue;  // neither occluded nor rotated
    const Sequence s = value_of(generate_sequence(script, test::sample_dir()));
    const cv::Mat target = value_of(target_appearance(script, test::sample_dir()));
    const cv::Rect frame_rect(0, 0, s.frame_size.width, s.frame_size.height);
    int checked = 0;
    for (int i = 0; i < s.size(); i += 10) {
      const cv::Rect2d& t = s.truth[i];
      const cv::Rect box(cvRound(t.x), cvRound(t.y), cvRound(t.width), cvRound(t.height));
      const cv::Rect search = box + cv::Size(2 * kMargin, 2 * kMargin) - cv::Point(kMargin, kMargin);
      if ((search & frame_rect) != search) continue;
      double peak = 0;
      const cv::Point offset = best_match_offset(value_of(s.frame(i)), box, target, kMargin, peak);
      // The picture sits where the truth says, to the rounding of the box.
      EXPECT_LE(std::abs(offset.x), 1) << s.name << " frame " << i;
      EXPECT_LE(std::abs(offset.y), 1) << s.name << " frame " << i;
      EXPECT_GT(peak, 0.8) << s.name << " frame " << i;
      ++checked;
    }
    EXPECT_GE(checked, 20) << s.name;
  }
}

// A round target is the rectangular one inside the ellipse inscribed in its
// box, and the scene behind it in the box's corners.
TEST(Generator, ARoundTargetShowsTheSceneInItsBoxsCorners) {
  const std::vector<SyntheticScript> rectangles = standard_scripts();
  const std::vector<SyntheticScript> rounds = with_round_targets(rectangles);
  ASSERT_EQ(rounds.size(), rectangles.size());
  for (std::size_t k = 0; k < rounds.size(); ++k) {
    EXPECT_EQ(rounds[k].name, rectangles[k].name + "@round");
    EXPECT_TRUE(rounds[k].round);
    EXPECT_FALSE(rectangles[k].round);
  }
  const auto scale = std::find_if(rectangles.begin(), rectangles.end(), [](auto& s) { return s.name == "scale"; });
  ASSERT_NE(scale, rectangles.end());  // neither occluded nor rotated
  SyntheticScript round = *scale;
  round.round = true;
  const Sequence rectangle_frames = value_of(generate_sequence(*scale, test::sample_dir()));
  const Sequence round_frames = value_of(generate_sequence(round, test::sample_dir()));
  ASSERT_EQ(round_frames.truth, rectangle_frames.truth);
  int checked = 0;
  for (int i = 0; i < round_frames.size(); i += 25) {
    const cv::Mat a = value_of(rectangle_frames.frame(i)), b = value_of(round_frames.frame(i));
    const cv::Rect2d& t = round_frames.truth[i];
    if ((t & cv::Rect2d(0, 0, a.cols, a.rows)) != t) continue;
    double inside = 0, corners = 0;
    int inside_count = 0, corner_count = 0;
    for (int y = cvCeil(t.y); y < cvFloor(t.y + t.height); ++y)
      for (int x = cvCeil(t.x); x < cvFloor(t.x + t.width); ++x) {
        const double u = (x + 0.5 - (t.x + t.width / 2)) / (t.width / 2),
                     v = (y + 0.5 - (t.y + t.height / 2)) / (t.height / 2), r = std::hypot(u, v);
        const double difference =
            cv::norm(cv::Vec3d(a.at<cv::Vec3b>(y, x)) - cv::Vec3d(b.at<cv::Vec3b>(y, x)), cv::NORM_L1);
        if (r < 0.8) inside += difference, ++inside_count;
        if (r > 1.2) corners += difference, ++corner_count;
      }
    ASSERT_GT(inside_count, 0);
    ASSERT_GT(corner_count, 0);
    EXPECT_LT(inside / inside_count, 1.0) << "frame " << i;    // the same picture
    EXPECT_GT(corners / corner_count, 20.0) << "frame " << i;  // the scene, not the picture's corners
    ++checked;
  }
  EXPECT_GE(checked, 8);
}

// A turning target shows another part of its picture as it turns, inside the
// same box: the scene and the truth are those of the script without the turn.
TEST(Generator, ATurningTargetChangesWhatItsBoxShowsAndNothingElse) {
  const std::vector<SyntheticScript> still = standard_scripts();
  const std::vector<SyntheticScript> turning = with_turning_targets(still, 60);
  ASSERT_EQ(turning.size(), still.size());
  for (std::size_t k = 0; k < turning.size(); ++k) {
    EXPECT_EQ(turning[k].name, still[k].name + "@turn60");
    EXPECT_EQ(turning[k].turn_deg, 60);
    EXPECT_EQ(still[k].turn_deg, 0);
  }
  const auto scale = std::find_if(still.begin(), still.end(), [](auto& s) { return s.name == "scale"; });
  ASSERT_NE(scale, still.end());  // neither occluded nor rotated
  SyntheticScript turned = *scale;
  turned.turn_deg = 60;
  const Sequence still_frames = value_of(generate_sequence(*scale, test::sample_dir()));
  const Sequence turned_frames = value_of(generate_sequence(turned, test::sample_dir()));
  ASSERT_EQ(turned_frames.truth, still_frames.truth);
  double largest_inside = 0;
  int checked = 0;
  for (int i = 0; i < turned_frames.size(); i += 15) {
    const cv::Mat a = value_of(still_frames.frame(i)), b = value_of(turned_frames.frame(i));
    const cv::Rect2d& t = turned_frames.truth[i];
    if ((t & cv::Rect2d(0, 0, a.cols, a.rows)) != t) continue;
    // Outside the box (a pixel of interpolation aside) the frames are the same.
    cv::Mat outside(a.size(), CV_8U, cv::Scalar(255));
    outside(cv::Rect(cvFloor(t.x) - 1, cvFloor(t.y) - 1, cvCeil(t.width) + 3, cvCeil(t.height) + 3) &
            cv::Rect(0, 0, a.cols, a.rows))
        .setTo(0);
    cv::Mat difference;
    cv::absdiff(a, b, difference);
    EXPECT_EQ(cv::norm(difference, cv::NORM_INF, outside), 0) << "frame " << i;
    const cv::Rect inner(cvCeil(t.x) + 2, cvCeil(t.y) + 2, cvFloor(t.width) - 4, cvFloor(t.height) - 4);
    largest_inside = std::max(largest_inside, cv::mean(difference(inner))[0]);
    ++checked;
  }
  EXPECT_GE(checked, 10);
  EXPECT_GT(largest_inside, 20.0);  // another part of the picture, not the same one moved a little
  // Unturned, the box's middle is the picture's middle (magnified by pi / 2,
  // as the front of a cylinder is seen).
  const cv::Mat a = value_of(still_frames.frame(0)), b = value_of(turned_frames.frame(0));
  const cv::Rect2d& t = turned_frames.truth[0];
  const cv::Rect middle(cvRound(t.x + t.width / 2) - 1, cvCeil(t.y) + 2, 2, cvFloor(t.height) - 4);
  cv::Mat difference;
  cv::absdiff(a(middle), b(middle), difference);
  EXPECT_LT(cv::mean(difference)[0], largest_inside / 4) << largest_inside;
}

TEST(Generator, TheTargetLeavesTheViewAndComesBack) {
  const Sequence s = value_of(generate_sequence(standard_scripts().at(6), test::sample_dir()));
  ASSERT_EQ(s.name, "out_of_view");
  const cv::Rect2d frame_rect(0, 0, s.frame_size.width, s.frame_size.height);
  int reappearances = 0;
  for (int i = 1; i < s.size(); ++i) {
    if (!s.visible[i]) {  // no occluder here: not visible means (next to) nothing inside the frame
      const cv::Rect2d inside = s.truth[i] & frame_rect;
      EXPECT_TRUE(inside.width < 1 || inside.height < 1) << "frame " << i;
    }
    reappearances += s.visible[i] && !s.visible[i - 1];
  }
  EXPECT_EQ(reappearances, 2);
}

// The OTB layout written for other tools (the benchmark's --export): read_otb
// gives back every frame and box exactly, hidden frames as hidden.
TEST(OtbWriter, WritesWhatReadOtbGivesBackExactly) {
  Sequence s = value_of(generate_sequence(standard_scripts().at(6), test::sample_dir()));
  ASSERT_EQ(s.name, "out_of_view");
  truncate(s, 90);  // the camera looks away from frame 75 on
  const TempDir dir;
  const std::string folder = (dir.path() / "out_of_view").string();
  ASSERT_TRUE(write_otb(s, folder).ok());
  EXPECT_TRUE(fs::is_regular_file(dir.path() / "out_of_view/img/0090.png"));
  const Sequence back = value_of(read_otb(folder));
  EXPECT_EQ(back.name, "out_of_view");
  ASSERT_EQ(back.size(), 90);
  EXPECT_EQ(back.frame_size, s.frame_size);
  int hidden = 0;
  for (int i = 0; i < s.size(); ++i) {
    EXPECT_EQ(back.visible[i], s.visible[i]) << "frame " << i;
    if (s.visible[i]) {
      EXPECT_EQ(back.truth[i], s.truth[i]) << "frame " << i;  // every bit of every number
    }
    hidden += !s.visible[i];
  }
  EXPECT_GE(hidden, 10);
  for (const int i : {0, 45, 89}) {
    const cv::Mat written = value_of(s.frame(i)), read = value_of(back.frame(i));
    ASSERT_EQ(read.size(), written.size());
    EXPECT_EQ(cv::norm(read, written, cv::NORM_INF), 0.0) << "frame " << i;
  }
  // Written again, fewer frames would leave the first export's last ones to be read as this one's.
  truncate(s, 60);
  EXPECT_EQ(write_otb(s, folder).message(), folder + "/img: already holds files; export into a folder without them");
}

// A camera of a third the frame rate and half the resolution: every third
// frame, each halved by area averaging, the truth with it; the name says so.
TEST(Resample, KeepsEveryNthFrameScaledWithItsTruthAndNamesBadValues) {
  Sequence s = value_of(generate_sequence(standard_scripts().at(6), test::sample_dir()));
  truncate(s, 90);
  const Sequence original = s;
  ASSERT_TRUE(resample(s, 3, 0.5).ok());
  EXPECT_EQ(s.name, "out_of_view@every3@scale0.5");
  ASSERT_EQ(s.size(), 30);
  EXPECT_EQ(s.frame_size, cv::Size(160, 120));
  for (int i = 0; i < s.size(); ++i) {
    const cv::Rect2d& b = original.truth[static_cast<std::size_t>(3 * i)];
    EXPECT_EQ(s.truth[static_cast<std::size_t>(i)], cv::Rect2d(b.x / 2, b.y / 2, b.width / 2, b.height / 2));
    EXPECT_EQ(s.visible[static_cast<std::size_t>(i)], original.visible[static_cast<std::size_t>(3 * i)]);
  }
  for (const int i : {0, 17, 29}) {
    cv::Mat expected;
    cv::resize(value_of(original.frame(3 * i)), expected, cv::Size(160, 120), 0, 0, cv::INTER_AREA);
    const cv::Mat got = value_of(s.frame(i));
    ASSERT_EQ(got.size(), expected.size());
    EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << "frame " << i;
  }
  EXPECT_EQ(s.frame(30).error(), "no frame 30 (the sequence has 30)");
  Sequence same = original;
  ASSERT_TRUE(resample(same, 1, 1.0).ok());
  EXPECT_EQ(same.name, "out_of_view");
  EXPECT_EQ(same.size(), 90);
  EXPECT_THAT(resample(same, 0, 1.0).message(), ::testing::HasSubstr("every 0"));
  EXPECT_EQ(resample(same, 1, 20.0).message(), "scale 20: expected a factor from 0.1 to 8");
  Sequence tiny = original;
  tiny.frame_size = {12, 9};
  EXPECT_EQ(resample(tiny, 1, 0.1).message(), "out_of_view: its 12x9 frames scaled by 0.1 are under 2x2");
}

// The generated `out_of_view` sequence's first `count` frames: what the
// views of other cameras below are made from.
Sequence out_of_view_frames(int count) {
  Sequence s = value_of(generate_sequence(standard_scripts().at(6), test::sample_dir()));
  truncate(s, count);
  return s;
}

// A compressing camera's view: each frame through OpenCV's JPEG encoder at the
// quality asked, the truth unchanged, the name marked; a quality out of range
// refused with the value.
TEST(MakeJpeg, GivesEachFrameThroughAJpegOfTheQualityAsked) {
  const Sequence original = out_of_view_frames(20);
  Sequence s = original;
  ASSERT_TRUE(make_jpeg(s, 30).ok());
  EXPECT_EQ(s.name, "out_of_view@jpeg30");
  EXPECT_EQ(s.truth, original.truth);
  const cv::Mat colour = value_of(original.frame(7)), got = value_of(s.frame(7));
  std::vector<uchar> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", colour, bytes, {cv::IMWRITE_JPEG_QUALITY, 30}));
  EXPECT_EQ(cv::norm(got, cv::imdecode(bytes, cv::IMREAD_COLOR), cv::NORM_INF), 0.0);
  EXPECT_GT(cv::norm(got, colour, cv::NORM_INF), 0.0) << "not compressed";
  Sequence bad = original;
  EXPECT_EQ(make_jpeg(bad, 0).message(), "jpeg quality 0: expected a whole number from 1 to 100");
  EXPECT_EQ(make_jpeg(bad, 101).message(), "jpeg quality 101: expected a whole number from 1 to 100");
  EXPECT_EQ(bad.name, "out_of_view");
}

// A drifting white balance: red and blue swung by the amount asked in
// opposite ways over kWhiteBalancePeriod frames, green and the truth
// unchanged, the first frame as it was; an amount out of range refused.
TEST(MakeWhiteBalance, SwingsRedAndBlueOppositeWaysAndLeavesTheTruth) {
  const Sequence original = out_of_view_frames(60);
  for (const double out_of_range : {0.0, 0.6}) {
    Sequence bad = original;
    char expected[80];
    std::snprintf(expected, sizeof expected, "white balance %g: expected an amount from 0.01 to 0.5", out_of_range);
    EXPECT_EQ(make_white_balance(bad, out_of_range).message(), expected);
    EXPECT_EQ(bad.name, "out_of_view");
  }
  Sequence s = original;
  ASSERT_TRUE(make_white_balance(s, 0.2).ok());
  EXPECT_EQ(s.name, "out_of_view@wb0.2");
  EXPECT_EQ(s.truth, original.truth);
  EXPECT_EQ(cv::norm(value_of(s.frame(0)), value_of(original.frame(0)), cv::NORM_INF), 0.0);
  const int quarter = static_cast<int>(kWhiteBalancePeriod / 4);  // the swing's peak: red 1.2, blue 0.8
  const cv::Scalar before = cv::mean(value_of(original.frame(quarter))), after = cv::mean(value_of(s.frame(quarter)));
  EXPECT_NEAR(after[2] / before[2], 1.2, 0.02);
  EXPECT_NEAR(after[1] / before[1], 1.0, 1e-9);
  EXPECT_NEAR(after[0] / before[0], 0.8, 0.02);
}

// A monochrome camera's view: each frame's gray in all three channels, the
// truth and the frames' count unchanged, the name marked.
TEST(MakeGray, GivesEachFramesGrayInAllThreeChannels) {
  const Sequence original = out_of_view_frames(20);
  Sequence s = original;
  make_gray(s);
  EXPECT_EQ(s.name, "out_of_view@gray");
  EXPECT_EQ(s.truth, original.truth);
  EXPECT_EQ(s.visible, original.visible);
  for (const int i : {0, 19}) {
    const cv::Mat colour = value_of(original.frame(i)), got = value_of(s.frame(i));
    ASSERT_EQ(got.type(), CV_8UC3);
    cv::Mat gray;
    cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
    std::vector<cv::Mat> channels;
    cv::split(got, channels);
    for (const cv::Mat& c : channels) EXPECT_EQ(cv::norm(c, gray, cv::NORM_INF), 0.0) << "frame " << i;
  }
}

TEST(OtbWriter, NamesWhatItCannotWrite) {
  Sequence video;
  video.name = "vtest@0+1+2+3+4";
  video.truth_known = false;
  EXPECT_EQ(write_otb(video, "anywhere").message(), "vtest@0+1+2+3+4: no truth to write (only its first box is known)");
  const TempDir dir;
  write_file(dir.path() / "a_file", "not a folder");
  Sequence one;
  one.name = "one";
  const std::string under_a_file = (dir.path() / "a_file" / "one").string();
  const Status written = write_otb(one, under_a_file);
  EXPECT_THAT(written.message(), ::testing::StartsWith(under_a_file + "/img: cannot be made"));
}

// ------------------------------------------------------------------ scoring

TEST(Scoring, HandMadeTrackGivesTheExpectedMeasures) {
  const cv::Rect2d t(10, 10, 20, 20);
  // Frame 0 is the initialisation (never scored, here nonsense); frame 3 has no target.
  const std::vector<cv::Rect2d> truth(6, t);
  const std::vector<bool> visible{true, true, true, false, true, true};
  const std::vector<TrackedFrame> track{
      {cv::Rect2d(500, 500, 1, 1), false, 100}, {t, true, 1},  // IoU 1, error 0
      {t + cv::Point2d(4, 0), true, 2},                        // IoU 320/480 = 2/3, error 4
      {cv::Rect2d(90, 90, 20, 20), true, 3},                   // invisible: unscored, claims tracking
      {t + cv::Point2d(10, 0), false, 4},                      // IoU 200/600 = 1/3, error 10
      {t + cv::Point2d(0, 25), false, 5},                      // IoU 0, error 25
  };
  const TrackScore s = value_of(score_track(truth, visible, track));
  EXPECT_EQ(s.scored_frames, 4);
  EXPECT_DOUBLE_EQ(s.mean_center_error, (0 + 4 + 10 + 25) / 4.0);
  EXPECT_DOUBLE_EQ(s.precision20, 0.75);
  EXPECT_DOUBLE_EQ(s.success50, 0.5);
  // Shares above thresholds k/20: 3/4 for k = 0..6, 2/4 for k = 7..13, 1/4 for k = 14..19, 0 at 1.
  EXPECT_NEAR(s.success_auc, (7 * 3 + 7 * 2 + 6 * 1) / (4.0 * 21), 1e-12);
  EXPECT_EQ(s.frames_lost, 2);
  EXPECT_DOUBLE_EQ(s.honest_lost, 0.0);
  EXPECT_EQ(s.claimed_off_target, 0);  // frame 5 misses the target but does not claim it; frame 3 is invisible
  EXPECT_EQ(s.reappearances, 1);
  EXPECT_EQ(s.max_reacquire_delay, -1);  // frames 4 and 5 do not claim tracking
  EXPECT_EQ(s.reacquire_misses, 1);
  EXPECT_DOUBLE_EQ(s.ms_per_frame, 3.0);
}

TEST(Scoring, PerfectTrackScoresAsOtbDoes) {
  const std::vector<cv::Rect2d> truth(11, cv::Rect2d(3, 4, 15, 9));
  const std::vector<bool> visible(11, true);
  std::vector<TrackedFrame> track;
  for (const cv::Rect2d& box : truth) track.push_back({box, true, 0});
  const TrackScore s = value_of(score_track(truth, visible, track));
  EXPECT_DOUBLE_EQ(s.mean_center_error, 0);
  EXPECT_DOUBLE_EQ(s.precision20, 1);
  EXPECT_NEAR(s.success_auc, 20.0 / 21, 1e-12);  // IoU 1 is not above the threshold 1
  EXPECT_DOUBLE_EQ(s.success50, 1);
  EXPECT_EQ(s.frames_lost, 0);
  EXPECT_LT(s.honest_lost, 0);  // no invisible frame
  EXPECT_EQ(s.reappearances, 0);
}

TEST(Scoring, ReacquisitionDelayAndHonesty) {
  const cv::Rect2d t(0, 0, 10, 10), far(100, 100, 10, 10);
  //                           0     1     2      3      4      5     6     7     8      9     10    11
  const std::vector<bool> visible{true, true, false, false, false, true, true, true, false, true, true, true};
  const std::vector<cv::Rect2d> truth(visible.size(), t);
  std::vector<TrackedFrame> track(visible.size(), TrackedFrame{t, true, 0});
  track[2].tracking = track[3].tracking = false;  // honest on 2 of the first 3 invisible frames
  track[5].box = far;                             // reappears at 5: wrong box at 5,
  track[6].tracking = false;                      // lost at 6, right at 7: delay 2
  track[8].tracking = false;                      // honest; reappears at 9: right at once, delay 0
  const TrackScore s = value_of(score_track(truth, visible, track));
  EXPECT_EQ(s.reappearances, 2);
  EXPECT_EQ(s.max_reacquire_delay, 2);
  EXPECT_EQ(s.reacquire_misses, 0);
  EXPECT_DOUBLE_EQ(s.honest_lost, 3.0 / 4);
  EXPECT_EQ(s.frames_lost, 4);
  EXPECT_EQ(s.scored_frames, 7);
  EXPECT_EQ(s.claimed_off_target, 1);  // frame 5: claimed, on `far`
}

TEST(Scoring, AClaimedBoxThatMissesTheTargetInViewIsAFalseLock) {
  const cv::Rect2d t(10, 10, 20, 20);
  const std::vector<bool> visible{true, true, true, true, true, false};
  const std::vector<cv::Rect2d> truth(visible.size(), t);
  const std::vector<TrackedFrame> track{
      {t, true, 0},
      {t + cv::Point2d(19, 0), true, 0},   // overlaps by a column: not off the target
      {t + cv::Point2d(20, 0), true, 0},   // touches its edge only: IoU 0, claimed
      {t + cv::Point2d(0, 60), true, 0},   // far off, claimed
      {t + cv::Point2d(0, 60), false, 0},  // far off, not claimed
      {t + cv::Point2d(0, 60), true, 0},   // the target out of view: honest_lost's, not this
  };
  const TrackScore s = value_of(score_track(truth, visible, track));
  EXPECT_EQ(s.claimed_off_target, 2);
  EXPECT_DOUBLE_EQ(s.honest_lost, 0.0);
}

TEST(Scoring, IouAndCenterError) {
  EXPECT_DOUBLE_EQ(iou({0, 0, 10, 10}, {5, 0, 10, 10}), 50.0 / 150);
  EXPECT_DOUBLE_EQ(iou({0, 0, 10, 10}, {20, 0, 10, 10}), 0);
  EXPECT_DOUBLE_EQ(iou({0, 0, 0, 0}, {0, 0, 0, 0}), 0);
  EXPECT_DOUBLE_EQ(center_error({0, 0, 10, 10}, {3, 4, 10, 10}), 5);
  EXPECT_EQ(score_track({{0, 0, 1, 1}}, {true, false}, {{}}).error(),
            "score_track: truth, visibility and track differ in length");
}

}  // namespace
}  // namespace saccade::bench
