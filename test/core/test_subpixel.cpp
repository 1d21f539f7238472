#include <gtest/gtest.h>

#include "saccade/subpixel.hpp"

namespace saccade {
namespace {

// Samples at -1, 0, 1 of a parabola whose extremum is at `at`.
double sample(double x, double at, double curvature) { return curvature * (x - at) * (x - at); }

TEST(Subpixel, APeakBetweenSamplesIsFoundWhereTheParabolaPeaks) {
  for (const double at : {-0.45, -0.2, 0.0, 0.13, 0.5}) {
    EXPECT_NEAR(peak_vertex(sample(-1, at, -2), sample(0, at, -2), sample(1, at, -2)), at, 1e-12) << at;
    EXPECT_NEAR(peak_vertex(static_cast<float>(sample(-1, at, -0.3)), static_cast<float>(sample(0, at, -0.3)),
                            static_cast<float>(sample(1, at, -0.3))),
                at, 1e-5)
        << at;
  }
}

TEST(Subpixel, AValleyIsFoundLikeAPeakUpsideDown) {
  for (const double at : {-0.3, 0.0, 0.42})
    EXPECT_NEAR(valley_vertex(sample(-1, at, 5), sample(0, at, 5), sample(1, at, 5)), at, 1e-12) << at;
}

TEST(Subpixel, FlatOrWrongWayUpSamplesGiveTheMiddle) {
  EXPECT_EQ(peak_vertex(1.0, 1.0, 1.0), 0.0);
  EXPECT_EQ(peak_vertex(0.0, -1.0, 0.5), 0.0);   // a valley has no peak
  EXPECT_EQ(valley_vertex(0.0, 1.0, 0.5), 0.0);  // a peak has no valley
}

TEST(Subpixel, AnOffsetIsNeverMoreThanHalfASample) {
  // The middle sample not the largest (a caller's edge case): clamped.
  EXPECT_EQ(peak_vertex(0.0, 0.9, 1.0), 0.5);
  EXPECT_EQ(peak_vertex(1.0, 0.9, 0.0), -0.5);
}

}  // namespace
}  // namespace saccade
