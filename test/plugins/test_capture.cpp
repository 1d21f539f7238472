#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <algorithm>
#include <fstream>
#include <filesystem>
#include <sys/stat.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <spdlog/sinks/ringbuffer_sink.h>

#include "readers.hpp"
#include "saccade/log.hpp"
#include "support.hpp"

namespace saccade {
namespace {

using test::sample_path;

std::unique_ptr<testing::NodeHarness> harness(const std::string& xml) {
  auto h = testing::NodeHarness::create(xml);
  if (!h.ok()) throw std::runtime_error(h.error());
  return std::move(h).value();
}

// A capture node run to its end, with what it logged meanwhile.
struct RunToEnd {
  std::unique_ptr<testing::NodeHarness> node;
  int frames = 0;
  Status end;
  std::vector<std::string> logged;
  // Lines logged that contain every one of `parts`.
  int lines_with(std::initializer_list<std::string> parts) const {
    return static_cast<int>(std::count_if(logged.begin(), logged.end(), [&](const std::string& line) {
      return std::all_of(parts.begin(), parts.end(),
                         [&](const std::string& part) { return line.find(part) != std::string::npos; });
    }));
  }
};
RunToEnd run_to_end(const std::string& xml) {
  auto ring = std::make_shared<spdlog::sinks::ringbuffer_sink_mt>(64);
  log().sinks().push_back(ring);
  // (Taken off the library's logger however the run ends, a throw included.)
  struct Unhook {
    ~Unhook() { log().sinks().pop_back(); }
  } unhook;
  RunToEnd run;
  run.node = harness(xml);
  while ((run.end = run.node->process()).ok()) ++run.frames;
  run.logged = ring->last_formatted();
  return run;
}

TEST(CaptureVideo, ReadsEveryFrameOfVtestWithMediaTimestamps) {
  auto h = harness("<node plugin=\"capture.video\"><param name=\"path\" value=\"" + sample_path("vtest.avi") +
                   "\"/><param name=\"rate\" value=\"fast\"/></node>");
  int frames = 0;
  Status s;
  while ((s = h->process()).ok()) ++frames;
  EXPECT_TRUE(s.is_end_of_stream()) << s.message();
  EXPECT_EQ(frames, 795);
  const auto& out = h->outputs("image");
  ASSERT_EQ(out.size(), 795u);
  auto first = std::dynamic_pointer_cast<const Image>(out[0]);
  auto last = std::dynamic_pointer_cast<const Image>(out.back());
  EXPECT_EQ(first->mat.size(), cv::Size(768, 576));
  EXPECT_EQ(first->mat.type(), CV_8UC1);
  EXPECT_EQ(last->frame_id, 794);
  EXPECT_EQ(last->timestamp_ns, 79'400'000'000) << "10 fps: frame k at k * 100 ms";
  EXPECT_GT(first->origin_ns, 0);
  EXPECT_EQ(h->counter("frames_unread"), 0u) << "every frame its header announces came";
}

// A video whose frames end before its header's count (a recording cut off
// while written, a copy that stopped) ends there, as a video does, but says
// so and counts what it could not give: its frames are not silently dropped.
TEST(CaptureVideo, AVideoCutShortSaysSoAndCountsTheFramesItCouldNotGive) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("saccade_cut_short_" + std::to_string(getpid()) + ".avi");
  constexpr int kWritten = 60;
  ASSERT_TRUE(test::write_cut_short_video(path.string(), kWritten));

  const RunToEnd run = run_to_end(R"(<node plugin="capture.video"><param name="path" value=")" + path.string() +
                                  R"("/><param name="rate" value="fast"/></node>)");
  EXPECT_TRUE(run.end.is_end_of_stream()) << run.end.message();
  EXPECT_GT(run.frames, 0);
  EXPECT_LT(run.frames, kWritten - 2);
  EXPECT_EQ(run.node->counter("frames_unread"), static_cast<uint64_t>(kWritten - run.frames));
  EXPECT_EQ(
      run.lines_with({path.string() + ": the video ended after " + std::to_string(run.frames) + " of the 60 frames"}),
      1)
      << "said once, naming the file and both counts";
  std::filesystem::remove(path);
}

TEST(CaptureVideo, FramesAreMadeWithTheAllocatorAConsumerOffers) {
  const std::string path = sample_path("vtest.avi");
  for (const char* color : {"gray", "color"}) {  // vtest is colour: decoded in place, or converted into it
    const std::string xml = R"(<node plugin="capture.video"><param name="path" value=")" + path +
                            R"("/><param name="rate" value="fast"/><param name="color" value=")" + color +
                            R"("/></node>)";
    test::NamedAllocator ring;  // outlives the harnesses' pooled frames it made
    auto plain = harness(xml), offered = harness(xml);
    offered->set_frame_allocator("image", &ring);
    for (int i = 0; i < 5; ++i) {
      ASSERT_TRUE(plain->process().ok());
      ASSERT_TRUE(offered->process().ok());
      auto a = plain->last<Image>("image");
      auto b = offered->last<Image>("image");
      ASSERT_NE(b->mat.u, nullptr);
      EXPECT_EQ(b->mat.u->currAllocator, &ring) << color << " frame " << i;
      EXPECT_EQ(b->mat.type(), a->mat.type());
      EXPECT_EQ(test::max_abs_diff(a->mat, b->mat), 0) << color << " frame " << i;
    }
    EXPECT_GE(ring.made, 5);
  }
}

TEST(CaptureVideo, LoopsWithIncreasingTimestampsAndResizes) {
  auto h = harness("<node plugin=\"capture.video\"><param name=\"path\" value=\"" + sample_path("tree.avi") +
                   "\"/><param name=\"rate\" value=\"fast\"/><param name=\"loop\" value=\"true\"/>"
                   "<param name=\"resize\" value=\"160x120\"/><param name=\"color\" value=\"color\"/></node>");
  for (int i = 0; i < 500; ++i) ASSERT_TRUE(h->process().ok()) << i;
  const auto& out = h->outputs("image");
  for (std::size_t i = 1; i < out.size(); ++i) ASSERT_GT(out[i]->timestamp_ns, out[i - 1]->timestamp_ns);
  auto img = std::dynamic_pointer_cast<const Image>(out.back());
  EXPECT_EQ(img->mat.size(), cv::Size(160, 120));
  EXPECT_EQ(img->mat.type(), CV_8UC3);
}

TEST(CaptureVideo, MissingFileIsAClearError) {
  auto h =
      testing::NodeHarness::create(R"(<node plugin="capture.video"><param name="path" value="/no/such.avi"/></node>)");
  EXPECT_FALSE(h.ok());
  EXPECT_THAT(h.error(), ::testing::HasSubstr("/no/such.avi: no such video file"));
}

TEST(CaptureImages, ReadsTheSequenceUpToTheFirstGap) {
  // left01..left09 exist, left10 does not.
  auto h = harness("<node plugin=\"capture.images\"><param name=\"pattern\" value=\"" +
                   sample_path("left01.jpg").substr(0, sample_path("left01.jpg").size() - 6) +
                   "%02d.jpg\"/><param name=\"rate\" value=\"fast\"/></node>");
  int n = 0;
  while (h->process().ok()) ++n;
  EXPECT_EQ(n, 9);
  auto img = h->last<Image>("image");
  EXPECT_EQ(img->mat.size(), cv::Size(640, 480));
}

TEST(CaptureImage, RepeatsOneImageWithoutCopying) {
  auto h = harness("<node plugin=\"capture.image\"><param name=\"path\" value=\"" + sample_path("aloeL.jpg") +
                   "\"/><param name=\"count\" value=\"3\"/><param name=\"rate\" value=\"fast\"/>"
                   "<param name=\"color\" value=\"unchanged\"/></node>");
  while (h->process().ok()) {}
  const auto& out = h->outputs("image");
  ASSERT_EQ(out.size(), 3u);
  auto a = std::dynamic_pointer_cast<const Image>(out[0]);
  auto c = std::dynamic_pointer_cast<const Image>(out[2]);
  EXPECT_EQ(a->mat.data, c->mat.data);
  EXPECT_EQ(a->mat.size(), cv::Size(1282, 1110));
}

TEST(CaptureStereo, TheAloePairComesOutTimeMatched) {
  auto h = harness("<node plugin=\"capture.stereo\"><param name=\"left_path\" value=\"" + sample_path("aloeL.jpg") +
                   "\"/><param name=\"right_path\" value=\"" + sample_path("aloeR.jpg") +
                   "\"/><param name=\"count\" value=\"4\"/><param name=\"rate\" value=\"fast\"/></node>");
  int n = 0;
  while (h->process().ok()) ++n;
  EXPECT_EQ(n, 4);
  const auto& l = h->outputs("left");
  const auto& r = h->outputs("right");
  ASSERT_EQ(l.size(), 4u);
  ASSERT_EQ(r.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(l[i]->timestamp_ns, r[i]->timestamp_ns);
    EXPECT_EQ(l[i]->frame_id, r[i]->frame_id);
  }
  auto li = std::dynamic_pointer_cast<const Image>(l[0]);
  auto ri = std::dynamic_pointer_cast<const Image>(r[0]);
  EXPECT_EQ(li->mat.size(), cv::Size(1282, 1110));
  EXPECT_EQ(li->camera_id, 0);
  EXPECT_EQ(ri->camera_id, 1);
  EXPECT_GT(cv::norm(li->mat, ri->mat, cv::NORM_L1), 0) << "left and right differ";
}

TEST(CaptureCamera, AbsentDeviceIsAClearError) {
  auto h = testing::NodeHarness::create(
      R"(<node plugin="capture.camera"><param name="device" value="/dev/video97"/></node>)");
  EXPECT_FALSE(h.ok());
  EXPECT_THAT(h.error(), ::testing::HasSubstr("camera '/dev/video97' cannot be opened"));
}

TEST(CaptureCamera, AnIndexPastAnyDeviceIsAClearErrorNotAThrow) {
  auto h = testing::NodeHarness::create(
      R"(<node plugin="capture.camera"><param name="device" value="99999999999"/></node>)");
  EXPECT_FALSE(h.ok());
  EXPECT_THAT(h.error(), ::testing::HasSubstr("camera '99999999999': a V4L2 index is 0..9999"));
}

// Issue 25: after the drives' side restarted, its joint states' clock starts
// at 0 again; the sim's cameras rendered nothing until the new clock passed
// the old one.
TEST(CaptureSimHead, RendersAtOnceWhenTheJointsClockRestarts) {
  auto h = harness(R"(<node plugin="capture.sim_head"><param name="fps" value="25"/></node>)");
  auto state_at = [](int64_t ns) {
    auto s = std::make_shared<JointState>();
    s->position.assign(5, 0.0);
    s->timestamp_ns = ns;
    return s;
  };
  int frames = 0;
  for (int64_t t = 0; t <= 2'000'000'000; t += 40'000'000) {
    h->set("state", state_at(t));
    ASSERT_TRUE(h->process().ok());
  }
  const std::size_t before = h->outputs("left").size();
  ASSERT_GT(before, 40u);
  for (int64_t t = 0; t < 200'000'000; t += 40'000'000) {  // the restarted clock's first 0.2 s
    h->set("state", state_at(t));
    ASSERT_TRUE(h->process().ok());
    ++frames;
  }
  EXPECT_EQ(h->outputs("left").size(), before + frames) << "a frame per period from the restart on";
}

// Issue 25: a FIFO as an image path blocked forever; a huge image was
// decoded (2.8 GB for 20000 x 20000) before anything said no.
TEST(CaptureImage, AFifoAndAnImageLargerThanTheLimitAreErrors) {
  const std::string fifo = (std::filesystem::temp_directory_path() / "saccade_capture_fifo.png").string();
  std::filesystem::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto h = testing::NodeHarness::create(R"(<node plugin="capture.image"><param name="path" value=")" + fifo +
                                        R"("/></node>)");
  EXPECT_FALSE(h.ok());
  EXPECT_THAT(h.error(), ::testing::HasSubstr("not a regular file"));
  std::filesystem::remove(fifo);

  // A PNG whose header says 20000 x 20000 (its pixels need not be there: the
  // size is refused from the header).
  auto crc32 = [](const std::string& bytes) {
    uint32_t c = 0xffffffffu;
    for (unsigned char b : bytes) {
      c ^= b;
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return c ^ 0xffffffffu;
  };
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
                       static_cast<char>(v)};
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    return be32(static_cast<uint32_t>(data.size())) + type + data + be32(crc32(type + data));
  };
  const std::string ihdr = be32(20000) + be32(20000) + std::string("\x08\x00\x00\x00\x00", 5);
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) + chunk("IEND", "");
  const std::string huge = (std::filesystem::temp_directory_path() / "saccade_capture_huge.png").string();
  std::ofstream(huge, std::ios::binary) << png;
  h = testing::NodeHarness::create(R"(<node plugin="capture.image"><param name="path" value=")" + huge +
                                   R"("/></node>)");
  EXPECT_FALSE(h.ok());
  EXPECT_THAT(h.error(), ::testing::HasSubstr("a 20000x20000 image; at most 67108864 pixels are read"));
  std::filesystem::remove(huge);
}

TEST(CaptureSynthetic, TruthIsWhereTheTargetIsDrawnAndTheRightViewIsShifted) {
  // Synthetic data: a textured square over vtest.avi's first frame.
  auto h = harness("<node plugin=\"capture.synthetic\"><param name=\"background\" value=\"" + sample_path("vtest.avi") +
                   "\"/><param name=\"disparity\" value=\"9\"/><param name=\"count\" value=\"20\"/></node>");
  while (h->process().ok()) {}
  ASSERT_EQ(h->outputs("image").size(), 20u);
  ASSERT_EQ(h->outputs("truth").size(), 20u);
  ASSERT_EQ(h->outputs("right").size(), 20u);
  for (std::size_t k = 0; k < 20; ++k) {
    auto left = std::dynamic_pointer_cast<const Image>(h->outputs("image")[k]);
    auto right = std::dynamic_pointer_cast<const Image>(h->outputs("right")[k]);
    auto truth = std::dynamic_pointer_cast<const Region>(h->outputs("truth")[k]);
    EXPECT_EQ(truth->frame_id, left->frame_id);
    EXPECT_EQ(truth->size, cv::Size2d(48, 48));
    cv::Rect target(static_cast<int>(truth->center.x - 24), static_cast<int>(truth->center.y - 24), 48, 48);
    // The target in the right view is the left one moved 9 px to the left.
    EXPECT_EQ(cv::norm(left->mat(target), right->mat(target - cv::Point(9, 0)), cv::NORM_INF), 0);
    if (k > 0) {
      auto prev = std::dynamic_pointer_cast<const Region>(h->outputs("truth")[k - 1]);
      EXPECT_NE(prev->center, truth->center) << "the target moves";
    }
  }
  // Ground truth against an independent look: the truth region differs from the
  // background, the background elsewhere does not.
  auto left = std::dynamic_pointer_cast<const Image>(h->outputs("image")[5]);
  auto other = std::dynamic_pointer_cast<const Image>(h->outputs("image")[15]);
  const auto target_in = [&](std::size_t k) {
    auto truth = std::dynamic_pointer_cast<const Region>(h->outputs("truth")[k]);
    return cv::Rect(static_cast<int>(truth->center.x - 24), static_cast<int>(truth->center.y - 24), 48, 48) &
           cv::Rect(0, 0, left->mat.cols, left->mat.rows);
  };
  cv::Mat diff;
  cv::absdiff(left->mat, other->mat, diff);
  EXPECT_GT(cv::countNonZero(diff(target_in(5)).clone().reshape(1)), 48 * 48 / 3);
  diff(target_in(5)).setTo(cv::Scalar::all(0));
  diff(target_in(15)).setTo(cv::Scalar::all(0));
  EXPECT_EQ(cv::countNonZero(diff.reshape(1)), 0) << "the background outside both targets is the same";
}

TEST(SourceKinds, ClassifiesPaths) {
  using capture::classify_source;
  using capture::SourceKind;
  EXPECT_EQ(classify_source("left%02d.jpg"), SourceKind::kSequence);
  EXPECT_EQ(classify_source("a/b.PNG"), SourceKind::kImage);
  EXPECT_EQ(classify_source("0"), SourceKind::kCamera);
  EXPECT_EQ(classify_source("/dev/video2"), SourceKind::kCamera);
  EXPECT_EQ(classify_source("clip.avi"), SourceKind::kVideo);
}

}  // namespace
}  // namespace saccade

namespace saccade::capture {
namespace {

// A user's file pattern is never a printf format: %s, %n, two numbers or a
// stray % are refused with the pattern named; one %d (with 0 and a width)
// and %% work as printf would have them.
TEST(NumberedPattern, TakesOneNumberAndRefusesEveryOtherConversion) {
  for (const char* bad : {"img_%s.png", "img_%n.png", "img_%d_%d.png", "img_%04d_%s.png", "img.png", "100%", "%%d.png",
                          "img_%ld.png", "img_%x.png"}) {
    const auto parsed = NumberedPattern::parse(bad);
    EXPECT_FALSE(parsed.ok()) << bad;
    EXPECT_THAT(parsed.error(), ::testing::HasSubstr(std::string("'") + bad + "'"));
  }
  EXPECT_EQ(NumberedPattern::parse("img_%04d.png")->name(7), "img_0007.png");
  EXPECT_EQ(NumberedPattern::parse("a%%b_%d.jpg")->name(12), "a%b_12.jpg");
  EXPECT_EQ(NumberedPattern::parse("%3d")->name(5), "  5");
  const auto reader = open_sequence("/nonexistent/img_%s_%n.png", 0, 30);
  EXPECT_FALSE(reader.ok());
  EXPECT_THAT(reader.error(), ::testing::HasSubstr("expected one %d"));
}

// A missing number ends the sequence; images numbered after it are not
// passed over in silence: said once, naming the missing file, and counted.
TEST(CaptureImages, AGapEndsTheSequenceAndTheImagesAfterItAreSaidAndCounted) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("saccade_sequence_gap_" + std::to_string(getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  for (const int i : {1, 2, 3, 4, 5, 7, 8, 9})
    cv::imwrite((dir / ("img_" + std::to_string(i) + ".png")).string(), cv::Mat(8, 8, CV_8UC1, cv::Scalar(i)));
  std::ofstream(dir / "img_x.png") << "not one of its numbers";
  std::ofstream(dir / "other_10.png") << "not its name";

  const RunToEnd run = run_to_end(R"(<node plugin="capture.images"><param name="pattern" value=")" +
                                  (dir / "img_%d.png").string() + R"("/><param name="rate" value="fast"/></node>)");
  EXPECT_TRUE(run.end.is_end_of_stream()) << run.end.message();
  EXPECT_EQ(run.frames, 5);
  EXPECT_EQ(run.node->counter("frames_total"), 5u) << "up to the gap, where it ends";
  EXPECT_EQ(run.node->counter("frames_unread"), 3u);
  EXPECT_EQ(
      run.lines_with({(dir / "img_6.png").string() + " is missing", "the 3 images numbered after it are skipped"}), 1);
  std::filesystem::remove_all(dir);
}

// opencv-doc's chessboard images: left01..left09 and left11..left14, the
// example pattern of capture.images' documentation.
TEST(CaptureImages, OpencvDocsLeftChessboardsEndAtTheMissingTenthAndCountTheFourAfter) {
  const RunToEnd run = run_to_end(R"(<node plugin="capture.images"><param name="pattern" value=")" +
                                  test::sample_dir() + R"(/left%02d.jpg"/><param name="rate" value="fast"/></node>)");
  EXPECT_EQ(run.frames, 9);
  EXPECT_EQ(run.node->counter("frames_total"), 9u);
  EXPECT_EQ(run.node->counter("frames_unread"), 4u);
  EXPECT_EQ(run.lines_with({"left10.jpg is missing", "the 4 images numbered after it are skipped"}), 1);
}

// A reader tells the end of its frames apart from an error.
TEST(FrameReader, EndOfStreamIsNotAnError) {
  const std::string dir = (std::filesystem::temp_directory_path() / "saccade_frame_reader_end").string();
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  cv::imwrite(dir + "/img_1.png", cv::Mat(8, 8, CV_8UC1, cv::Scalar(7)));
  auto reader = open_sequence(dir + "/img_%d.png", 1, 30);
  ASSERT_TRUE(reader.ok()) << reader.error();
  cv::Mat frame;
  int64_t media_ns = 0;
  EXPECT_TRUE((*reader)->read(frame, media_ns).ok());
  EXPECT_EQ(frame.at<uint8_t>(0, 0), 7);
  const Status end = (*reader)->read(frame, media_ns);
  EXPECT_TRUE(end.is_end_of_stream()) << end.message();
  EXPECT_EQ((*reader)->frames_unread(), 0) << "nothing numbered after the end";
  std::ofstream(dir + "/img_2.png") << "not a png";
  const Status broken = (*reader)->read(frame, media_ns);
  EXPECT_TRUE(broken.is_error());
  EXPECT_THAT(broken.message(), ::testing::HasSubstr("img_2.png: cannot decode image"));
}

}  // namespace
}  // namespace saccade::capture
