#pragma once
// Sub-pixel peaks: where between three equally spaced samples an extremum
// lies, from the parabola through them. One definition for every matcher
// and tracker (NCC and SGM disparities, the fixation search, the template
// and correlation-filter trackers).
#include <algorithm>

namespace saccade {

// The maximum at the middle sample: the parabola's vertex, -0.5 .. 0.5 from
// the middle one; 0 where the parabola does not open downwards (flat).
template <typename T>
T peak_vertex(T left, T middle, T right) {
  const T curvature = left - 2 * middle + right;
  return curvature < 0 ? std::clamp(T(0.5) * (left - right) / curvature, T(-0.5), T(0.5)) : T(0);
}

// The minimum at the middle sample (costs): the same, upside down.
template <typename T>
T valley_vertex(T left, T middle, T right) {
  return peak_vertex(-left, -middle, -right);
}

}  // namespace saccade
