#include "retina.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "saccade/simd.hpp"

namespace saccade::retina {

namespace {

int sub_step(double step) { return std::max(1, static_cast<int>(std::ceil(step / 3.0 - 1e-9))); }

// Rounded mean of five 8-bit samples: (sum + 2) / 5, exact for sums up to 1275.
inline uint8_t mean5(unsigned sum) { return static_cast<uint8_t>(((sum + 2) * 52429u) >> 18); }

// The same mean as the high half of a 16x16-bit product, so a row of sums
// divides in one vector multiply per eight pixels (pmulhuw). Exact: with
// sum + 2 = 5q + r, the product is q + r/5 + (5q + r) * 4 / (5 * 65536) < q + 1
// for every sum up to 1275 (q <= 255).
inline uint8_t mean5_u16(uint16_t sum) {
  return static_cast<uint8_t>((static_cast<uint32_t>(static_cast<uint16_t>(sum + 2)) * 13108u) >> 16);
}

// Cell centre along one axis, in frame pixels.
inline int cell_center(int origin, double step, int i) {
  return origin + static_cast<int>(std::floor((i + 0.5) * step));
}

}  // namespace

cv::Point clamp_fovea_corner(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea) {
  int x = static_cast<int>(std::lround(fovea.x - config.size.width / 2.0));
  int y = static_cast<int>(std::lround(fovea.y - config.size.height / 2.0));
  return {std::clamp(x, 0, frame.width - config.size.width), std::clamp(y, 0, frame.height - config.size.height)};
}

std::vector<LevelGeometry> retina_geometry(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea) {
  std::vector<LevelGeometry> out;
  retina_geometry(config, frame, fovea, out);
  return out;
}

void retina_geometry(const RetinaConfig& config, cv::Size frame, cv::Point2d fovea, std::vector<LevelGeometry>& out) {
  cv::Point corner = clamp_fovea_corner(config, frame, fovea);
  out.resize(static_cast<std::size_t>(config.levels));
  int m = config.levels - 1;
  for (int k = 0; k <= m; ++k) {
    double t = m == 0 ? 1.0 : static_cast<double>(k) / m;
    int w = static_cast<int>(std::lround(frame.width + (config.size.width - frame.width) * t));
    int h = static_cast<int>(std::lround(frame.height + (config.size.height - frame.height) * t));
    int x = std::min(static_cast<int>(std::lround(corner.x * t)), frame.width - w);
    int y = std::min(static_cast<int>(std::lround(corner.y * t)), frame.height - h);
    auto& g = out[static_cast<std::size_t>(k)];
    g.region = cv::Rect(x, y, w, h);
    g.step_x = static_cast<double>(w) / config.size.width;
    g.step_y = static_cast<double>(h) / config.size.height;
  }
}

void sample_reference(const RetinaConfig& config, const cv::Mat& frame, const std::vector<LevelGeometry>& geometry,
                      std::vector<cv::Mat>& levels) {
  const int cn = frame.channels();
  levels.resize(geometry.size());
  for (std::size_t k = 0; k < geometry.size(); ++k) {
    const LevelGeometry& g = geometry[k];
    cv::Mat& level = levels[k];
    const bool fovea = k + 1 == geometry.size();
    if (fovea || config.mode == SamplingMode::kFivePoint) {
      sample_level(frame, g.region.x, g.region.y, g.step_x, g.step_y, config.size, fovea, level);
      continue;
    }
    level.create(config.size, frame.type());
    for (int j = 0; j < config.size.height; ++j)
      for (int i = 0; i < config.size.width; ++i)
        for (int c = 0; c < cn; ++c) {
          int x0 = g.region.x + static_cast<int>(std::floor(i * g.step_x));
          int x1 = std::max(x0 + 1, g.region.x + static_cast<int>(std::floor((i + 1) * g.step_x)));
          int y0 = g.region.y + static_cast<int>(std::floor(j * g.step_y));
          int y1 = std::max(y0 + 1, g.region.y + static_cast<int>(std::floor((j + 1) * g.step_y)));
          double sum = 0;
          for (int y = y0; y < y1; ++y)
            for (int x = x0; x < x1; ++x)
              sum += frame.ptr<uint8_t>(std::clamp(y, 0, frame.rows - 1))[std::clamp(x, 0, frame.cols - 1) * cn + c];
          level.ptr<uint8_t>(j)[i * cn + c] = cv::saturate_cast<uint8_t>(sum / ((x1 - x0) * (y1 - y0)));
        }
  }
}

namespace {

// Column offsets and rows of sample_level, reused by a thread's calls (one
// lookup of the thread's storage per call).
struct SampleTables {
  std::vector<int> cols, rows;
};

SampleTables& sample_tables() {
  thread_local SampleTables tables;
  return tables;
}

// The sampling proper; an AVX2 clone for its floors (one instruction there)
// and the gray loop's five loads.
SACCADE_AVX2_CLONE void sample_level_with(const cv::Mat& frame, double x0, double y0, double step_x, double step_y,
                                          cv::Size size, bool crop, cv::Mat& out, std::vector<int>& cols,
                                          std::vector<int>& rows) {
  const int cn = frame.channels();
  const int sx = sub_step(step_x), sy = sub_step(step_y);
  // Column offsets and rows first (the same for every row and column), so the
  // loop over pixels is integer indexing only.
  cols.resize(static_cast<std::size_t>(size.width));
  rows.resize(static_cast<std::size_t>(size.height));
  for (int i = 0; i < size.width; ++i)
    cols[static_cast<std::size_t>(i)] =
        crop ? std::clamp(static_cast<int>(std::floor(x0)) + i, 0, frame.cols - 1)
             : std::clamp(static_cast<int>(std::floor(x0 + (i + 0.5) * step_x)), sx, frame.cols - 1 - sx);
  for (int j = 0; j < size.height; ++j)
    rows[static_cast<std::size_t>(j)] =
        crop ? std::clamp(static_cast<int>(std::floor(y0)) + j, 0, frame.rows - 1)
             : std::clamp(static_cast<int>(std::floor(y0 + (j + 0.5) * step_y)), sy, frame.rows - 1 - sy);
  const std::ptrdiff_t pitch = static_cast<std::ptrdiff_t>(frame.step[0]);
  if (cn == 1) {
    // Gray, the stereo matcher's case: the same sums without the channel loop
    // and the crop test per pixel.
    const int* col = cols.data();
    for (int j = 0; j < size.height; ++j) {
      uint8_t* o = out.ptr<uint8_t>(j);
      const uint8_t* r = frame.ptr<uint8_t>(rows[static_cast<std::size_t>(j)]);
      if (crop) {
        // Inside the frame the columns are consecutive: one copy.
        if (size.width > 0 && col[size.width - 1] - col[0] == size.width - 1)
          std::memcpy(o, r + col[0], static_cast<std::size_t>(size.width));
        else
          for (int i = 0; i < size.width; ++i) o[i] = r[col[i]];
        continue;
      }
      for (int i = 0; i < size.width; ++i) {
        const uint8_t* p = r + col[i];
        o[i] = mean5(static_cast<unsigned>(p[0]) + p[-sx] + p[sx] + p[-sy * pitch] + p[sy * pitch]);
      }
    }
    return;
  }
  for (int j = 0; j < size.height; ++j) {
    uint8_t* o = out.ptr<uint8_t>(j);
    const uint8_t* r = frame.ptr<uint8_t>(rows[static_cast<std::size_t>(j)]);
    for (int i = 0; i < size.width; ++i) {
      const uint8_t* p = r + static_cast<std::ptrdiff_t>(cols[static_cast<std::size_t>(i)]) * cn;
      for (int c = 0; c < cn; ++c) {
        if (crop) {
          o[i * cn + c] = p[c];
          continue;
        }
        const unsigned sum =
            static_cast<unsigned>(p[c]) + p[c - sx * cn] + p[c + sx * cn] + p[c - sy * pitch] + p[c + sy * pitch];
        o[i * cn + c] = mean5(sum);
      }
    }
  }
}

}  // namespace

void sample_level(const cv::Mat& frame, double x0, double y0, double step_x, double step_y, cv::Size size, bool crop,
                  cv::Mat& out) {
  CV_Assert(frame.depth() == CV_8U);
  out.create(size, frame.type());
  SampleTables& tables = sample_tables();
  sample_level_with(frame, x0, y0, step_x, step_y, size, crop, out, tables.cols, tables.rows);
}

RetinaSampler::RetinaSampler(RetinaConfig config) : config_(config) {
  tables_.resize(static_cast<std::size_t>(config_.levels));
  for (auto& t : tables_) {
    t.col.resize(static_cast<std::size_t>(config_.size.width));
    t.row.resize(static_cast<std::size_t>(config_.size.height));
  }
  sums_.resize(static_cast<std::size_t>(config_.size.width));
}

Status RetinaSampler::check(const cv::Mat& frame) const {
  if (frame.empty()) return Status::error("empty frame");
  if (frame.depth() != CV_8U || (frame.channels() != 1 && frame.channels() != 3))
    return Status::error("expected an 8-bit gray or BGR frame, got type " + cv::typeToString(frame.type()));
  if (frame.cols < config_.size.width || frame.rows < config_.size.height)
    return Status::error("frame " + std::to_string(frame.cols) + "x" + std::to_string(frame.rows) +
                         " is smaller than a level (" + std::to_string(config_.size.width) + "x" +
                         std::to_string(config_.size.height) + ")");
  return {};
}

void RetinaSampler::prepare(const cv::Mat& frame, cv::Point corner) {
  const std::size_t pitch = frame.step[0];
  if (frame.size() == prepared_size_ && frame.type() == prepared_type_ && pitch == prepared_pitch_ &&
      corner == prepared_corner_)
    return;
  cv::Point2d center(corner.x + config_.size.width / 2.0, corner.y + config_.size.height / 2.0);
  retina_geometry(config_, frame.size(), center, geometry_);  // (into the member: a moving fovea allocates nothing)
  const int cn = frame.channels();
  for (std::size_t k = 0; k < geometry_.size(); ++k) {
    const LevelGeometry& g = geometry_[k];
    LevelTable& t = tables_[k];
    int sx = sub_step(g.step_x), sy = sub_step(g.step_y);
    for (int i = 0; i < config_.size.width; ++i) {
      int cx = std::clamp(cell_center(g.region.x, g.step_x, i), sx, frame.cols - 1 - sx);
      t.col[static_cast<std::size_t>(i)] = cx * cn;
    }
    for (int j = 0; j < config_.size.height; ++j) {
      int cy = std::clamp(cell_center(g.region.y, g.step_y, j), sy, frame.rows - 1 - sy);
      t.row[static_cast<std::size_t>(j)] = static_cast<std::ptrdiff_t>(cy) * static_cast<std::ptrdiff_t>(pitch);
    }
    t.up_bytes = -static_cast<std::ptrdiff_t>(sy) * static_cast<std::ptrdiff_t>(pitch);
    t.down_bytes = static_cast<std::ptrdiff_t>(sy) * static_cast<std::ptrdiff_t>(pitch);
    t.sub_x_bytes = sx * cn;
  }
  prepared_size_ = frame.size();
  prepared_type_ = frame.type();
  prepared_pitch_ = pitch;
  prepared_corner_ = corner;
}

void RetinaSampler::sample_five_point(const cv::Mat& frame, std::vector<cv::Mat>& levels) {
  const int cn = frame.channels();
  const int w = config_.size.width, h = config_.size.height;
  uint16_t* sums = sums_.data();
  for (std::size_t k = 0; k + 1 < tables_.size(); ++k) {
    const LevelTable& t = tables_[k];
    cv::Mat& level = levels[k];
    const std::ptrdiff_t s = t.sub_x_bytes;
    const std::ptrdiff_t* col = t.col.data();
    // Every sample is one base+index load from the cell centre's address.
    const std::ptrdiff_t du = t.up_bytes, dd = t.down_bytes;
    const uint8_t* data = frame.data;
    for (int j = 0; j < h; ++j) {
      const uint8_t* r0 = data + t.row[static_cast<std::size_t>(j)];
      uint8_t* out = level.ptr<uint8_t>(j);
      if (cn == 1) {
        // Sums first, the rounded division in a second loop the compiler vectorises.
        // Four pixels per iteration: the loop is bound by issuing loads, and
        // unrolling removes the counter's share of each pixel's instructions.
        int i = 0;
        for (; i + 4 <= w; i += 4) {
          const uint8_t* c0 = r0 + col[i];
          const uint8_t* c1 = r0 + col[i + 1];
          const uint8_t* c2 = r0 + col[i + 2];
          const uint8_t* c3 = r0 + col[i + 3];
          sums[i] = static_cast<uint16_t>(c0[0] + c0[-s] + c0[s] + c0[du] + c0[dd]);
          sums[i + 1] = static_cast<uint16_t>(c1[0] + c1[-s] + c1[s] + c1[du] + c1[dd]);
          sums[i + 2] = static_cast<uint16_t>(c2[0] + c2[-s] + c2[s] + c2[du] + c2[dd]);
          sums[i + 3] = static_cast<uint16_t>(c3[0] + c3[-s] + c3[s] + c3[du] + c3[dd]);
        }
        for (; i < w; ++i) {
          const uint8_t* c = r0 + col[i];
          sums[i] = static_cast<uint16_t>(c[0] + c[-s] + c[s] + c[du] + c[dd]);
        }
        for (int k2 = 0; k2 < w; ++k2) out[k2] = mean5_u16(sums[k2]);
      } else {
        for (int i = 0; i < w; ++i) {
          const uint8_t* c = r0 + col[i];
          for (int ch = 0; ch < 3; ++ch)
            out[i * 3 + ch] = mean5(static_cast<unsigned>(c[ch]) + c[ch - s] + c[ch + s] + c[ch + du] + c[ch + dd]);
        }
      }
    }
  }
}

void RetinaSampler::sample(const cv::Mat& frame, cv::Point2d fovea, std::vector<cv::Mat>& levels,
                           std::vector<LevelGeometry>& geometry) {
  cv::Point corner = clamp_fovea_corner(config_, frame.size(), fovea);
  prepare(frame, corner);
  levels.resize(static_cast<std::size_t>(config_.levels));
  for (auto& level : levels) level.create(config_.size, frame.type());
  geometry.assign(geometry_.begin(), geometry_.end());
  if (config_.mode == SamplingMode::kFivePoint) {
    sample_five_point(frame, levels);
    // The fovea is a direct crop.
    frame(geometry_.back().region).copyTo(levels.back());
  } else {
    sample_reference(config_, frame, geometry_, levels);
  }
}

void RetinaSampler::sample(const cv::Mat& frame, cv::Point2d fovea, Retina& out) {
  sample(frame, fovea, out.levels, out.geometry);
  out.source_size = frame.size();
  const cv::Rect inner = out.geometry.back().region;
  out.fovea = cv::Point(inner.x + inner.width / 2, inner.y + inner.height / 2);
  out.sampling = config_.mode == SamplingMode::kAreaMean ? Retina::Sampling::kAreaMean : Retina::Sampling::kFivePoint;
}

}  // namespace saccade::retina
