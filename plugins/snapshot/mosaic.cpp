#include "mosaic.hpp"

#include <bit>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include <opencv2/imgproc.hpp>

namespace saccade::snapshot {

namespace {

const cv::Scalar kText(255, 255, 255);

cv::Scalar level_color(std::size_t k, std::size_t n) {
  double t = n > 1 ? static_cast<double>(k) / static_cast<double>(n - 1) : 1.0;
  return cv::Scalar(255 * (1 - t), 80 + 100 * (1 - std::abs(2 * t - 1)), 255 * t);
}

cv::Mat source_bgr(const Retina& retina) {
  if (retina.source && !retina.source->mat.empty()) return to_display(retina.source->mat);
  return cv::Mat(retina.source_size, CV_8UC3, cv::Scalar(0, 0, 0));
}

}  // namespace

cv::Mat to_display(const cv::Mat& image) {
  cv::Mat m8;
  if (image.depth() == CV_8U) {
    m8 = image;
  } else {
    double lo = 0, hi = 0;
    cv::minMaxLoc(image.reshape(1), &lo, &hi);
    if (lo < 0) {
      double a = std::max(std::abs(lo), std::abs(hi));
      image.convertTo(m8, CV_8U, a > 0 ? 127.5 / a : 1.0, 127.5);
    } else {
      image.convertTo(m8, CV_8U, hi > 0 ? 255.0 / hi : 1.0);
    }
  }
  cv::Mat bgr;
  if (m8.channels() == 1)
    cv::cvtColor(m8, bgr, cv::COLOR_GRAY2BGR);
  else
    bgr = m8.clone();
  return bgr;
}

cv::Mat disparity_color(const cv::Mat& disparity, double max_disparity) {
  CV_Assert(disparity.type() == CV_32F);
  cv::Mat valid = disparity >= 0;
  if (max_disparity <= 0) cv::minMaxLoc(disparity, nullptr, &max_disparity, nullptr, nullptr, valid);
  cv::Mat scaled, color;
  disparity.convertTo(scaled, CV_8U, max_disparity > 0 ? 255.0 / max_disparity : 1.0);
  cv::applyColorMap(scaled, color, cv::COLORMAP_JET);
  color.setTo(cv::Scalar(0, 0, 0), ~valid);
  return color;
}

cv::Mat disparity_png16(const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  cv::Mat out(disparity.size(), CV_16U);
  for (int y = 0; y < disparity.rows; ++y) {
    const float* d = disparity.ptr<float>(y);
    uint16_t* o = out.ptr<uint16_t>(y);
    for (int x = 0; x < disparity.cols; ++x) {
      const double v = d[x];
      o[x] = v >= 0 && std::isfinite(v)
                 ? static_cast<uint16_t>(std::min(65535.0, std::round(v * kDisparityPng16Scale) + 1))
                 : uint16_t{0};
    }
  }
  return out;
}

cv::Mat disparity_from_png16(const cv::Mat& png16) {
  CV_Assert(png16.type() == CV_16U);
  cv::Mat out(png16.size(), CV_32F);
  for (int y = 0; y < png16.rows; ++y) {
    const uint16_t* v = png16.ptr<uint16_t>(y);
    float* o = out.ptr<float>(y);
    for (int x = 0; x < png16.cols; ++x)
      o[x] = v[x] == 0 ? -1.0f : static_cast<float>((v[x] - 1) / kDisparityPng16Scale);
  }
  return out;
}

bool write_pfm(const std::string& path, const cv::Mat& disparity) {
  CV_Assert(disparity.type() == CV_32F);
  std::ofstream file(path, std::ios::binary);
  if (!file) return false;
  static_assert(std::endian::native == std::endian::little, "PFM is written little-endian (scale -1)");
  file << "Pf\n" << disparity.cols << ' ' << disparity.rows << "\n-1\n";
  std::vector<float> row(static_cast<std::size_t>(disparity.cols));
  for (int y = disparity.rows - 1; y >= 0; --y) {
    const float* d = disparity.ptr<float>(y);
    for (int x = 0; x < disparity.cols; ++x)
      row[static_cast<std::size_t>(x)] =
          d[x] >= 0 && std::isfinite(d[x]) ? d[x] : std::numeric_limits<float>::infinity();
    file.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(row.size() * sizeof(float)));
  }
  return static_cast<bool>(file);
}

cv::Mat read_pfm(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  std::string magic;
  int width = 0, height = 0;
  double scale = 0;
  if (!(file >> magic >> width >> height >> scale) || magic != "Pf" || width <= 0 || height <= 0 || scale == 0)
    return {};
  file.get();  // the one whitespace character after the scale
  cv::Mat out(height, width, CV_32F);
  const bool swap = (scale > 0) != (std::endian::native == std::endian::big);
  for (int y = height - 1; y >= 0; --y) {
    float* o = out.ptr<float>(y);
    if (!file.read(reinterpret_cast<char*>(o), static_cast<std::streamsize>(width * sizeof(float)))) return {};
    if (swap)
      for (int x = 0; x < width; ++x) {
        uint32_t bits;
        std::memcpy(&bits, o + x, sizeof bits);
        bits = __builtin_bswap32(bits);
        std::memcpy(o + x, &bits, sizeof bits);
      }
  }
  return out;
}

cv::Mat retina_overlay(const Retina& retina) {
  cv::Mat out = source_bgr(retina);
  int thickness = std::max(1, out.cols / 400);
  for (std::size_t k = 0; k < retina.geometry.size(); ++k)
    cv::rectangle(out, retina.geometry[k].region, level_color(k, retina.geometry.size()), thickness);
  cv::drawMarker(out, retina.fovea, cv::Scalar(0, 0, 255), cv::MARKER_CROSS, 12, thickness);
  cv::putText(out, "frame " + std::to_string(retina.frame_id), {8, 20}, cv::FONT_HERSHEY_SIMPLEX, 0.6, kText, 1,
              cv::LINE_AA);
  return out;
}

cv::Mat track_overlay(const FoveaState& state, const std::vector<TrackPoint>& track) {
  if (!state.retina) return {};
  cv::Mat out = retina_overlay(*state.retina);
  const int thickness = std::max(1, out.cols / 400);
  auto color = [](FoveaState::State s) {
    switch (s) {
      case FoveaState::State::kTracking: return cv::Scalar(0, 220, 0);
      case FoveaState::State::kLost: return cv::Scalar(0, 0, 255);
      case FoveaState::State::kUncertain: return cv::Scalar(0, 140, 255);
      case FoveaState::State::kSearching: break;
    }
    return cv::Scalar(0, 220, 255);
  };
  for (std::size_t i = 1; i < track.size(); ++i) {
    cv::line(out, track[i - 1].fovea, track[i].fovea, color(track[i].state), thickness, cv::LINE_AA);
    if (track[i - 1].target_valid && track[i].target_valid)
      cv::line(out, track[i - 1].target, track[i].target, cv::Scalar(255, 160, 0), thickness, cv::LINE_AA);
  }
  for (const TrackPoint& t : track)
    if (t.gaze_request) cv::circle(out, t.fovea, 10 * thickness, cv::Scalar(255, 0, 255), thickness, cv::LINE_AA);
  if (state.target_valid) {
    if (state.target.w > 0 && state.target.h > 0)
      cv::rectangle(out, state.target.rect(), cv::Scalar(255, 160, 0), thickness, cv::LINE_AA);
    else
      cv::drawMarker(out, state.target.center(), cv::Scalar(255, 160, 0), cv::MARKER_SQUARE, 10, thickness);
  }
  char text[160];
  std::snprintf(text, sizeof text, "%s  score %.2f  shifts %lld  gaze requests %lld", to_string(state.state),
                state.score, static_cast<long long>(state.attention_shifts),
                static_cast<long long>(state.gaze_requests));
  cv::putText(out, text, {8, 42}, cv::FONT_HERSHEY_SIMPLEX, 0.6, color(state.state), 1, cv::LINE_AA);
  return out;
}

cv::Mat level_strip(const std::vector<cv::Mat>& levels, int scale, const std::string& title) {
  if (levels.empty()) return {};
  const int gap = 4, header = 18;
  // Retina levels are enlarged; full-frame maps (the baseline's) are not.
  scale = std::max(1, std::min(scale, 256 / std::max(1, levels[0].cols)));
  cv::Size cell(levels[0].cols * scale, levels[0].rows * scale);
  cv::Mat out(cell.height + header, static_cast<int>(levels.size()) * (cell.width + gap) - gap, CV_8UC3,
              cv::Scalar(40, 40, 40));
  const bool disparity = title.rfind("disparity", 0) == 0;
  double max_disparity = 0;
  if (disparity)
    for (const auto& level : levels) {
      double m = 0;
      cv::minMaxLoc(level, nullptr, &m);
      max_disparity = std::max(max_disparity, m);
    }
  for (std::size_t k = 0; k < levels.size(); ++k) {
    cv::Mat big;
    cv::Mat shown =
        disparity && levels[k].type() == CV_32F ? disparity_color(levels[k], max_disparity) : to_display(levels[k]);
    cv::resize(shown, big, cell, 0, 0, cv::INTER_NEAREST);
    big.copyTo(out(cv::Rect(static_cast<int>(k) * (cell.width + gap), header, cell.width, cell.height)));
    cv::putText(out, "L" + std::to_string(k), {static_cast<int>(k) * (cell.width + gap) + 2, 13},
                cv::FONT_HERSHEY_SIMPLEX, 0.4, kText, 1, cv::LINE_AA);
  }
  if (!title.empty())
    cv::putText(out, title, {out.cols - 8 * static_cast<int>(title.size()) - 4, 13}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 220, 255), 1, cv::LINE_AA);
  return out;
}

cv::Mat foveated_view(const Retina& retina) {
  cv::Mat out(retina.source_size, CV_8UC3, cv::Scalar(0, 0, 0));
  for (std::size_t k = 0; k < retina.levels.size(); ++k) {
    const cv::Rect& r = retina.geometry[k].region;
    cv::Mat big;
    cv::resize(to_display(retina.levels[k]), big, r.size(), 0, 0, cv::INTER_NEAREST);
    big.copyTo(out(r));
  }
  return out;
}

cv::Mat feature_grid(const FeatureMaps& maps, int scale) {
  std::vector<cv::Mat> strips;
  int width = 0;
  for (std::size_t i = 0; i < maps.names.size(); ++i) {
    strips.push_back(level_strip(maps.maps[i], scale, maps.names[i]));
    width = std::max(width, strips.back().cols);
  }
  if (strips.empty()) return {};
  int height = 0;
  for (const auto& s : strips) height += s.rows + 4;
  cv::Mat out(height, width, CV_8UC3, cv::Scalar(20, 20, 20));
  int y = 0;
  for (const auto& s : strips) {
    s.copyTo(out(cv::Rect(0, y, s.cols, s.rows)));
    y += s.rows + 4;
  }
  return out;
}

}  // namespace saccade::snapshot
