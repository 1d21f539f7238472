// The NCC stereo matcher's building blocks on synthetic pairs with known
// disparity (synthetic data: random texture shifted by a known amount).
#include <gtest/gtest.h>

#include <cstring>

#include <opencv2/imgproc.hpp>

#include "ncc.hpp"
#include "support.hpp"

namespace saccade::stereo {
namespace {

// right(x) = left(x + d): a left pixel x is seen in the right image at x - d.
cv::Mat shifted_right(const cv::Mat& left, int d) {
  cv::Mat right(left.size(), left.type(), cv::Scalar(0));
  left(cv::Rect(d, 0, left.cols - d, left.rows)).copyTo(right(cv::Rect(0, 0, left.cols - d, left.rows)));
  return right;
}

double share_near(const cv::Mat& disparity, float expected, float tolerance, cv::Rect interior) {
  int n = 0, good = 0;
  for (int y = interior.y; y < interior.br().y; ++y)
    for (int x = interior.x; x < interior.br().x; ++x) {
      ++n;
      good += std::fabs(disparity.at<float>(y, x) - expected) <= tolerance;
    }
  return static_cast<double>(good) / n;
}

// Per-pixel search ranges with both ends drawn from -reach .. reach.
void random_ranges(cv::Size size, int reach, cv::RNG& rng, cv::Mat& lo, cv::Mat& hi) {
  lo.create(size, CV_32S);
  hi.create(size, CV_32S);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const int a = rng.uniform(-reach, reach + 1), b = rng.uniform(-reach, reach + 1);
      lo.at<int>(y, x) = std::min(a, b);
      hi.at<int>(y, x) = std::max(a, b);
    }
}

TEST(NccReference, IsTheCorrelationCoefficient) {
  cv::Mat a = test::random_image({16, 16}, 1);
  cv::Mat b;
  a.convertTo(b, CV_8U, 0.5, 40);  // gain and offset: still perfectly correlated
  EXPECT_NEAR(ncc_reference(a, 8, 8, a, 8, 8, 5), 1.0, 1e-12);
  EXPECT_NEAR(ncc_reference(a, 8, 8, b, 8, 8, 5), 1.0, 2e-2);  // rounding of the 8-bit copy
  cv::Mat inv = 255 - a;
  EXPECT_NEAR(ncc_reference(a, 8, 8, inv, 8, 8, 5), -1.0, 1e-12);
}

TEST(NccMatch, FindsAKnownDisparityBothWays) {
  const int d = 5;
  cv::Mat left = test::random_image({48, 36}, 2);
  cv::Mat right = shifted_right(left, d);
  NccConfig config = plain_ncc_config();
  cv::Mat lr, lr_score, rl, rl_score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 12, config, lr, lr_score);
  ncc_match(left, right, Direction::kRightToLeft, 0, 12, config, rl, rl_score);
  // Left pixels whose match lies in the right image, away from the borders.
  EXPECT_GE(share_near(lr, d, 0.25f, cv::Rect(d + 3, 3, 48 - d - 6, 30)), 0.98);
  EXPECT_GE(share_near(rl, d, 0.25f, cv::Rect(3, 3, 48 - d - 6, 30)), 0.98);
  // The score is the correlation coefficient at the chosen disparity.
  EXPECT_NEAR(lr_score.at<float>(18, 20), ncc_reference(left, 20, 18, right, 20 - d, 18, 5), 1e-4);
  EXPECT_NEAR(lr_score.at<float>(18, 20), 1.0, 1e-4);
}

TEST(NccMatchCross, RightPixelsTakeThePairsTheLeftPixelsSearch) {
  const int d = 4;
  cv::Mat left = test::random_image({48, 36}, 7);
  cv::Mat right = shifted_right(left, d);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(0)), hi(left.size(), CV_32S, cv::Scalar(8));
  NccConfig config = plain_ncc_config();
  NccScratch scratch;
  cv::Mat lr, lr_score, rl, rl_score;
  ncc_match_cross(left, right, lo, hi, config, lr, lr_score, rl, rl_score, scratch);
  EXPECT_GE(share_near(lr, d, 0.25f, cv::Rect(d + 3, 3, 48 - d - 6, 30)), 0.98);
  EXPECT_GE(share_near(rl, d, 0.25f, cv::Rect(3, 3, 48 - d - 6, 30)), 0.98);
  // A right pixel no left pixel's search reaches has no match: right pixel
  // 46 pairs with left pixels 46 .. 54, none of which has a whole window.
  EXPECT_LE(rl_score.at<float>(18, 46), -1.0f);
}

TEST(NccMatchCross, SemiGlobalCarriesTheNeighboursDisparityAcrossAFlatBand) {
  const int d = 3;
  cv::Mat left = test::random_image({56, 32}, 8);
  left(cv::Rect(22, 0, 12, 32)).setTo(128);  // no texture: no window there can be matched alone
  cv::Mat right = shifted_right(left, d);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(0)), hi(left.size(), CV_32S, cv::Scalar(7));
  const cv::Rect band(26, 4, 4, 24);  // windows wholly inside the flat band
  NccConfig plain = plain_ncc_config();
  NccScratch scratch;
  cv::Mat lr, lr_score, rl, rl_score;
  ncc_match_cross(left, right, lo, hi, plain, lr, lr_score, rl, rl_score, scratch);
  EXPECT_EQ(share_near(lr_score, -1.0f, 0.0f, band), 1.0) << "flat windows are not matched alone";
  for (int paths : {4, 8}) {
    NccConfig semi_global = plain;
    semi_global.semi_global = true;
    semi_global.paths = paths;
    ncc_match_cross(left, right, lo, hi, semi_global, lr, lr_score, rl, rl_score, scratch);
    EXPECT_EQ(share_near(lr, d, 0.5f, band), 1.0) << "the band takes its neighbours' disparity, " << paths << " paths";
    EXPECT_GE(share_near(lr, d, 0.25f, cv::Rect(d + 3, 4, 14, 24)), 0.98) << "textured pixels stay exact";
    EXPECT_GE(share_near(rl, d, 0.5f, cv::Rect(26 - d, 4, 4, 24)), 1.0) << "right to left too";
  }
}

TEST(NccMatchCross, AggregatedPicksAtTheirRangesEdgeAreDroppedOnRequest) {
  // The truth, 12, lies outside the left half's range (0 .. 10), inside the
  // right half's (6 .. 18). The left half's picks then sit at the range's
  // edge nearest the truth (smooth texture: the correlation rises towards
  // it); dropped on request, as the minimum may lie beyond what was searched.
  const int d = 12;
  cv::Mat left;
  cv::GaussianBlur(test::random_image({80, 32}, 9), left, cv::Size(), 1.5);
  left.convertTo(left, CV_8U, 3.0, -256);  // contrast back after the blur
  cv::Mat right = shifted_right(left, d);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(6)), hi(left.size(), CV_32S, cv::Scalar(18));
  lo(cv::Rect(0, 0, 40, 32)).setTo(0);
  hi(cv::Rect(0, 0, 40, 32)).setTo(10);
  NccConfig config;  // semi-global, the defaults
  NccScratch scratch;
  cv::Mat lr, lr_score, rl, rl_score;
  ncc_match_cross(left, right, lo, hi, config, lr, lr_score, rl, rl_score, scratch);
  const cv::Rect outside(d + 4, 4, 40 - d - 8, 24), inside(44, 4, 30, 24);
  const double given_before = 1 - share_near(lr_score, -1.0f, 0.0f, outside);
  const double at_edge = share_near(lr, 10, 0.5f, outside);
  config.drop_range_edges = true;
  ncc_match_cross(left, right, lo, hi, config, lr, lr_score, rl, rl_score, scratch);
  const double given_after = 1 - share_near(lr_score, -1.0f, 0.0f, outside);
  std::printf("outside its range: %.3f given (%.3f at its edge), %.3f with the edge's picks dropped\n", given_before,
              at_edge, given_after);
  EXPECT_GE(given_before, 0.95);
  EXPECT_GE(at_edge, 0.6);
  EXPECT_LE(given_after, given_before - at_edge + 0.05) << "the edge's picks dropped, and only they";
  EXPECT_GE(share_near(lr, d, 0.25f, inside), 0.95) << "picks inside their ranges stay";
}

TEST(NccMatchCross, EightSemiGlobalPathsCarryDisparityAlongTheDiagonals) {
  // Flat but for two textured blocks diagonal to each other: the pixels
  // between them see texture along neither their row nor their column, only
  // along a diagonal. Four paths leave them undecided (every disparity costs
  // the same: the first wins), eight carry the blocks' disparity to them.
  const int d = 2;
  const cv::Mat texture = test::random_image({64, 48}, 21);
  cv::Mat left(texture.size(), CV_8U, cv::Scalar(128));
  texture(cv::Rect(10, 10, 11, 11)).copyTo(left(cv::Rect(10, 10, 11, 11)));  // columns and rows 10..20
  texture(cv::Rect(40, 30, 11, 11)).copyTo(left(cv::Rect(40, 30, 11, 11)));  // columns 40..50, rows 30..40
  cv::Mat right = shifted_right(left, d);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(0)), hi(left.size(), CV_32S, cv::Scalar(6));
  // Rows 23..27 and columns 26..34: their windows, their rows and their
  // columns (in both images) are flat.
  const cv::Rect between(26, 23, 9, 5);
  NccScratch scratch;
  double right_share[2];
  for (int i = 0; i < 2; ++i) {
    NccConfig config = plain_ncc_config();
    config.semi_global = true;
    config.paths = i == 0 ? 4 : 8;
    cv::Mat disparity, score, rl, rl_score;
    ncc_match_cross(left, right, lo, hi, config, disparity, score, rl, rl_score, scratch);
    right_share[i] = share_near(disparity, d, 0.5f, between);
    EXPECT_GE(share_near(disparity, d, 0.25f, cv::Rect(13, 13, 5, 5)), 0.9) << "inside a block, " << config.paths;
  }
  EXPECT_LE(right_share[0], 0.1) << "four paths: nothing reaches them";
  EXPECT_GE(right_share[1], 0.9) << "eight paths: the diagonals do";
}

// Window standard deviation (population), as the matcher's texture test reads it.
double window_std(const cv::Mat& image, int x, int y, int window) {
  const int r = window / 2;
  double sum = 0, sq = 0;
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx) {
      const double v = image.at<uint8_t>(y + dy, x + dx);
      sum += v;
      sq += v * v;
    }
  const double n = window * window, mean = sum / n;
  return std::sqrt(std::max(0.0, sq / n - mean * mean));
}

TEST(NccMatchCross, RightPixelsTakeTheBestOfTheLeftPixelsPairsWithTheirParabola) {
  // Plainly, per right pixel: the best among the left pixels whose range
  // reached it, and the parabola where the left pixels either side of that
  // one searched their pair with it. Random ranges, so the sweep's vector
  // and scalar steps and every edge case of the neighbours are exercised.
  cv::RNG rng(11);
  int compared = 0, same = 0, with_subpixel = 0;
  for (int trial = 0; trial < 6; ++trial) {
    cv::Mat left = test::random_image({45, 26}, 300 + trial), right;
    cv::GaussianBlur(left, left, {3, 3}, 0.8);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, -rng.uniform(-5, 6) - 0.3, 0, 1, 0);
    cv::warpAffine(left, right, m, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    left(cv::Rect(20, 5, 6, 8)).setTo(90);  // flat windows: neither matched nor a neighbour
    cv::Mat lo, hi;
    random_ranges(left.size(), 8, rng, lo, hi);
    for (int window : {3, 5}) {
      NccConfig config = plain_ncc_config();
      config.window = window;
      const int r = window / 2, w = left.cols;
      NccScratch scratch;
      cv::Mat lr, lr_score, rl, rl_score;
      ncc_match_cross(left, right, lo, hi, config, lr, lr_score, rl, rl_score, scratch);
      auto score = [&](int y, int xl, int d) -> double {  // -2: not searched or flat
        if (xl < r || xl >= w - r || xl - d < r || xl - d >= w - r) return -2;
        if (d < lo.at<int>(y, xl) || d > hi.at<int>(y, xl)) return -2;
        if (window_std(left, xl, y, window) < config.min_texture ||
            window_std(right, xl - d, y, window) < config.min_texture)
          return -2;
        return ncc_reference(left, xl, y, right, xl - d, y, window);
      };
      for (int y = r; y < left.rows - r; ++y)
        for (int x = r; x < w - r; ++x) {
          double best = -2;
          int best_d = 0;
          for (int d = -8; d <= 8; ++d)
            if (const double c = score(y, x + d, d); c > best) {
              best = c;
              best_d = d;
            }
          float expected = -1;
          if (best >= config.min_score) {
            expected = static_cast<float>(best_d);
            const double c0 = score(y, x + best_d - 1, best_d - 1), c2 = score(y, x + best_d + 1, best_d + 1);
            const double denom = c0 - 2 * best + c2;
            if (c0 > -2 && c2 > -2 && denom < 0) {
              expected += static_cast<float>(std::clamp(0.5 * (c0 - c2) / denom, -0.5, 0.5));
              ++with_subpixel;
            }
          }
          ++compared;
          const float got = rl_score.at<float>(y, x) > -1 ? rl.at<float>(y, x) : -1.0f;
          same += std::abs(got - expected) < 1e-3f;
        }
    }
  }
  // Float sums against double: a near-tie may go the other way, rarely.
  EXPECT_GE(static_cast<double>(same) / compared, 0.995) << same << " of " << compared;
  EXPECT_GE(with_subpixel, compared / 20) << "the parabola was exercised";
}

TEST(NccMatch, IsInsensitiveToGainAndOffset) {
  cv::Mat left = test::random_image({48, 36}, 3);
  cv::Mat right;
  shifted_right(left, 7).convertTo(right, CV_8U, 0.7, 30);
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 15, {}, lr, score);
  EXPECT_GE(share_near(lr, 7, 0.25f, cv::Rect(10, 3, 30, 30)), 0.98);
}

TEST(NccMatch, PerPixelRangesRestrictTheSearch) {
  cv::Mat left = test::random_image({48, 36}, 4);
  cv::Mat right = shifted_right(left, 6);
  cv::Mat lo(left.size(), CV_32S, cv::Scalar(6)), hi(left.size(), CV_32S, cv::Scalar(6));
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, lo, hi, {}, lr, score);
  EXPECT_GE(share_near(lr, 6, 0.0f, cv::Rect(9, 3, 30, 30)), 0.98) << "a one-value range gives that value, no subpixel";
  lo.setTo(0);
  hi.setTo(3);  // the truth is outside: nothing correlates well enough
  ncc_match(left, right, Direction::kLeftToRight, lo, hi, {}, lr, score);
  EXPECT_LE(cv::countNonZero(lr >= 0), 60);
}

TEST(NccMatch, FlatWindowsAreNotMatched) {
  cv::Mat left(36, 48, CV_8UC1, cv::Scalar(90)), right = left.clone();
  cv::Mat lr, score;
  ncc_match(left, right, Direction::kLeftToRight, 0, 8, {}, lr, score);
  EXPECT_EQ(cv::countNonZero(lr >= 0), 0);
}

TEST(LeftRightCheck, KeepsConsistentPixelsAndDropsOthers) {
  const int d = 4;
  cv::Mat left = test::random_image({48, 36}, 5), right = shifted_right(left, d);
  cv::Mat lr, rl, s1, s2;
  ncc_match(left, right, Direction::kLeftToRight, 0, 10, {}, lr, s1);
  ncc_match(left, right, Direction::kRightToLeft, 0, 10, {}, rl, s2);
  cv::Mat corrupted = lr.clone();
  corrupted.at<float>(18, 20) = 9;  // a wrong match
  cv::Mat valid(lr.size(), CV_8U, cv::Scalar(255));
  double kept = left_right_check(corrupted, s1, rl, s2, 1.0f, valid);
  EXPECT_GT(kept, 0.95);
  EXPECT_EQ(valid.at<uint8_t>(18, 20), 0);
  EXPECT_EQ(valid.at<uint8_t>(18, 22), 255);
  EXPECT_NEAR(corrupted.at<float>(18, 22), d, 0.25);
}

TEST(NccMatch, TheSweepAgreesWithThePlainReferenceEverywhere) {
  cv::RNG rng(5);
  int compared = 0, same = 0;
  for (int trial = 0; trial < 6; ++trial) {
    cv::Mat left = test::random_image({44, 30}, 100 + trial), right;
    cv::GaussianBlur(left, left, {3, 3}, 0.8);
    const int shift = rng.uniform(-6, 7);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, -shift, 0, 1, 0);
    cv::warpAffine(left, right, m, left.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
    cv::Mat noise(left.size(), CV_8U);
    rng.fill(noise, cv::RNG::UNIFORM, 0, 6);
    right += noise;
    cv::Mat lo, hi;
    random_ranges(left.size(), 9, rng, lo, hi);
    for (Direction direction : {Direction::kLeftToRight, Direction::kRightToLeft})
      for (int window : {3, 5}) {
        NccConfig config = plain_ncc_config();
        config.window = window;
        NccScratch a, b;
        cv::Mat d_fast, s_fast, d_ref, s_ref;
        ncc_match(left, right, direction, lo, hi, config, d_fast, s_fast, a);
        ncc_match_reference(left, right, direction, lo, hi, config, d_ref, s_ref, b);
        for (int y = 0; y < d_ref.rows; ++y)
          for (int x = 0; x < d_ref.cols; ++x) {
            ++compared;
            const bool valid_ref = s_ref.at<float>(y, x) > -1, valid_fast = s_fast.at<float>(y, x) > -1;
            if (valid_ref != valid_fast) continue;
            if (!valid_ref || (std::abs(d_ref.at<float>(y, x) - d_fast.at<float>(y, x)) < 1e-3f &&
                               std::abs(s_ref.at<float>(y, x) - s_fast.at<float>(y, x)) < 1e-4f))
              ++same;
          }
      }
  }
  // Float sums against double: a near-tie may go the other way, rarely.
  EXPECT_GE(static_cast<double>(same) / compared, 0.999) << same << " of " << compared;
}

TEST(NccMatch, AvxTwoAndAvx512AreTheSameToTheBit) {
  // Random textures, shifts, widths (narrow ones too), ranges with holes,
  // windows, score floors and with and without the parabola; both
  // directions with their own ranges and with the left pixels' pairs, and
  // the left-right check.
  cv::RNG rng(11);
  int valid = 0;
  bool cpu_has = false;
  for (int trial = 0; trial < 120; ++trial) {
    const cv::Size size(6 + rng.uniform(0, 70), 6 + rng.uniform(0, 30));
    cv::Mat left = test::random_image(size, 300 + trial), right;
    if (trial % 3 == 0) cv::GaussianBlur(left, left, {3, 3}, 0.8);
    if (trial % 7 == 0) left(cv::Rect(0, 0, size.width / 2, size.height)).setTo(90);  // flat: unmatched
    const int shift = rng.uniform(-8, 9);
    const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, -shift, 0, 1, 0);
    cv::warpAffine(left, right, m, size, cv::INTER_LINEAR, cv::BORDER_REFLECT);
    cv::Mat lo, hi, lo2, hi2;
    random_ranges(size, 12, rng, lo, hi);
    random_ranges(size, 10, rng, lo2, hi2);
    for (int y = 0; y < size.height; ++y)
      for (int x = 0; x < size.width; ++x)
        if (rng.uniform(0, 10) == 0) lo.at<int>(y, x) = hi.at<int>(y, x) + 1;  // searches nothing
    NccConfig config = plain_ncc_config();
    config.window = trial % 2 == 0 ? 5 : 3;
    config.subpixel = trial % 5 != 0;
    config.min_score = trial % 4 == 0 ? -1.0f : 0.3f;
    std::vector<cv::Mat> outputs[2];
    for (int wide = 0; wide < 2; ++wide) {
      cpu_has = allow_avx512(wide == 1);
      NccScratch scratch;
      cv::Mat d_lr, s_lr, d_rl, s_rl;
      ncc_match_cross(left, right, lo, hi, config, d_lr, s_lr, d_rl, s_rl, scratch);
      for (const cv::Mat& out : {d_lr, s_lr, d_rl, s_rl}) outputs[wide].push_back(out.clone());
      // The left-right check on them (a region inside, as the stereo node's).
      cv::Mat checked(size, CV_8U, cv::Scalar(255));
      const double kept = left_right_check(d_lr, s_lr, d_rl, s_rl, trial % 3 == 0 ? 0.5f : 1.0f, checked,
                                           cv::Rect(1, 1, size.width - 2, size.height - 2));
      outputs[wide].push_back(checked);
      outputs[wide].push_back(cv::Mat(1, 1, CV_64F, cv::Scalar(kept)));
      ncc_match_both(left, right, lo, hi, lo2, hi2, config, d_lr, s_lr, d_rl, s_rl, scratch);
      for (const cv::Mat& out : {d_lr, s_lr, d_rl, s_rl}) outputs[wide].push_back(out.clone());
    }
    allow_avx512(true);
    for (std::size_t i = 0; i < outputs[0].size(); ++i) {
      const cv::Mat& a = outputs[0][i];
      const cv::Mat& b = outputs[1][i];
      ASSERT_EQ(a.size(), b.size());
      for (int y = 0; y < a.rows; ++y)
        ASSERT_EQ(std::memcmp(a.ptr(y), b.ptr(y), a.cols * a.elemSize()), 0)
            << "trial " << trial << ", output " << i << ", row " << y;
      if (a.type() == CV_32F && i % 2 == 1) valid += cv::countNonZero(a > -1);
    }
  }
  EXPECT_GT(valid, 20000);  // the comparison saw matched pixels, not only -1
  if (!cpu_has)
    GTEST_SKIP() << "no AVX-512 here (the CPU, or SACCADE_AVX512=0): both runs took the AVX2 (or baseline) path";
}

}  // namespace
}  // namespace saccade::stereo
