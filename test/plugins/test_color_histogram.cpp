// The chromaticity and tone histograms the box tracker asks of a
// re-detection (box_min_shared_colors, box_min_shared_tones): real image
// patches (opencv-doc), one of them partly covered, one tinted as the
// benchmark's look-alikes are, one in dimmer light.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <numeric>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "color_histogram.hpp"
#include "support.hpp"

namespace saccade {
namespace {

using namespace saccade::fovea;

cv::Mat read(const std::string& name) { return test::read_sample(name, cv::IMREAD_COLOR); }

double total(const std::vector<float>& shares) { return std::accumulate(shares.begin(), shares.end(), 0.0); }

TEST(ChromaHistogram, OneColourFillsOneBinAndNearlyBlackPixelsAreLeftOut) {
  cv::Mat frame(20, 30, CV_8UC3, cv::Scalar(40, 80, 160));   // B, G, R: r = 4/7, g = 2/7
  frame(cv::Rect(0, 0, 30, 10)).setTo(cv::Scalar(5, 5, 5));  // R + G + B under kDarkestChroma
  std::vector<float> shares;
  chroma_histogram(frame, cv::Rect(-5, -5, 100, 100), shares);  // clipped to the frame
  ASSERT_EQ(shares.size(), static_cast<std::size_t>(kChromaBins * kChromaBins));
  const int r = 160 * kChromaBins / 280, g = 80 * kChromaBins / 280;
  EXPECT_FLOAT_EQ(shares[static_cast<std::size_t>(r * kChromaBins + g)], 1.0f);
  EXPECT_NEAR(total(shares), 1.0, 1e-6);
  EXPECT_DOUBLE_EQ(shared_colors(shares, shares), 1.0);
}

// Each pixel's bins are floor(channel * kChromaBins / (R + G + B)), as a plain
// integer division gives them, over a million random colours of every sum.
TEST(ChromaHistogram, BinsEveryColourAsIntegerDivisionDoes) {
  cv::Mat frame(1024, 1024, CV_8UC3);
  cv::RNG rng(7);
  rng.fill(frame, cv::RNG::UNIFORM, 0, 256);
  frame(cv::Rect(0, 0, 1024, 64)) /= 8;  // dark colours too, near kDarkestChroma
  std::vector<float> shares;
  chroma_histogram(frame, cv::Rect(0, 0, frame.cols, frame.rows), shares);
  std::vector<double> counts(static_cast<std::size_t>(kChromaBins * kChromaBins), 0.0);
  double counted = 0;
  for (int y = 0; y < frame.rows; ++y)
    for (int x = 0; x < frame.cols; ++x) {
      const cv::Vec3b p = frame.at<cv::Vec3b>(y, x);
      const int sum = p[0] + p[1] + p[2];
      if (sum < kDarkestChroma) continue;
      const int r = std::min(kChromaBins - 1, p[2] * kChromaBins / sum);
      const int g = std::min(kChromaBins - 1, p[1] * kChromaBins / sum);
      counts[static_cast<std::size_t>(r * kChromaBins + g)] += 1;
      ++counted;
    }
  for (std::size_t i = 0; i < counts.size(); ++i)
    EXPECT_FLOAT_EQ(shares[i], static_cast<float>(counts[i]) / static_cast<float>(counted)) << "bin " << i;
}

TEST(ChromaHistogram, AGrayFrameOrAnEmptyAreaHasNoColours) {
  std::vector<float> shares;
  chroma_histogram(cv::Mat(20, 20, CV_8UC1, cv::Scalar(100)), cv::Rect(0, 0, 20, 20), shares);
  EXPECT_EQ(total(shares), 0.0);
  chroma_histogram(cv::Mat(20, 20, CV_8UC3, cv::Scalar(40, 80, 160)), cv::Rect(30, 30, 5, 5), shares);
  EXPECT_EQ(total(shares), 0.0);
  EXPECT_EQ(shared_colors(shares, shares), 0.0);
}

// How much colour a target has to be told apart by: none in a monochrome
// camera's frames (one channel, or three equal ones), nor in pixels too dark
// for a chromaticity; a photograph's fruit nearly all, a pixel a little off
// gray counted only beyond the tolerance.
TEST(ColourfulShare, IsNoneInGrayFramesAndTheShareOfPixelsOffGrayInColour) {
  const cv::Mat photo = read("orange.jpg");
  const cv::Rect fruit(150, 150, 200, 200);
  EXPECT_GT(colourful_share(photo, fruit, 0.02), 0.9);
  cv::Mat gray, gray3;
  cv::cvtColor(photo, gray, cv::COLOR_BGR2GRAY);
  cv::cvtColor(gray, gray3, cv::COLOR_GRAY2BGR);
  EXPECT_EQ(colourful_share(gray, fruit, 0.02), 0.0);
  EXPECT_EQ(colourful_share(gray3, fruit, 0.02), 0.0);
  cv::Mat frame(10, 10, CV_8UC3, cv::Scalar(100, 100, 100));
  frame(cv::Rect(0, 0, 10, 3)).setTo(cv::Scalar(100, 100, 112));  // r = 112/312: 0.026 off gray
  frame(cv::Rect(0, 3, 10, 2)).setTo(cv::Scalar(100, 100, 104));  // r = 104/304: 0.009 off
  frame(cv::Rect(0, 5, 10, 2)).setTo(cv::Scalar(3, 3, 20));       // vivid but too dark: left out
  EXPECT_DOUBLE_EQ(colourful_share(frame, cv::Rect(0, 0, 10, 10), 0.02), 30.0 / 80.0);
  EXPECT_DOUBLE_EQ(colourful_share(frame, cv::Rect(0, 0, 10, 10), 0.005), 50.0 / 80.0);
  EXPECT_EQ(colourful_share(frame, cv::Rect(20, 20, 5, 5), 0.02), 0.0);  // outside the frame
}

// What the mean colour cannot tell apart: a third of the target covered by
// something else shares two thirds of its colours and more; the target
// tinted as the benchmark's look-alike is (0.85 of its brightness, blue up
// 14, green down 6, red up 8) shares few.
TEST(SharedColors, APartlyHiddenTargetSharesItsColoursATintedLookAlikeFew) {
  const cv::Mat target = read("baboon.jpg")(cv::Rect(180, 40, 150, 120)).clone();
  std::vector<float> learnt, seen;
  chroma_histogram(target, cv::Rect(0, 0, target.cols, target.rows), learnt);
  cv::Mat covered = target.clone();
  read("fruits.jpg")(cv::Rect(0, 300, 50, 120)).copyTo(covered(cv::Rect(0, 0, 50, 120)));
  chroma_histogram(covered, cv::Rect(0, 0, covered.cols, covered.rows), seen);
  const double partly_hidden = shared_colors(seen, learnt);
  cv::Mat tinted;
  target.convertTo(tinted, CV_8UC3, 0.85, 0);
  cv::add(tinted, cv::Scalar(14, -6, 8), tinted);
  chroma_histogram(tinted, cv::Rect(0, 0, tinted.cols, tinted.rows), seen);
  const double look_alike = shared_colors(seen, learnt);
  std::printf("shared colours: a third covered %.3f, tinted %.3f\n", partly_hidden, look_alike);
  EXPECT_GE(partly_hidden, 0.6);
  EXPECT_LT(look_alike, 0.45);
  EXPECT_DOUBLE_EQ(shared_colors(seen, learnt), shared_colors(learnt, seen));
}

// The tone histogram (box_min_shared_tones): each pixel's gray as a share of
// the area's mean, binned over 0 to kToneTop times it.
TEST(ToneHistogram, BinsEachGrayByItsShareOfTheMeanAndLeavesOutDarkAreas) {
  cv::Mat frame(10, 20, CV_8UC1, cv::Scalar(50));
  frame(cv::Rect(10, 0, 10, 10)).setTo(150);  // mean 100: half at 0.5 of it, half at 1.5
  std::vector<float> shares;
  tone_histogram(frame, cv::Rect(-5, -5, 100, 100), shares);  // clipped to the frame
  ASSERT_EQ(shares.size(), static_cast<std::size_t>(kToneBins));
  const auto bin = [](double of_mean) { return static_cast<std::size_t>(of_mean / kToneTop * kToneBins); };
  EXPECT_FLOAT_EQ(shares[bin(0.5)], 0.5f);
  EXPECT_FLOAT_EQ(shares[bin(1.5)], 0.5f);
  EXPECT_NEAR(total(shares), 1.0, 1e-6);

  // Brighter than kToneTop times the mean: the last bin.
  frame.setTo(10);
  frame.at<uint8_t>(0, 0) = 255;  // mean 11.2: 22.8 times it
  tone_histogram(frame, cv::Rect(0, 0, 20, 10), shares);
  EXPECT_FLOAT_EQ(shares[kToneBins - 1], 1.f / 200);

  frame.setTo(kDarkestTone);
  tone_histogram(frame, cv::Rect(0, 0, 20, 10), shares);
  EXPECT_FLOAT_EQ(shares[bin(1.0)], 1.f) << "as dark as an area with tones can be";
  frame.setTo(kDarkestTone - 1);
  tone_histogram(frame, cv::Rect(0, 0, 20, 10), shares);
  EXPECT_EQ(total(shares), 0.0) << "too dark for tones";
  tone_histogram(frame, cv::Rect(30, 30, 5, 5), shares);
  EXPECT_EQ(total(shares), 0.0) << "outside the frame";
}

// A monochrome camera's frames, read as one channel or as three equal ones,
// give one histogram; a colour frame's (BGR or BGRA) is that of its gray,
// cv::cvtColor's to the last level: over a photograph and over random
// colours, where other rounded weights move some pixels a level and some of
// those across a bin.
TEST(ToneHistogram, IsTheGraysWhateverTheChannels) {
  cv::Mat random(512, 512, CV_8UC3);
  cv::randu(random, 0, 256);
  for (const cv::Mat& colour : {read("baboon.jpg"), random}) {
    const cv::Rect area(0, 0, colour.cols, colour.rows);
    cv::Mat gray, gray3, bgra;
    cv::cvtColor(colour, gray, cv::COLOR_BGR2GRAY);
    cv::cvtColor(gray, gray3, cv::COLOR_GRAY2BGR);
    cv::cvtColor(colour, bgra, cv::COLOR_BGR2BGRA);
    std::vector<float> of_colour, of_bgra, of_gray, of_gray3;
    tone_histogram(colour, area, of_colour);
    tone_histogram(bgra, area, of_bgra);
    tone_histogram(gray, area, of_gray);
    tone_histogram(gray3, area, of_gray3);
    EXPECT_EQ(of_gray, of_gray3);
    EXPECT_EQ(of_colour, of_gray);
    EXPECT_EQ(of_bgra, of_gray);
  }
}

// What the tones tell apart where there is no colour: a textured target seen
// in dimmer light shares nearly all of them (relative to the mean, the light
// cancels), a third of it covered by other texture most; flat background and
// a patch of other contrast few.
TEST(SharedTones, AreTheSameInOtherLightAndFewForFlatBackgroundOrOtherContrast) {
  cv::Mat gray;
  cv::cvtColor(read("baboon.jpg"), gray, cv::COLOR_BGR2GRAY);
  const cv::Mat target = gray(cv::Rect(180, 40, 150, 120)).clone();
  const cv::Rect whole(0, 0, target.cols, target.rows);
  std::vector<float> learnt, seen;
  tone_histogram(target, whole, learnt);
  const auto shared_with = [&](const cv::Mat& look) {
    tone_histogram(look, cv::Rect(0, 0, look.cols, look.rows), seen);
    return shared_colors(seen, learnt);
  };
  cv::Mat dimmer;
  target.convertTo(dimmer, CV_8U, 0.6, 0);
  cv::Mat covered = target.clone();
  cv::Mat fruit;
  cv::cvtColor(read("fruits.jpg"), fruit, cv::COLOR_BGR2GRAY);
  fruit(cv::Rect(0, 300, 50, 120)).copyTo(covered(cv::Rect(0, 0, 50, 120)));
  cv::Mat flat;
  cv::GaussianBlur(target, flat, cv::Size(0, 0), 30);
  cv::Mat harsher;
  target.convertTo(harsher, CV_8U, 2.0, -cv::mean(target)[0]);  // twice the contrast (clipped at 0 and 255)
  const double in_other_light = shared_with(dimmer), partly_hidden = shared_with(covered),
               flat_background = shared_with(flat), other_contrast = shared_with(harsher);
  std::printf("shared tones: dimmer %.3f, a third covered %.3f, blurred flat %.3f, twice the contrast %.3f\n",
              in_other_light, partly_hidden, flat_background, other_contrast);
  EXPECT_GE(in_other_light, 0.9);
  EXPECT_GE(partly_hidden, 0.7);
  EXPECT_LT(flat_background, 0.6);
  EXPECT_LT(other_contrast, 0.6);
}

// The whole-frame search's colour evidence (box_color_proposals): a patch of
// the baboon's face (red and blue) pasted into a photograph of fruit; the
// target's colours are the patch's. Cells over the patch score high, the
// fruit low (its red apples share some of the face's colours: 0.33 on average).
TEST(ColorLikelihood, TheTargetsColoursScoreHighWhereTheSceneRarelyHasThem) {
  cv::Mat scene = read("fruits.jpg").clone();
  const cv::Mat target = read("baboon.jpg")(cv::Rect(180, 40, 150, 120));
  const cv::Rect pasted(300, 200, 150, 120);
  target.copyTo(scene(pasted));
  std::vector<float> learnt;
  chroma_histogram(target, cv::Rect(0, 0, target.cols, target.rows), learnt);
  // Cells of 10x10 pixels.
  const cv::Size cells(scene.cols / 10, scene.rows / 10);
  cv::Mat likelihood;
  std::vector<int> bins;
  color_likelihood(scene, cells, learnt, likelihood, bins);
  ASSERT_EQ(likelihood.size(), cells);
  ASSERT_EQ(likelihood.type(), CV_32F);
  const cv::Rect inside(pasted.x / 10 + 1, pasted.y / 10 + 1, pasted.width / 10 - 2, pasted.height / 10 - 2);
  cv::Mat outside_mask(cells, CV_8U, cv::Scalar(255));
  outside_mask(cv::Rect(pasted.x / 10 - 1, pasted.y / 10 - 1, pasted.width / 10 + 2, pasted.height / 10 + 2)) = 0;
  const double on_target = cv::mean(likelihood(inside))[0], elsewhere = cv::mean(likelihood, outside_mask)[0];
  std::printf("colour likelihood: over the patch %.3f, elsewhere %.3f\n", on_target, elsewhere);
  EXPECT_GE(on_target, 0.8);
  EXPECT_LE(elsewhere, 0.4);
  EXPECT_GE(on_target, 2.5 * elsewhere);

  // No colour to go by: a gray frame, and a black area's cells.
  cv::Mat gray;
  cv::cvtColor(scene, gray, cv::COLOR_BGR2GRAY);
  color_likelihood(gray, cells, learnt, likelihood, bins);
  EXPECT_EQ(cv::countNonZero(likelihood), 0);
  scene(pasted).setTo(cv::Scalar(3, 3, 3));
  color_likelihood(scene, cells, learnt, likelihood, bins);
  EXPECT_EQ(cv::countNonZero(likelihood(inside)), 0);
}

// A camera's white balance multiplies every pixel's channels by the same
// gains. WhiteBalanceDrift follows them from frame to frame, and the
// histograms read through its gains give the colours the first frame had: a
// target's colours after the white balance warmed by 20% over ten frames
// share nearly all of what was learnt, where read as they come they share far
// less.
TEST(WhiteBalanceDrift, FollowsACamerasGainsAndTheColoursReadThroughThemAreTheFirstFramesOnes) {
  const cv::Mat scene = read("baboon.jpg");
  const cv::Rect target(180, 40, 150, 120);
  WhiteBalanceDrift drift;
  drift.update(scene);
  EXPECT_TRUE(drift.gains().neutral());
  cv::Mat warmer;
  for (int i = 1; i <= 10; ++i) {
    const double warm = 1 + 0.02 * i;  // B, G, R
    cv::multiply(scene, cv::Scalar(2 - warm, 1.0, warm), warmer);
    drift.update(warmer);
  }
  const ChannelGains gains = drift.gains();
  std::printf("gains after a white balance 20%% warmer: blue %.3f, red %.3f\n", gains.q8[0] / 256.0,
              gains.q8[2] / 256.0);
  EXPECT_NEAR(gains.q8[2] / 256.0, 1 / 1.2, 0.05);
  EXPECT_NEAR(gains.q8[0] / 256.0, 1 / 0.8, 0.07);
  EXPECT_EQ(gains.q8[1], 256);
  std::vector<float> learnt, seen_raw, seen_balanced;
  chroma_histogram(scene, target, learnt);
  chroma_histogram(warmer, target, seen_raw);
  chroma_histogram(warmer, target, seen_balanced, gains);
  const double raw = shared_colors(seen_raw, learnt), balanced = shared_colors(seen_balanced, learnt);
  std::printf("a target's colours: %.3f as they come, %.3f balanced\n", raw, balanced);
  EXPECT_GE(balanced, 0.85);
  EXPECT_LT(raw, 0.7);
}

// What moves in the view is not taken for the camera's gains: a pan across a
// photograph of strong colours (4 px a frame for 60 frames, a fixed white
// balance) leaves the gains within a few percent of neutral; a cut to another
// picture is not measured; a gray frame has nothing to measure.
TEST(WhiteBalanceDrift, TakesNeitherAPanNorACutForTheCamerasGains) {
  const cv::Mat picture = read("fruits.jpg");
  WhiteBalanceDrift drift;
  double farthest = 0;
  for (int i = 0; i < 60; ++i) {
    drift.update(picture(cv::Rect(4 * i, 20, 240, 180)));
    const ChannelGains g = drift.gains();
    farthest = std::max({farthest, std::abs(g.q8[0] / 256.0 - 1), std::abs(g.q8[2] / 256.0 - 1)});
  }
  std::printf("a pan: the gains at most %.3f from neutral\n", farthest);
  EXPECT_LT(farthest, 0.05);
  const ChannelGains before = drift.gains();
  drift.update(read("baboon.jpg")(cv::Rect(0, 0, 240, 180)));
  for (std::size_t c = 0; c < 3; ++c)  // (an unmeasured frame still forgets 3% of the sum)
    EXPECT_NEAR(drift.gains().q8[c], before.q8[c], 1 + 0.04 * std::abs(before.q8[c] - 256))
        << "a cut taken for a white balance";
  WhiteBalanceDrift gray;
  gray.update(cv::Mat(48, 64, CV_8UC3, cv::Scalar(90, 90, 90)));
  gray.update(cv::Mat(48, 64, CV_8UC1, cv::Scalar(120)));
  gray.update(cv::Mat(48, 64, CV_8UC3, cv::Scalar(60, 60, 60)));
  EXPECT_TRUE(gray.gains().neutral());
}

// Told not to forget (the box tracker's frames while its target is lost), the
// sum keeps a change however long: 20% warmer, then 60 frames of the same
// view, the gains still undo it; forgetting, they are back within a few
// percent of neutral.
TEST(WhiteBalanceDrift, HoldsAChangeWhileToldNotToForget) {
  const cv::Mat scene = read("baboon.jpg");
  cv::Mat warmer;
  cv::multiply(scene, cv::Scalar(0.8, 1.0, 1.2), warmer);
  WhiteBalanceDrift held, forgetting;
  for (WhiteBalanceDrift* drift : {&held, &forgetting}) drift->update(scene), drift->update(warmer);
  for (int i = 0; i < 60; ++i) held.update(warmer, /*forget=*/false), forgetting.update(warmer);
  std::printf("red gain after 60 frames: %.3f held, %.3f forgetting\n", held.gains().q8[2] / 256.0,
              forgetting.gains().q8[2] / 256.0);
  EXPECT_NEAR(held.gains().q8[2] / 256.0, 1 / 1.2, 0.03);
  EXPECT_NEAR(held.gains().q8[0] / 256.0, 1 / 0.8, 0.05);
  EXPECT_NEAR(forgetting.gains().q8[2] / 256.0, 1.0, 0.04);
}

// Gains that double all three channels change no chromaticity: read
// through them, every reading is the plain one bit for bit, up to sums of
// 1530 (three channels of 255 doubled), the reciprocal table's last entry;
// gains beyond the range are held to it.
TEST(ChannelGains, TheStrongestEqualOnesChangeNoReadingAndLargerOnesAreHeld) {
  cv::Mat frame(256, 256, CV_8UC3);
  cv::RNG rng(11);
  rng.fill(frame, cv::RNG::UNIFORM, 20, 256);  // (no pixel the darkness threshold counts doubled and not plain)
  frame(cv::Rect(0, 0, 256, 16)).setTo(cv::Scalar(255, 255, 255));
  const cv::Rect all(0, 0, frame.cols, frame.rows);
  ChannelGains doubled;
  doubled.q8 = {512, 512, 512};
  std::vector<float> plain, balanced;
  chroma_histogram(frame, all, plain);
  chroma_histogram(frame, all, balanced, doubled);
  EXPECT_EQ(plain, balanced);
  EXPECT_EQ(colourful_share(frame, all, 0.02), colourful_share(frame, all, 0.02, doubled));
  ChannelGains beyond;
  beyond.q8 = {4096, 4096, 4096};
  chroma_histogram(frame, all, balanced, beyond);
  EXPECT_EQ(plain, balanced);
}

}  // namespace
}  // namespace saccade
