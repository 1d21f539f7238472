#include "readers.hpp"

#include <algorithm>
#include <cctype>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "saccade/log.hpp"

namespace saccade::capture {

namespace fs = std::filesystem;

namespace {

int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

int64_t frame_time_ns(int64_t index, double fps) {
  return fps > 0 ? static_cast<int64_t>(std::llround(static_cast<double>(index) * 1e9 / fps)) : index * 33'333'333;
}

std::string lower_extension(const std::string& path) {
  std::string ext = fs::path(path).extension().string();
  for (auto& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

// A path that exists but is no regular file (a FIFO, a device) would block the
// read or never end: an error naming it.
Status require_regular_file(const std::string& path) {
  std::error_code ec;
  const auto status = fs::status(path, ec);
  if (!fs::exists(status) || fs::is_regular_file(status)) return {};
  return Status::error(path + ": not a regular file (a FIFO or a device); expected an image or video file");
}

// An image's size from its file's header, for PNG, JPEG and BMP (the formats
// whose decoders would allocate first); empty when the format is another or
// the header unreadable (OpenCV's own checks then apply). OpenCV's limit,
// OPENCV_IO_MAX_IMAGE_PIXELS, is read once when the library loads, too late
// for a plugin to lower it.
cv::Size header_size(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  unsigned char h[32] = {};
  if (!in.read(reinterpret_cast<char*>(h), sizeof h)) return {};
  auto be32 = [&](int at) { return (h[at] << 24) | (h[at + 1] << 16) | (h[at + 2] << 8) | h[at + 3]; };
  if (h[0] == 0x89 && h[1] == 'P' && h[2] == 'N' && h[3] == 'G') return {be32(16), be32(20)};
  if (h[0] == 'B' && h[1] == 'M') {
    auto le32 = [&](int at) { return h[at] | (h[at + 1] << 8) | (h[at + 2] << 16) | (h[at + 3] << 24); };
    return {std::abs(le32(18)), std::abs(le32(22))};
  }
  if (h[0] != 0xff || h[1] != 0xd8) return {};
  // JPEG: walk the markers to the first start of frame (SOF0..SOF15 but DHT, JPG and DAC).
  in.seekg(2);
  for (int markers = 0; markers < 1000; ++markers) {
    unsigned char m[4];
    if (!in.read(reinterpret_cast<char*>(m), 4) || m[0] != 0xff) return {};
    const int length = (m[2] << 8) | m[3];
    if (m[1] >= 0xc0 && m[1] <= 0xcf && m[1] != 0xc4 && m[1] != 0xc8 && m[1] != 0xcc) {
      unsigned char f[5];
      if (!in.read(reinterpret_cast<char*>(f), 5)) return {};
      return {(f[3] << 8) | f[4], (f[1] << 8) | f[2]};
    }
    if (length < 2) return {};
    in.seekg(length - 2, std::ios::cur);
  }
  return {};
}

// An error when the image at `path` is larger than a reader decodes.
Status require_decodable_size(const std::string& path) {
  const cv::Size size = header_size(path);
  if (static_cast<long long>(size.width) * size.height <= kMaxImagePixels) return {};
  return Status::error(path + ": a " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                       " image; at most " + std::to_string(kMaxImagePixels) + " pixels are read");
}

class VideoReader final : public FrameReader {
 public:
  Status open(const std::string& path) {
    if (!fs::exists(path)) return Status::error(path + ": no such video file");
    if (Status s = require_regular_file(path); !s.ok()) return s;
    if (!cap_.open(path, cv::CAP_ANY) || !cap_.isOpened())
      return Status::error(path + ": OpenCV cannot open it as a video");
    fps_ = cap_.get(cv::CAP_PROP_FPS);
    length_ = std::max<int64_t>(0, static_cast<int64_t>(cap_.get(cv::CAP_PROP_FRAME_COUNT)));
    path_ = path;
    return {};
  }
  int64_t length() const override { return length_; }
  int64_t frames_unread() const override { return unread_; }
  Status read(cv::Mat& out, int64_t& media_ns) override {
    if (!cap_.read(out) || out.empty()) {
      note_early_end();
      return Status::end_of_stream();
    }
    media_ns = frame_time_ns(index_++, fps_);
    return {};
  }
  bool rewind() override {
    index_ = 0;
    return cap_.set(cv::CAP_PROP_POS_FRAMES, 0);
  }
  double fps() const override { return fps_; }

 private:
  // The end came before the header's count, by more than a header's usual
  // error (a few frames): the file is cut short, or OpenCV's FFmpeg cannot
  // decode past this frame (opencv-doc's tree.avi: 68 of 444, and seeking past
  // it fails too). Said once, and counted, rather than passed off as the end.
  void note_early_end() {
    const int64_t missing = frames_short_of(length_, index_);
    if (missing <= unread_) return;
    if (unread_ == 0)
      log().warn(
          "{}: the video ended after {} of the {} frames its header announces: frame {} could not be read "
          "(cut short, or not decodable here), and the {} frames from it on are skipped",
          path_, index_, length_, index_, missing);
    unread_ = missing;
  }

  cv::VideoCapture cap_;
  std::string path_;
  int64_t length_ = 0;
  double fps_ = 0;
  int64_t index_ = 0;
  int64_t unread_ = 0;
};

}  // namespace

Result<NumberedPattern> NumberedPattern::parse(const std::string& pattern) {
  // The user's text is never handed to printf as a format: one %d (with an
  // optional 0 flag and width, as in img_%04d.png) is the frame number, %% a
  // percent sign, and anything else after a % is refused.
  NumberedPattern out;
  bool numbered = false;
  std::string* text = &out.prefix_;
  for (std::size_t k = 0; k < pattern.size(); ++k) {
    if (pattern[k] != '%') {
      *text += pattern[k];
      continue;
    }
    std::size_t j = k + 1;
    if (j < pattern.size() && pattern[j] == '%') {
      *text += '%';
      k = j;
      continue;
    }
    const bool zero = j < pattern.size() && pattern[j] == '0';
    if (zero) ++j;
    int width = 0;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 64)
      width = width * 10 + (pattern[j++] - '0');
    if (j >= pattern.size() || pattern[j] != 'd' || numbered)
      return Status::error("pattern '" + pattern +
                           "': expected one %d for the frame number (such as img_%04d.png; %% for a percent sign), " +
                           (numbered && j < pattern.size() && pattern[j] == 'd'
                                ? "found a second"
                                : "found '" + pattern.substr(k, j - k + 1) + "'"));
    numbered = true;
    out.zero_ = zero;
    out.width_ = width;
    text = &out.suffix_;
    k = j;
  }
  if (!numbered)
    return Status::error("pattern '" + pattern + "': expected one %d for the frame number (such as img_%04d.png)");
  return out;
}

int64_t frames_short_of(int64_t announced, int64_t read) {
  const int64_t missing = announced - read;
  return missing > std::max<int64_t>(2, announced / 100) ? missing : 0;
}

std::string NumberedPattern::name(int i) const {
  char digits[128];
  std::snprintf(digits, sizeof digits, zero_ ? "%0*d" : "%*d", width_, i);  // our format, never the user's
  return prefix_ + digits + suffix_;
}

std::vector<int> NumberedPattern::numbers_present() const {
  std::vector<int> numbers;
  if (suffix_.find('/') != std::string::npos) return numbers;
  const std::size_t slash = prefix_.rfind('/');
  const std::string dir = slash == std::string::npos ? "." : prefix_.substr(0, slash + 1);
  const std::string lead = slash == std::string::npos ? prefix_ : prefix_.substr(slash + 1);
  std::error_code error;
  // (Incremented with the error code: a folder that changes while read ends the list, it does not throw.)
  for (fs::directory_iterator entry(dir, error), end; !error && entry != end; entry.increment(error)) {
    const std::string file = entry->path().filename().string();
    if (file.size() <= lead.size() + suffix_.size() || file.compare(0, lead.size(), lead) != 0 ||
        file.compare(file.size() - suffix_.size(), suffix_.size(), suffix_) != 0)
      continue;
    const std::string digits = file.substr(lead.size(), file.size() - lead.size() - suffix_.size());
    char* stop = nullptr;
    const long n = std::strtol(digits.c_str(), &stop, 10);
    // The pattern's own spelling of that number, or not one of its files.
    if (stop == digits.c_str() || *stop != '\0' || n < 0 || n > std::numeric_limits<int>::max() ||
        name(static_cast<int>(n)) != prefix_ + digits + suffix_)
      continue;
    numbers.push_back(static_cast<int>(n));
  }
  std::sort(numbers.begin(), numbers.end());
  return numbers;
}

namespace {

class SequenceReader final : public FrameReader {
 public:
  Status open(const std::string& pattern, int first, double fps) {
    auto parsed = NumberedPattern::parse(pattern);
    if (!parsed.ok()) return parsed.status();
    pattern_ = std::move(parsed).value();
    first_ = next_ = first;
    fps_ = fps;
    if (!fs::exists(name(first)))
      return Status::error(pattern + ": the first image of the sequence, " + name(first) + ", does not exist");
    text_ = pattern;
    present_ = pattern_.numbers_present();
    present_.erase(present_.begin(), std::lower_bound(present_.begin(), present_.end(), first));
    while (run_ < static_cast<int64_t>(present_.size()) && present_[static_cast<std::size_t>(run_)] == first + run_)
      ++run_;
    return {};
  }
  // The images from the first to the first missing number, where the
  // sequence ends (those after it: frames_unread, once the end is reached).
  int64_t length() const override { return run_; }
  int64_t frames_unread() const override { return unread_; }
  Status read(cv::Mat& out, int64_t& media_ns) override {
    std::string file = name(next_);
    if (!fs::exists(file)) {
      note_gap();
      return Status::end_of_stream();
    }
    if (Status s = require_regular_file(file); !s.ok()) return s;
    if (Status s = require_decodable_size(file); !s.ok()) return s;
    out = cv::imread(file, cv::IMREAD_UNCHANGED);
    if (out.empty()) return Status::error(file + ": cannot decode image");
    media_ns = frame_time_ns(next_ - first_, fps_);
    ++next_;
    return {};
  }
  bool rewind() override {
    next_ = first_;
    return true;
  }
  double fps() const override { return fps_; }

 private:
  // A number missing with images numbered after it: the sequence ends at
  // the gap, as it always has, but says so once and counts what it skips
  // (a copy that lost a file, a recording that dropped one).
  void note_gap() {
    const auto after = static_cast<int64_t>(present_.end() - std::upper_bound(present_.begin(), present_.end(), next_));
    if (after <= unread_) return;
    if (unread_ == 0)
      log().warn("{}: {} is missing: the sequence ends there, and the {} images numbered after it are skipped", text_,
                 name(next_), after);
    unread_ = after;
  }

  std::string name(int i) const { return pattern_.name(i); }
  NumberedPattern pattern_;
  std::string text_;
  std::vector<int> present_;  // the pattern's numbers from the first on, in order
  int64_t run_ = 0;           // how many of them follow the first without a gap
  int first_ = 0, next_ = 0;
  double fps_ = 0;
  int64_t unread_ = 0;
};

// Decodes once; every read hands out the same pixels without copying them.
class ImageReader final : public FrameReader {
 public:
  Status open(const std::string& path, int64_t count, double fps) {
    if (Status s = require_regular_file(path); !s.ok()) return s;
    if (Status s = require_decodable_size(path); !s.ok()) return s;
    image_ = cv::imread(path, cv::IMREAD_UNCHANGED);
    if (image_.empty())
      return Status::error(path + (fs::exists(path) ? ": cannot decode image" : ": no such image file"));
    count_ = count;
    fps_ = fps;
    return {};
  }
  int64_t length() const override { return count_; }
  Status read(cv::Mat& out, int64_t& media_ns) override {
    if (count_ > 0 && index_ >= count_) return Status::end_of_stream();
    out = image_;
    media_ns = frame_time_ns(index_++, fps_);
    return {};
  }
  bool rewind() override {
    index_ = 0;
    return true;
  }
  double fps() const override { return fps_; }

 private:
  cv::Mat image_;
  int64_t count_ = 0, index_ = 0;
  double fps_ = 0;
};

class CameraReader final : public FrameReader {
 public:
  Status open(const std::string& device, cv::Size size, double fps) {
    bool numeric = !device.empty() && device.find_first_not_of("0123456789") == std::string::npos;
    // At most four digits, so std::stoi below cannot throw.
    if (numeric && device.size() > 4)
      return Status::error("camera '" + device + "': a V4L2 index is 0..9999 (/dev/videoN)");
    bool ok = numeric ? cap_.open(std::stoi(device), cv::CAP_V4L2) : cap_.open(device, cv::CAP_V4L2);
    if (!ok || !cap_.isOpened())
      return Status::error("camera '" + device + "' cannot be opened through V4L2 (is it connected, and is " +
                           (numeric ? "/dev/video" + device : device) + " readable?)");
    if (size.area() > 0) {
      cap_.set(cv::CAP_PROP_FRAME_WIDTH, size.width);
      cap_.set(cv::CAP_PROP_FRAME_HEIGHT, size.height);
    }
    if (fps > 0) cap_.set(cv::CAP_PROP_FPS, fps);
    return {};
  }
  Status read(cv::Mat& out, int64_t& media_ns) override {
    if (!cap_.read(out) || out.empty()) return Status::error("camera stopped delivering frames");
    media_ns = now_ns();
    return {};
  }
  double fps() const override { return cap_.get(cv::CAP_PROP_FPS); }
  bool live() const override { return true; }

 private:
  mutable cv::VideoCapture cap_;
};

}  // namespace

SourceKind classify_source(const std::string& path) {
  if (path.find('%') != std::string::npos) return SourceKind::kSequence;
  if (!path.empty() && path.find_first_not_of("0123456789") == std::string::npos) return SourceKind::kCamera;
  if (path.rfind("/dev/video", 0) == 0) return SourceKind::kCamera;
  std::string ext = lower_extension(path);
  for (const char* e : {".png", ".jpg", ".jpeg", ".bmp", ".pgm", ".ppm", ".tif", ".tiff", ".webp"})
    if (ext == e) return SourceKind::kImage;
  return SourceKind::kVideo;
}

Result<std::unique_ptr<FrameReader>> open_video(const std::string& path) {
  auto r = std::make_unique<VideoReader>();
  if (Status s = r->open(path); !s.ok()) return s;
  return std::unique_ptr<FrameReader>(std::move(r));
}

Result<std::unique_ptr<FrameReader>> open_sequence(const std::string& pattern, int first, double fps) {
  auto r = std::make_unique<SequenceReader>();
  if (Status s = r->open(pattern, first, fps); !s.ok()) return s;
  return std::unique_ptr<FrameReader>(std::move(r));
}

Result<std::unique_ptr<FrameReader>> open_image(const std::string& path, int64_t count, double fps) {
  auto r = std::make_unique<ImageReader>();
  if (Status s = r->open(path, count, fps); !s.ok()) return s;
  return std::unique_ptr<FrameReader>(std::move(r));
}

Result<std::unique_ptr<FrameReader>> open_camera(const std::string& device, cv::Size size, double fps) {
  auto r = std::make_unique<CameraReader>();
  if (Status s = r->open(device, size, fps); !s.ok()) return s;
  return std::unique_ptr<FrameReader>(std::move(r));
}

Result<std::unique_ptr<FrameReader>> open_any(const std::string& path, double fps) {
  switch (classify_source(path)) {
    case SourceKind::kSequence: return open_sequence(path, 1, fps);
    case SourceKind::kImage: return open_image(path, 0, fps);
    case SourceKind::kCamera: return open_camera(path, {}, fps);
    case SourceKind::kVideo: return open_video(path);
  }
  return Status::error("'" + path + "': an unknown kind of source");
}

SyntheticRenderer::SyntheticRenderer(SyntheticScene scene) : scene_(std::move(scene)) {
  cv::RNG rng(scene_.seed);
  int s = scene_.target_size;
  texture_.create(s, s, CV_8UC3);
  // A checkerboard of random colours plus fine noise: texture at every scale, so
  // both the tracker and the stereo matcher have something to lock onto.
  int cell = std::max(2, s / 6);
  for (int y = 0; y < s; ++y)
    for (int x = 0; x < s; ++x) {
      bool dark = ((x / cell) + (y / cell)) % 2 == 0;
      auto& px = texture_.at<cv::Vec3b>(y, x);
      for (int c = 0; c < 3; ++c) {
        int base = dark ? 40 : 215;
        px[c] = cv::saturate_cast<uchar>(base + rng.uniform(-35, 36));
      }
    }
  if (scene_.background_disparity != 0) {
    cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -scene_.background_disparity, 0, 1, 0);
    cv::warpAffine(scene_.background, right_background_, shift, scene_.background.size(), cv::INTER_NEAREST,
                   cv::BORDER_REPLICATE);
  } else {
    right_background_ = scene_.background;
  }
}

namespace {

// Position on a segment [lo, hi] of a point moving at `v` per frame from `x0`,
// reflected at both ends (a triangle wave).
double reflect(double x0, double v, double k, double lo, double hi) {
  const double span = hi - lo;
  if (span <= 0) return lo;
  double u = std::fmod(x0 - lo + v * k, 2.0 * span);
  if (u < 0) u += 2.0 * span;
  return lo + (u <= span ? u : 2.0 * span - u);
}

// A deterministic hash of (seed, n) to [0, 1): where the n-th jump lands.
double unit_hash(uint64_t seed, uint64_t n) {
  uint64_t z = seed * 0x9E3779B97F4A7C15ull + n * 0xBF58476D1CE4E5B9ull + 0x94D049BB133111EBull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z ^= z >> 31;
  return static_cast<double>(z >> 11) * 0x1.0p-53;
}

}  // namespace

cv::Point SyntheticRenderer::target_corner(int64_t k) const {
  const cv::Size size = scene_.background.size();
  const int s = scene_.target_size;
  double cx = size.width / 2.0, cy = size.height / 2.0;
  if (scene_.path == "bounce") {
    const double a = scene_.angle_deg * M_PI / 180.0;
    const double o = scene_.overshoot;
    double x0 = cx, y0 = cy;
    double t = static_cast<double>(k);
    if (scene_.jump_every > 0) {
      // Each jump restarts the run from a new place, inside the frame.
      const int64_t n = k / scene_.jump_every;
      t = static_cast<double>(k % scene_.jump_every);
      if (n > 0) {
        x0 = s / 2.0 + unit_hash(scene_.seed, static_cast<uint64_t>(2 * n)) * (size.width - s);
        y0 = s / 2.0 + unit_hash(scene_.seed, static_cast<uint64_t>(2 * n + 1)) * (size.height - s);
      }
    }
    cx = reflect(x0, scene_.speed * std::cos(a), t, s / 2.0 - o, size.width - s / 2.0 + o);
    cy = reflect(y0, scene_.speed * std::sin(a), t, s / 2.0 - o, size.height - s / 2.0 + o);
    return {static_cast<int>(std::lround(cx - s / 2.0)), static_cast<int>(std::lround(cy - s / 2.0))};
  }
  double phase = 2.0 * M_PI * static_cast<double>(k) / scene_.period_frames;
  if (scene_.path == "circle") {
    cx += scene_.radius * std::cos(phase);
    cy += scene_.radius * std::sin(phase);
  } else if (scene_.path == "line") {
    cx += scene_.radius * std::sin(phase);
  }
  int x = static_cast<int>(std::lround(cx - s / 2.0));
  int y = static_cast<int>(std::lround(cy - s / 2.0));
  x = std::clamp(x, 0, size.width - s);
  y = std::clamp(y, 0, size.height - s);
  return {x, y};
}

double SyntheticRenderer::target_visible(int64_t k) const {
  cv::Point c = target_corner(k);
  const int s = scene_.target_size;
  cv::Rect inside = cv::Rect(c.x, c.y, s, s) & cv::Rect(cv::Point(), scene_.background.size());
  return static_cast<double>(inside.area()) / (static_cast<double>(s) * s);
}

cv::Point2d SyntheticRenderer::target_center(int64_t k) const {
  cv::Point c = target_corner(k);
  // Centre of the covered pixels [x, x+s): pixel centres at x+0.5 ... x+s-0.5.
  return {c.x + scene_.target_size / 2.0, c.y + scene_.target_size / 2.0};
}

void SyntheticRenderer::render(int64_t k, cv::Mat& left, cv::Mat& right) const {
  cv::Point c = target_corner(k);
  int s = scene_.target_size;
  scene_.background.copyTo(left);
  cv::Rect target(c.x, c.y, s, s);
  cv::Rect shown = target & cv::Rect(0, 0, left.cols, left.rows);
  if (shown.area() > 0) texture_(shown - target.tl()).copyTo(left(shown));
  if (right.data != nullptr || scene_.disparity != 0 || scene_.background_disparity != 0) {
    right_background_.copyTo(right);
    int rx = c.x - scene_.disparity;
    cv::Rect dst(rx, c.y, s, s);
    cv::Rect visible = dst & cv::Rect(0, 0, right.cols, right.rows);
    if (visible.area() > 0) texture_(visible - dst.tl()).copyTo(right(visible));
  }
}

}  // namespace saccade::capture
