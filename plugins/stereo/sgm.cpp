#include "sgm.hpp"

#include <algorithm>
#include <cstddef>
#include <cstring>
#include <limits>
#include <vector>

#include "saccade/fill.hpp"
#include "saccade/simd.hpp"
#include "saccade/subpixel.hpp"

namespace saccade::stereo {

namespace {

// The left pixels the aggregation covers: rows y0 .. y1, columns x0 .. x1.
struct Box {
  int y0, y1, x0, x1;
};

// One step of a path of the semi-global aggregation: the path's costs at a
// pixel from its costs at the previous pixel on the path (prev, with one
// padding entry either side holding a large value) and the pixel's own, also
// added to the pixel's sum over the paths (in the same pass: the sums are
// read and written once per path instead of twice).
// Aligned to a cache line: its speed otherwise depends on where the linker
// happens to place it (5% of an 8-path match either way on an AMD EPYC).
SACCADE_AVX2_CLONE __attribute__((aligned(64))) void path_step(float* __restrict out, float* __restrict sum,
                                                               const float* __restrict cost,
                                                               const float* __restrict prev, int n, float p1,
                                                               float p2) {
  // The previous costs' minimum eight at a time (GCC leaves a float min
  // reduction scalar: it may not reorder it, though a minimum does not depend
  // on the order).
  typedef float v8f __attribute__((vector_size(32)));
  const float* previous = prev + 1;
  v8f lanes = v8f{} + std::numeric_limits<float>::infinity();
  int d8 = 0;
  for (; d8 + 8 <= n; d8 += 8) {
    v8f v;
    std::memcpy(&v, previous + d8, sizeof v);
    lanes = v < lanes ? v : lanes;
  }
  float prev_min = std::numeric_limits<float>::infinity();
  for (int i = 0; i < 8; ++i) prev_min = std::min(prev_min, lanes[i]);
  for (; d8 < n; ++d8) prev_min = std::min(prev_min, previous[d8]);
  const float jump = prev_min + p2;
  for (int d = 0; d < n; ++d) {
    const float step = std::min(prev[d], prev[d + 2]) + p1;
    out[d] = cost[d] + std::min(std::min(prev[d + 1], step), jump) - prev_min;
    sum[d] += out[d];
  }
}

// A path's first pixel: its costs are the pixel's own.
void path_start(float* __restrict out, float* __restrict sum, const float* __restrict cost, int n) {
  for (int d = 0; d < n; ++d) {
    out[d] = cost[d];
    sum[d] += cost[d];
  }
}

// A pair outside its pixel's range, and the padding either side of a path's
// disparities: a prohibitive cost.
constexpr float kOutside = 16.0f;

// The costs the paths aggregate, into scratch.cost at [((y - y0) * cols + x -
// x0) * count + d - d_min]: 1 - NCC where the sweep computed the pair, 1 (no
// preference) where a window was too flat, kOutside outside the pixel's range.
void path_costs(const Box& box, const SweepVolume& volume, const cv::Mat& lo, const cv::Mat& hi, NccScratch& scratch) {
  constexpr float kFlat = 1.0f;
  const int rows = box.y1 - box.y0 + 1, cols = box.x1 - box.x0 + 1, count = volume.d_max - volume.d_min + 1;
  const std::size_t pixel_count = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
  std::vector<float>& cost = scratch.cost;
  cost.resize(pixel_count * static_cast<std::size_t>(count));
  for (int y = box.y0; y <= box.y1; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    for (int x = box.x0; x <= box.x1; ++x) {
      float* c = cost.data() + (static_cast<std::size_t>(y - box.y0) * cols + (x - box.x0)) * count;
      // Outside the pixel's range first (most of a wide sweep), then its range.
      const int first = std::max(l[x] - volume.d_min, 0), last = std::min(u[x] - volume.d_min, count - 1);
      std::fill(c, c + count, kOutside);
      for (int i = first; i <= last; ++i) {
        const float ncc =
            volume.has(volume.d_min + i, x)
                ? volume
                      .data[static_cast<std::size_t>(i) * volume.plane + static_cast<std::size_t>(y) * volume.width + x]
                : -2.0f;
        c[i] = ncc > -2.0f ? 1.0f - ncc : kFlat;
      }
    }
  }
}

// Semi-global aggregation of path_costs over the left pixels of `box` (rows
// y0 .. y1, columns x0 .. x1), disparities d_min .. d_max: four paths (along
// the rows both ways, along the columns both ways), or eight (and the
// diagonals both ways), summed into scratch.aggregated, indexed as the costs.
void aggregate(const Box& box, const SweepVolume& volume, const cv::Mat& lo, const cv::Mat& hi, float p1, float p2,
               int paths, NccScratch& scratch) {
  path_costs(box, volume, lo, hi, scratch);
  const int rows = box.y1 - box.y0 + 1, cols = box.x1 - box.x0 + 1, count = volume.d_max - volume.d_min + 1;
  const std::vector<float>& cost = scratch.cost;
  std::vector<float>& sum = scratch.aggregated;
  sum.assign(cost.size(), 0.0f);
  // A path's previous costs, padded either side so that d - 1 and d + 1 read
  // something: two entries for the paths along rows, two rows' worth for the
  // others (the row before is still read while this one is written).
  std::vector<float>& current = scratch.path;
  std::vector<float>& rows_of_paths = scratch.path_rows;
  const int stride = count + 2;
  current.assign(static_cast<std::size_t>(stride) * 2, kOutside);
  rows_of_paths.assign(2 * static_cast<std::size_t>(cols) * stride, kOutside);
  // Along the rows, left to right and right to left.
  for (int y = 0; y < rows; ++y)
    for (int dir = 0; dir < 2; ++dir) {
      float* prev = current.data();
      float* next = current.data() + stride;
      for (int k = 0; k < cols; ++k) {
        const int x = dir == 0 ? k : cols - 1 - k;
        const std::size_t pixel = static_cast<std::size_t>(y) * cols + x;
        const float* c = cost.data() + pixel * count;
        float* s = sum.data() + pixel * count;
        if (k == 0)
          path_start(next + 1, s, c, count);
        else
          path_step(next + 1, s, c, prev, count, p1, p2);
        std::swap(prev, next);
      }
    }
  // Down and up the columns (lean 0), then with eight paths along the
  // diagonals (leaning left and right): a row of paths at a time, each
  // pixel's from the row before's, `lean` columns to the side.
  struct Path {
    int dir, lean;
  };
  constexpr Path kPaths[] = {{0, 0}, {1, 0}, {0, -1}, {0, 1}, {1, -1}, {1, 1}};
  for (const Path& path : kPaths) {
    if (path.lean != 0 && paths < 8) break;
    float* before = rows_of_paths.data();
    float* now = rows_of_paths.data() + static_cast<std::size_t>(cols) * stride;
    for (int k = 0; k < rows; ++k) {
      const int y = path.dir == 0 ? k : rows - 1 - k;
      for (int x = 0; x < cols; ++x) {
        const std::size_t pixel = static_cast<std::size_t>(y) * cols + x;
        const float* c = cost.data() + pixel * count;
        float* s = sum.data() + pixel * count;
        float* next = now + static_cast<std::size_t>(x) * stride;
        const int from = x - path.lean;
        if (k == 0 || from < 0 || from >= cols)
          path_start(next + 1, s, c, count);
        else
          path_step(next + 1, s, c, before + static_cast<std::size_t>(from) * stride, count, p1, p2);
      }
      std::swap(before, now);
    }
  }
}

// Whether a pixel's aggregated costs c[first..last] have another disparity,
// more than one from the best, within `uniqueness` of it.
bool undecided_costs(const float* c, int first, int last, int best, float uniqueness) {
  const float bar = c[best] * (1 + uniqueness);
  for (int i = first; i <= last; ++i)
    if ((i < best - 1 || i > best + 1) && c[i] < bar) return true;
  return false;
}

// The aggregated costs of the box's left pixels, and the sweep's correlations.
struct AggregatedCosts {
  const Box& box;
  const SweepVolume& volume;
  const std::vector<float>& sum;
  int cols, count;
  const float* at(int y, int x) const {
    return sum.data() + (static_cast<std::size_t>(y - box.y0) * cols + (x - box.x0)) * count;
  }
  // -2 where the pair has no correlation: a flat window, or one the sweep did not reach.
  float correlation(int y, int x, int d) const {
    return volume.has(d, x) ? volume.data[static_cast<std::size_t>(d - volume.d_min) * volume.plane +
                                          static_cast<std::size_t>(y) * volume.width + x]
                            : -2.0f;
  }
  // The score given: the correlation, 0 where there is none.
  float score(int y, int x, int d) const {
    const float v = correlation(y, x, d);
    return v > -2.0f ? v : 0.0f;
  }
};

// Row y's left pixels: each the smallest aggregated cost in its range.
void pick_left_row(const AggregatedCosts& a, const NccConfig& config, int y, const int* l, const int* u, float* out_d,
                   float* out_s, uint8_t* undecided) {
  const SweepVolume& volume = a.volume;
  for (int x = a.box.x0; x <= a.box.x1; ++x) {
    const int first = std::max(l[x], volume.d_min) - volume.d_min, last = std::min(u[x], volume.d_max) - volume.d_min;
    if (last < first) continue;
    const float* c = a.at(y, x);
    const int best = static_cast<int>(std::min_element(c + first, c + last + 1) - c);
    const bool at_floor = best == first && first + volume.d_min > config.range_floor;
    const bool at_ceiling = best == last && last + volume.d_min < config.range_ceiling;
    if (config.drop_range_edges && last > first && (at_floor || at_ceiling)) continue;
    const float step =
        config.subpixel && best > first && best < last ? valley_vertex(c[best - 1], c[best], c[best + 1]) : 0.0f;
    out_d[x] = static_cast<float>(best + volume.d_min) + step;
    out_s[x] = a.score(y, x, best + volume.d_min);
    if (a.correlation(y, x, best + volume.d_min) <= -2.0f &&
        undecided_costs(c, first, last, best, config.flat_uniqueness))
      undecided[x] = 255;
  }
}

// Row y's right pixels: right pixel xr at d is left pixel xr + d; each left
// pixel's pairs, in order of x and then of d, offered to their right pixels
// (for a right pixel that is in order of d: the smallest d wins a tie, as a
// search of each right pixel over d would pick).
void pick_right_row(const AggregatedCosts& a, const NccConfig& config, NccScratch& scratch, int y, const int* l,
                    const int* u, int w, float* back_d, float* back_s) {
  const SweepVolume& volume = a.volume;
  scratch.right_best.assign(static_cast<std::size_t>(w), -1);
  scratch.right_cost.resize(static_cast<std::size_t>(w));
  for (int x = a.box.x0; x <= a.box.x1; ++x) {
    const int first = std::max(l[x], volume.d_min) - volume.d_min, last = std::min(u[x], volume.d_max) - volume.d_min;
    const float* c = a.at(y, x);
    for (int i = first; i <= last; ++i) {
      const int xr = x - (i + volume.d_min);
      if (xr < 0 || xr >= w) continue;
      const std::size_t r = static_cast<std::size_t>(xr);
      if (scratch.right_best[r] < 0 || c[i] < scratch.right_cost[r])
        scratch.right_best[r] = i, scratch.right_cost[r] = c[i];
    }
  }
  for (int xr = 0; xr < w; ++xr) {
    auto wanted = [&](int i) {
      const int d = i + volume.d_min, x = xr + d;
      return x >= a.box.x0 && x <= a.box.x1 && d >= l[x] && d <= u[x];
    };
    const int best = scratch.right_best[static_cast<std::size_t>(xr)];
    if (best < 0) continue;
    const float best_cost = scratch.right_cost[static_cast<std::size_t>(xr)];
    float step = 0.0f;
    if (config.subpixel && best > 0 && best + 1 < a.count && wanted(best - 1) && wanted(best + 1))
      step = valley_vertex(a.at(y, xr + best - 1 + volume.d_min)[best - 1], best_cost,
                           a.at(y, xr + best + 1 + volume.d_min)[best + 1]);
    back_d[xr] = static_cast<float>(best + volume.d_min) + step;
    back_s[xr] = a.score(y, xr + best + volume.d_min, best + volume.d_min);
  }
}

// Both directions' disparities from the aggregated costs: each left pixel
// the smallest in its range, each right pixel the smallest among the pairs
// the left pixels search; a parabola through the costs either side. Scores:
// the NCC at the chosen pair where the sweep computed one, 0 otherwise.
void pick_aggregated(const Box& box, const SweepVolume& volume, const cv::Mat& lo, const cv::Mat& hi,
                     const NccConfig& config, NccScratch& scratch, cv::Mat& disparity_lr, cv::Mat& score_lr,
                     cv::Mat& disparity_rl, cv::Mat& score_rl) {
  const AggregatedCosts costs{.box = box,
                              .volume = volume,
                              .sum = scratch.aggregated,
                              .cols = box.x1 - box.x0 + 1,
                              .count = volume.d_max - volume.d_min + 1};
  for (cv::Mat* m : {&disparity_lr, &score_lr, &disparity_rl, &score_rl}) {
    m->create(lo.size(), CV_32F);
    fill(*m, -1);
  }
  for (int y = box.y0; y <= box.y1; ++y) {
    pick_left_row(costs, config, y, lo.ptr<int>(y), hi.ptr<int>(y), disparity_lr.ptr<float>(y), score_lr.ptr<float>(y),
                  scratch.undecided.ptr<uint8_t>(y));
    pick_right_row(costs, config, scratch, y, lo.ptr<int>(y), hi.ptr<int>(y), lo.cols, disparity_rl.ptr<float>(y),
                   score_rl.ptr<float>(y));
  }
}

}  // namespace

void semi_global_match(const SweepVolume& volume, const cv::Mat& lo, const cv::Mat& hi, int r, const NccConfig& config,
                       NccScratch& scratch, cv::Mat& disparity_lr, cv::Mat& score_lr, cv::Mat& disparity_rl,
                       cv::Mat& score_rl) {
  const int w = lo.cols, h = lo.rows;
  Box box{.y0 = std::numeric_limits<int>::max(), .y1 = -1, .x0 = std::numeric_limits<int>::max(), .x1 = -1};
  for (int y = r; y < h - r; ++y) {
    const int* l = lo.ptr<int>(y);
    const int* u = hi.ptr<int>(y);
    for (int x = r; x < w - r; ++x) {
      if (u[x] < l[x]) continue;
      box.y0 = std::min(box.y0, y);
      box.y1 = y;
      box.x0 = std::min(box.x0, x);
      box.x1 = std::max(box.x1, x);
    }
  }
  aggregate(box, volume, lo, hi, config.p1, config.p2, config.paths, scratch);
  pick_aggregated(box, volume, lo, hi, config, scratch, disparity_lr, score_lr, disparity_rl, score_rl);
}

}  // namespace saccade::stereo
