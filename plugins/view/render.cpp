#include "render.hpp"

#include <algorithm>
#include <cstring>

#include <opencv2/imgproc.hpp>

#include "channel.hpp"

namespace saccade::view {

namespace {

constexpr int kMinRows = 96;  // a retina level is enlarged to at least this many rows
constexpr int kGap = 2;
constexpr std::size_t kMaxFeatures = 12;

// `in` as 8-bit BGR: 8-bit as is, anything else scaled from its own range.
void to_bgr8(const cv::Mat& in, cv::Mat& out) {
  cv::Mat eight;
  if (in.depth() == CV_8U) {
    eight = in;
  } else {
    cv::Mat one = in.channels() == 1 ? in : in.reshape(1);
    double lo = 0, hi = 0;
    cv::minMaxLoc(one, &lo, &hi);
    const double scale = hi > lo ? 255.0 / (hi - lo) : 0.0;
    in.convertTo(eight, CV_8U, scale, -lo * scale);
  }
  if (eight.channels() == 3) {
    out = eight;
  } else if (eight.channels() == 1) {
    cv::cvtColor(eight, out, cv::COLOR_GRAY2BGR);
  } else if (eight.channels() == 4) {
    cv::cvtColor(eight, out, cv::COLOR_BGRA2BGR);
  } else {
    out.release();
  }
}

int enlargement(const cv::Mat& m) { return m.rows > 0 ? std::max(1, (kMinRows + m.rows - 1) / m.rows) : 1; }

// Draws `grid` (rows of tiles) into `out`, tiles enlarged by nearest neighbour.
void draw_grid(const std::vector<std::vector<const cv::Mat*>>& grid, cv::Mat& out) {
  int width = 0, height = 0;
  for (const auto& row : grid) {
    int w = 0, h = 0;
    for (const cv::Mat* m : row) {
      const int k = enlargement(*m);
      w += m->cols * k + kGap;
      h = std::max(h, m->rows * k);
    }
    width = std::max(width, w);
    height += h + kGap;
  }
  if (width <= 0 || height <= 0) {
    out.release();
    return;
  }
  out.create(height, width, CV_8UC3);
  out.setTo(cv::Scalar(40, 40, 40));
  int y = 0;
  cv::Mat tile, big;
  for (const auto& row : grid) {
    int x = 0, h = 0;
    for (const cv::Mat* m : row) {
      const int k = enlargement(*m);
      to_bgr8(*m, tile);
      if (tile.empty()) continue;
      cv::resize(tile, big, cv::Size(m->cols * k, m->rows * k), 0, 0, cv::INTER_NEAREST);
      big.copyTo(out(cv::Rect(x, y, big.cols, big.rows)));
      x += big.cols + kGap;
      h = std::max(h, big.rows);
    }
    y += h + kGap;
  }
}

void put_u32(std::vector<uint8_t>& out, uint32_t v) {
  const std::size_t at = out.size();
  out.resize(at + 4);
  std::memcpy(out.data() + at, &v, 4);  // little-endian hosts (CDR_LE)
}

// Pads to a multiple of 4 from the end of the encapsulation header.
void align4(std::vector<uint8_t>& out) {
  while ((out.size() - 4) % 4 != 0) out.push_back(0);
}

void put_string(std::vector<uint8_t>& out, std::string_view s) {
  align4(out);
  put_u32(out, static_cast<uint32_t>(s.size() + 1));
  out.insert(out.end(), s.begin(), s.end());
  out.push_back(0);
}

}  // namespace

bool has_picture(std::string_view type) {
  return type == Image::kTypeName || type == Retina::kTypeName || type == FeatureMaps::kTypeName;
}

void render_picture(const Message& message, cv::Mat& out) {
  const std::string_view type = message.type_name();
  if (type == Image::kTypeName) {
    const auto& image = static_cast<const Image&>(message);
    if (image.mat.empty()) {
      out.release();
      return;
    }
    if (image.mat.depth() == CV_8U && (image.mat.channels() == 1 || image.mat.channels() == 3)) {
      out = image.mat;  // imencode takes it as it is
    } else {
      to_bgr8(image.mat, out);
    }
    return;
  }
  std::vector<std::vector<const cv::Mat*>> grid;
  if (type == Retina::kTypeName) {
    const auto& retina = static_cast<const Retina&>(message);
    grid.emplace_back();
    for (const cv::Mat& level : retina.levels)
      if (!level.empty()) grid.back().push_back(&level);
  } else if (type == FeatureMaps::kTypeName) {
    const auto& maps = static_cast<const FeatureMaps&>(message);
    for (std::size_t f = 0; f < maps.maps.size() && f < kMaxFeatures; ++f) {
      grid.emplace_back();
      for (const cv::Mat& level : maps.maps[f])
        if (!level.empty()) grid.back().push_back(&level);
    }
  }
  draw_grid(grid, out);
}

const std::string& compressed_image_schema() {
  static const std::string schema = dds::ros2_schema_with_header(R"(std_msgs/Header header
string format
uint8[] data
)");
  return schema;
}

void encode_compressed_image(int64_t timestamp_ns, std::string_view frame_id, const std::vector<uint8_t>& jpeg,
                             std::vector<uint8_t>& out) {
  out.clear();
  out.reserve(jpeg.size() + 64 + frame_id.size());
  out.insert(out.end(), {0x00, 0x01, 0x00, 0x00});  // CDR, little-endian
  const int64_t sec = timestamp_ns >= 0 ? timestamp_ns / 1000000000 : 0;
  const int64_t nsec = timestamp_ns >= 0 ? timestamp_ns % 1000000000 : 0;
  put_u32(out, static_cast<uint32_t>(static_cast<int32_t>(sec)));
  put_u32(out, static_cast<uint32_t>(nsec));
  put_string(out, frame_id);
  put_string(out, "jpeg");
  align4(out);
  put_u32(out, static_cast<uint32_t>(jpeg.size()));
  out.insert(out.end(), jpeg.begin(), jpeg.end());
}

}  // namespace saccade::view
