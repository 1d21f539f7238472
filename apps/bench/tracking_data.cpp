#include "tracking_data.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <random>
#include <sstream>
#include <utility>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/videoio.hpp>

#include "readers.hpp"

namespace saccade::bench {
namespace {

namespace fs = std::filesystem;
constexpr double kPi = std::numbers::pi;

Result<cv::Mat> read_image(const std::string& path) {
  cv::Mat image;
  try {
    image = cv::imread(path, cv::IMREAD_COLOR);
  } catch (const cv::Exception& e) {  // a decoder's limits (e.g. image size) are asserted
    return Status::error("cannot read image " + path + ": " + e.what());
  }
  if (image.empty()) return Status::error("cannot read image " + path);
  return image;
}

bool open_video(cv::VideoCapture& video, const std::string& path) {
  try {
    return video.open(path) && video.isOpened();
  } catch (const cv::Exception&) {  // a backend that cannot parse the name throws
    return false;
  }
}

// Sequence::frame's error for an index outside the sequence.
Status no_such_frame(int i, std::size_t frames) {
  return Status::error("no frame " + std::to_string(i) + " (the sequence has " + std::to_string(frames) + ")");
}

}  // namespace

void truncate(Sequence& sequence, int frames) {
  if (frames <= 0 || frames >= sequence.size()) return;
  sequence.truth.resize(static_cast<std::size_t>(frames));
  sequence.visible.resize(static_cast<std::size_t>(frames));
}

Status resample(Sequence& sequence, int every, double scale) {
  if (every < 1 || every > 100)
    return Status::error("every " + std::to_string(every) + ": expected a whole number from 1 to 100");
  char factor[32];
  std::snprintf(factor, sizeof factor, "%g", scale);
  if (!(scale >= 0.1 && scale <= 8))
    return Status::error("scale " + std::string(factor) + ": expected a factor from 0.1 to 8");
  if (every == 1 && scale == 1) return {};
  const cv::Size from = sequence.frame_size;
  const cv::Size to(static_cast<int>(std::lround(from.width * scale)),
                    static_cast<int>(std::lround(from.height * scale)));
  if (to.width < 2 || to.height < 2)
    return Status::error(sequence.name + ": its " + std::to_string(from.width) + "x" + std::to_string(from.height) +
                         " frames scaled by " + factor + " are under 2x2");
  // The truth by the frame's own ratios: its size is rounded to whole pixels.
  const double sx = static_cast<double>(to.width) / from.width, sy = static_cast<double>(to.height) / from.height;
  std::vector<cv::Rect2d> truth;
  std::vector<bool> visible;
  for (int i = 0; i < sequence.size(); i += every) {
    const cv::Rect2d& b = sequence.truth[static_cast<std::size_t>(i)];
    truth.emplace_back(b.x * sx, b.y * sy, b.width * sx, b.height * sy);
    visible.push_back(sequence.visible[static_cast<std::size_t>(i)]);
  }
  sequence.truth = std::move(truth);
  sequence.visible = std::move(visible);
  sequence.frame_size = to;
  sequence.frame = [read = std::move(sequence.frame), every, to, shrink = scale < 1,
                    count = sequence.truth.size()](int i) -> Result<cv::Mat> {
    // (Checked here: the reader's own error would number the frames as it read them.)
    if (i < 0 || static_cast<std::size_t>(i) >= count) return no_such_frame(i, count);
    Result<cv::Mat> frame = read(i * every);
    if (!frame.ok() || frame->size() == to) return frame;
    cv::Mat out;
    cv::resize(*frame, out, to, 0, 0, shrink ? cv::INTER_AREA : cv::INTER_LINEAR);
    return out;
  };
  if (every != 1) sequence.name += "@every" + std::to_string(every);
  if (scale != 1) sequence.name += "@scale" + std::string(factor);
  return {};
}

void make_gray(Sequence& sequence) {
  sequence.frame = [read = std::move(sequence.frame)](int i) -> Result<cv::Mat> {
    Result<cv::Mat> frame = read(i);
    if (!frame.ok() || frame->channels() == 1) return frame;
    cv::Mat gray, out;
    cv::cvtColor(*frame, gray, cv::COLOR_BGR2GRAY);
    cv::cvtColor(gray, out, cv::COLOR_GRAY2BGR);
    return out;
  };
  sequence.name += "@gray";
}

Status make_jpeg(Sequence& sequence, int quality) {
  if (quality < 1 || quality > 100)
    return Status::error("jpeg quality " + std::to_string(quality) + ": expected a whole number from 1 to 100");
  sequence.frame = [read = std::move(sequence.frame), quality](int i) -> Result<cv::Mat> {
    Result<cv::Mat> frame = read(i);
    if (!frame.ok()) return frame;
    std::vector<uchar> bytes;
    if (!cv::imencode(".jpg", *frame, bytes, {cv::IMWRITE_JPEG_QUALITY, quality}))
      return Status::error("frame " + std::to_string(i) + ": the JPEG encoder refused it");
    return cv::imdecode(bytes, cv::IMREAD_COLOR);
  };
  sequence.name += "@jpeg" + std::to_string(quality);
  return {};
}

Status make_white_balance(Sequence& sequence, double amount) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", amount);
  if (!(amount >= 0.01 && amount <= 0.5))
    return Status::error("white balance " + std::string(text) + ": expected an amount from 0.01 to 0.5");
  sequence.frame = [read = std::move(sequence.frame), amount](int i) -> Result<cv::Mat> {
    Result<cv::Mat> frame = read(i);
    if (!frame.ok() || frame->channels() != 3) return frame;
    const double swing = amount * std::sin(2 * kPi * i / kWhiteBalancePeriod);
    cv::Mat out;
    cv::multiply(*frame, cv::Scalar(1 - swing, 1, 1 + swing), out);
    return out;
  };
  sequence.name += "@wb" + std::string(text);
  return {};
}

// ---------------------------------------------------------------- readers

Result<TruthRow> parse_truth_row(const std::string& row, const std::string& where) {
  std::string text = row;
  // Commas, tabs and a CR left by CRLF line ends are all separators.
  std::replace_if(
      text.begin(), text.end(), [](char c) { return c == ',' || c == '\t' || c == '\r'; }, ' ');
  std::istringstream tokens(text);
  std::vector<double> v;
  for (std::string token; tokens >> token;) {
    char* end = nullptr;
    const double number = std::strtod(token.c_str(), &end);
    if (end == token.c_str() || *end != '\0') return Status::error(where + ": '" + token + "' is not a number");
    v.push_back(number);
  }
  if (v.size() != 4 && v.size() != 8)
    return Status::error(where + ": expected 4 numbers (x,y,w,h) or 8 (a polygon x1,y1,...,x4,y4), got " +
                         std::to_string(v.size()));
  if (std::any_of(v.begin(), v.end(), [](double x) { return std::isnan(x); })) return TruthRow{{}, false};
  cv::Rect2d box(v[0], v[1], v[2], v[3]);
  if (v.size() == 8) {
    const double x0 = std::min({v[0], v[2], v[4], v[6]}), x1 = std::max({v[0], v[2], v[4], v[6]});
    const double y0 = std::min({v[1], v[3], v[5], v[7]}), y1 = std::max({v[1], v[3], v[5], v[7]});
    box = {x0, y0, x1 - x0, y1 - y0};
  } else if (box.width < 0 || box.height < 0) {
    return Status::error(where + ": negative width or height");
  }
  // An empty box is how several datasets (GOT-10k, LaSOT) mark an absent target.
  return TruthRow{box, box.width > 0 && box.height > 0};
}

namespace {

// Appends the file's rows to the sequence's truth and visibility.
Status read_truth_file(const fs::path& path, Sequence& sequence) {
  std::ifstream in(path);
  if (!in) return Status::error("cannot open " + path.string());
  std::vector<std::string> lines;
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  // Trailing blank lines are common; a blank line inside would shift every later frame.
  auto blank = [](const std::string& s) { return s.find_first_not_of(" \t\r") == std::string::npos; };
  while (!lines.empty() && blank(lines.back())) lines.pop_back();
  if (lines.empty()) return Status::error(path.string() + ": no ground-truth rows");
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const Result<TruthRow> row = parse_truth_row(lines[i], path.string() + ":" + std::to_string(i + 1));
    if (!row.ok()) return row.status();
    sequence.truth.push_back(row->box);
    sequence.visible.push_back(row->visible);
  }
  return {};
}

// The frames are read when asked for; the first now, for the frame size.
Status attach_frames(Sequence& sequence, std::vector<std::string> paths) {
  const Result<cv::Mat> first = read_image(paths.front());
  if (!first.ok()) return first.status();
  sequence.frame_size = first->size();
  auto shared = std::make_shared<std::vector<std::string>>(std::move(paths));
  sequence.frame = [shared](int i) -> Result<cv::Mat> {
    if (i < 0 || static_cast<std::size_t>(i) >= shared->size()) return no_such_frame(i, shared->size());
    return read_image((*shared)[static_cast<std::size_t>(i)]);
  };
  return {};
}

Status require_folder(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return Status::error(dir.string() + ": not a folder");
  return {};
}

// "data/Basketball/" and "data/Basketball" are both named Basketball.
std::string folder_name(const std::string& dir) {
  fs::path path = fs::path(dir).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();
  return path.filename().string();
}

// A sequence's image folder: every .jpg or .png whose name is a number,
// in the order of the numbers, which must follow each other without a gap.
struct NumberedImages {
  std::vector<std::string> paths;
  std::vector<long> numbers;
  int digits = 4;  // of the names, for naming a missing one
  std::string extension = ".jpg";
};

Result<NumberedImages> list_numbered_images(const fs::path& folder) {
  if (Status s = require_folder(folder); !s.ok()) return s;
  std::vector<std::pair<long, fs::path>> found;
  std::error_code ec;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder, ec)) {
    const std::string extension = entry.path().extension().string(), stem = entry.path().stem().string();
    if ((extension != ".jpg" && extension != ".png") || stem.empty() ||
        !std::all_of(stem.begin(), stem.end(), [](char c) { return c >= '0' && c <= '9'; }))
      continue;
    found.emplace_back(std::strtol(stem.c_str(), nullptr, 10), entry.path());
  }
  if (ec) return Status::error(folder.string() + ": cannot list (" + ec.message() + ")");
  if (found.empty()) return Status::error(folder.string() + ": no numbered .jpg or .png images");
  std::sort(found.begin(), found.end());
  NumberedImages images;
  images.digits = static_cast<int>(found.front().second.stem().string().size());
  images.extension = found.front().second.extension().string();
  for (std::size_t i = 0; i < found.size(); ++i) {
    if (i > 0 && found[i].first == found[i - 1].first)
      return Status::error(found[i - 1].second.string() + " and " + found[i].second.filename().string() +
                           ": two images of one number");
    if (i > 0 && found[i].first != found[i - 1].first + 1)
      return Status::error(found[i - 1].second.string() + ": the next image is " + found[i].second.filename().string() +
                           " (the images must be numbered without gaps)");
    images.numbers.push_back(found[i].first);
    images.paths.push_back(found[i].second.string());
  }
  return images;
}

// The images the truth's `rows` belong to: from number `first_image` on (0:
// the first image); and how many the folder holds.
struct TruthFrames {
  std::vector<std::string> paths;
  std::size_t in_folder = 0;
};

// An image's file name in a numbered folder: `number` zero-padded to `digits`.
std::string numbered_name(long number, int digits, const std::string& extension) {
  const std::string text = std::to_string(number);
  return std::string(static_cast<std::size_t>(std::max(0, digits - static_cast<int>(text.size()))), '0') + text +
         extension;
}

Result<TruthFrames> truth_frames(const fs::path& folder, int first_image, std::size_t rows,
                                 const fs::path& truth_file) {
  Result<NumberedImages> listed = list_numbered_images(folder);
  if (!listed.ok()) return listed.status();
  const NumberedImages& images = *listed;
  auto name = [&](long number) { return (folder / numbered_name(number, images.digits, images.extension)).string(); };
  const long first = first_image > 0 ? first_image : images.numbers.front();
  if (first < images.numbers.front() || first > images.numbers.back())
    return Status::error(name(first) + ": missing (the truth starts there; " + folder.filename().string() + "/ holds " +
                         fs::path(images.paths.front()).filename().string() + " to " +
                         fs::path(images.paths.back()).filename().string() + ")");
  const std::size_t start = static_cast<std::size_t>(first - images.numbers.front());
  if (images.paths.size() - start < rows)
    return Status::error(name(images.numbers.back() + 1) + ": missing (" + truth_file.filename().string() + " has " +
                         std::to_string(rows) + " rows from image " + std::to_string(first) + ")");
  return TruthFrames{{images.paths.begin() + static_cast<std::ptrdiff_t>(start),
                      images.paths.begin() + static_cast<std::ptrdiff_t>(start + rows)},
                     images.paths.size()};
}

// The truth's rows paired with the folder's images from number `first_image`
// on (0: the first), and a note where images were left over at the end.
Status pair_frames(const fs::path& folder, int first_image, const fs::path& truth_file, Sequence& sequence) {
  Result<TruthFrames> frames = truth_frames(folder, first_image, sequence.truth.size(), truth_file);
  if (!frames.ok()) return frames.status();
  const std::vector<std::string>& paths = frames->paths;
  if (first_image <= 0 && frames->in_folder > paths.size())
    sequence.note = truth_file.filename().string() + " has " + std::to_string(paths.size()) + " rows for " +
                    std::to_string(frames->in_folder) + " images: taken as " +
                    fs::path(paths.front()).filename().string() + " to " + fs::path(paths.back()).filename().string() +
                    "'s";
  return attach_frames(sequence, std::move(frames->paths));
}

}  // namespace

Result<Sequence> read_otb(const std::string& dir, int first_image, const std::string& truth_name) {
  if (Status s = require_folder(dir); !s.ok()) return s;
  Sequence sequence;
  sequence.name = folder_name(dir);
  const fs::path truth_file = fs::path(dir) / truth_name;
  if (Status s = read_truth_file(truth_file, sequence); !s.ok()) return s;
  if (Status s = pair_frames(fs::path(dir) / "img", first_image, truth_file, sequence); !s.ok()) return s;
  return sequence;
}

Result<OtbFolder> parse_otb_folder(const std::string& spec) {
  const std::size_t colon = spec.rfind(':');
  std::error_code ec;
  if (colon == std::string::npos || colon + 1 == spec.size() || fs::is_directory(spec, ec) ||
      spec.find_first_not_of("0123456789", colon + 1) != std::string::npos)
    return OtbFolder{spec, 0};
  int first = 0;
  const char* digits = spec.data() + colon + 1;
  const std::from_chars_result read = std::from_chars(digits, spec.data() + spec.size(), first);
  if (read.ec != std::errc() || first < 1)
    return Status::error(spec + ": expected DIR or DIR:FIRST, FIRST an image number from 1 to " +
                         std::to_string(std::numeric_limits<int>::max()));
  return OtbFolder{spec.substr(0, colon), first};
}

Result<std::vector<Sequence>> read_otb_targets(const std::string& dir, int first_image) {
  if (Status s = require_folder(dir); !s.ok()) return s;
  std::error_code ec;
  std::vector<Sequence> targets;
  if (fs::exists(fs::path(dir) / "groundtruth_rect.txt", ec)) {
    Result<Sequence> one = read_otb(dir, first_image);
    if (!one.ok()) return one.status();
    targets.push_back(std::move(one).value());
    return targets;
  }
  for (int n = 1; fs::exists(fs::path(dir) / ("groundtruth_rect." + std::to_string(n) + ".txt"), ec); ++n) {
    Result<Sequence> target = read_otb(dir, first_image, "groundtruth_rect." + std::to_string(n) + ".txt");
    if (!target.ok()) return target.status();
    target->name += "." + std::to_string(n);  // as OTB names them: Jogging.1, Jogging.2
    targets.push_back(std::move(target).value());
  }
  if (targets.empty())
    return Status::error("cannot open " + (fs::path(dir) / "groundtruth_rect.txt").string() +
                         " (nor groundtruth_rect.1.txt, as a folder with several targets has)");
  return targets;
}

Status write_otb(const Sequence& sequence, const std::string& dir) {
  if (!sequence.truth_known) return Status::error(sequence.name + ": no truth to write (only its first box is known)");
  std::error_code ec;
  const fs::path img = fs::path(dir) / "img";
  // Images left from a longer export would be read as this sequence's.
  if (fs::exists(img, ec) && !fs::is_empty(img, ec))
    return Status::error(img.string() + ": already holds files; export into a folder without them");
  fs::create_directories(img, ec);
  if (ec) return Status::error(img.string() + ": cannot be made (" + ec.message() + ")");
  const int digits = std::max(4, static_cast<int>(std::to_string(sequence.size()).size()));
  const fs::path truth_path = fs::path(dir) / "groundtruth_rect.txt";
  std::ofstream truth(truth_path);
  for (int i = 0; i < sequence.size(); ++i) {
    const Result<cv::Mat> frame = sequence.frame(i);
    if (!frame.ok()) return frame.status();
    const fs::path image = img / numbered_name(i + 1, digits, ".png");
    if (!cv::imwrite(image.string(), *frame)) return Status::error(image.string() + ": cannot be written");
    const cv::Rect2d& b = sequence.truth[static_cast<std::size_t>(i)];
    std::string row;
    for (const double v : {b.x, b.y, b.width, b.height}) {
      char text[32] = "NaN";
      if (sequence.visible[static_cast<std::size_t>(i)]) *std::to_chars(text, text + sizeof text - 1, v).ptr = 0;
      row += (row.empty() ? "" : ",") + std::string(text);
    }
    truth << row << "\n";
  }
  if (!truth) return Status::error(truth_path.string() + ": cannot be written");
  return {};
}

Result<VideoTarget> parse_video_target(const std::string& spec) {
  const Status bad = Status::error("--video " + spec + ": expected FILE:FIRST:x,y,w,h or FILE:FIRST:x,y,w,h:COUNT");
  // Taken apart from the right: the path may hold ':' itself.
  std::size_t end = spec.size();
  const auto take = [&spec, &end](std::string& part) {
    if (end == 0) return false;
    const std::size_t colon = spec.rfind(':', end - 1);
    if (colon == std::string::npos || colon == 0) return false;
    part = spec.substr(colon + 1, end - colon - 1);
    end = colon;
    return true;
  };
  std::string first, box, count;
  if (!take(box)) return bad;
  if (box.find(',') == std::string::npos) {
    count = std::exchange(box, {});
    if (count.empty() || !take(box)) return bad;
  }
  if (!take(first) || box.find(',') == std::string::npos) return bad;
  const auto whole = [](const std::string& text, int& value) {
    const std::from_chars_result read = std::from_chars(text.data(), text.data() + text.size(), value);
    return !text.empty() && read.ec == std::errc() && read.ptr == text.data() + text.size() && value >= 0;
  };
  VideoTarget target;
  target.path = spec.substr(0, end);
  if (!whole(first, target.first_frame)) return bad;
  if (!count.empty() && (!whole(count, target.frames) || target.frames < 2 ||
                         target.frames > std::numeric_limits<int>::max() - target.first_frame))
    return Status::error("--video " + spec + ": COUNT must be a whole number of frames, 2 or more");
  if (std::count(box.begin(), box.end(), ',') != 3) return bad;
  Result<TruthRow> row = parse_truth_row(box, "--video " + spec);
  if (!row.ok()) return row.status();
  const cv::Rect2d& b = row->box;
  if (!row->visible || !std::isfinite(b.x) || !std::isfinite(b.y) || !std::isfinite(b.width) ||
      !std::isfinite(b.height))
    return Status::error("--video " + spec + ": the box must be finite, with a width and a height");
  target.box = b;
  return target;
}

Result<Sequence> read_video(const VideoTarget& target) {
  // A missing file is named before OpenCV is asked: asked, it tries every
  // backend, cameras' too (whose USB probing leaks under AddressSanitizer).
  std::error_code error;
  if (!fs::exists(target.path, error)) return Status::error("cannot open video " + target.path + ": no such file");
  if (!fs::is_regular_file(target.path, error))
    return Status::error("cannot open video " + target.path + ": not a file");
  auto video = std::make_shared<cv::VideoCapture>();
  if (!open_video(*video, target.path)) return Status::error("cannot open video " + target.path);
  // The frames are read through once: a video's own frame count is a guess
  // for some containers, and a seek is exact for none.
  cv::Mat frame;
  int read = 0;
  const int wanted = target.frames > 0 ? static_cast<int>(std::min<int64_t>(int64_t{target.first_frame} + target.frames,
                                                                            std::numeric_limits<int>::max()))
                                       : std::numeric_limits<int>::max();
  const auto announced = static_cast<int64_t>(video->get(cv::CAP_PROP_FRAME_COUNT));
  cv::Size size;
  while (read < wanted && video->read(frame)) {
    if (read == target.first_frame) size = frame.size();
    ++read;
  }
  if (read <= target.first_frame + 1)
    return Status::error("video " + target.path + " has " + std::to_string(read) + " frames: none after frame " +
                         std::to_string(target.first_frame) + " to follow the box into");
  const cv::Rect2d& b = target.box;
  if ((b & cv::Rect2d(0, 0, size.width, size.height)).area() <= 0)
    return Status::error("video " + target.path + ": the box " + std::to_string(b.x) + "," + std::to_string(b.y) + "," +
                         std::to_string(b.width) + "," + std::to_string(b.height) + " lies outside its " +
                         std::to_string(size.width) + "x" + std::to_string(size.height) + " frames");
  Sequence sequence;
  // Every number of the spec but the count: two targets differ in the name.
  sequence.name = fs::path(target.path).stem().string() + "@" + std::to_string(target.first_frame);
  for (const double v : {b.x, b.y, b.width, b.height}) sequence.name += "+" + std::to_string(std::lround(v));
  sequence.frame_size = size;
  const auto count = static_cast<std::size_t>(read - target.first_frame);
  if (target.frames > 0 && static_cast<int>(count) < target.frames)
    sequence.note = "the video ends " + std::to_string(count) + " frames after frame " +
                    std::to_string(target.first_frame) + ", not " + std::to_string(target.frames);
  // (As capture.video: a header's count off by a few is usual, more is a
  // video cut short or not decodable past a frame.)
  if (read < wanted && capture::frames_short_of(announced, read) > 0)
    sequence.note += std::string(sequence.note.empty() ? "" : "; ") + "only " + std::to_string(read) + " of the " +
                     std::to_string(announced) + " frames its header announces could be read";
  sequence.truth.assign(count, b);
  sequence.visible.assign(count, true);
  sequence.truth_known = false;
  video->release();
  // Read in order, as the benchmark asks: one open video and the index of
  // the next frame it gives (a frame at or before the last one read opens
  // the video again: each tracker and run reads from the start).
  auto next = std::make_shared<int>(0);
  sequence.frame = [video, next, path = target.path, first = target.first_frame, count](int i) -> Result<cv::Mat> {
    if (i < 0 || static_cast<std::size_t>(i) >= count) return no_such_frame(i, count);
    const int index = first + i;
    if (!video->isOpened() || *next > index) {
      if (!open_video(*video, path)) return Status::error("cannot open video " + path + " again");
      *next = 0;
    }
    cv::Mat image;
    for (; *next <= index; ++*next)
      if (!video->read(image)) return Status::error("video " + path + ": cannot read frame " + std::to_string(*next));
    return image;
  };
  return sequence;
}

Result<Sequence> read_vot(const std::string& dir) {
  if (Status s = require_folder(dir); !s.ok()) return s;
  Sequence sequence;
  sequence.name = folder_name(dir);
  const fs::path truth_file = fs::path(dir) / "groundtruth.txt";
  if (Status s = read_truth_file(truth_file, sequence); !s.ok()) return s;
  // VOT 2020 and later keep the frames in color/, LaSOT in img/; older VOT
  // editions and GOT-10k next to the truth.
  std::error_code ec;
  fs::path folder = dir;
  for (const char* sub : {"color", "img"})
    if (fs::is_directory(fs::path(dir) / sub, ec)) {
      folder = fs::path(dir) / sub;
      break;
    }
  if (Status s = pair_frames(folder, 0, truth_file, sequence); !s.ok()) return s;
  return sequence;
}

// ---------------------------------------------------------------- generator

namespace {

// std::mt19937's output is fixed by the standard; the library's
// distributions are not, so the conversion to doubles is done here.
class Random {
 public:
  explicit Random(uint32_t seed) : engine_(seed) {}
  double uniform(double lo, double hi) { return lo + (hi - lo) * (engine_() / 4294967296.0); }

 private:
  std::mt19937 engine_;
};

// A piecewise-linear ramp through (u, value) knots, u in [0, 1].
double ramp(double u, std::initializer_list<std::pair<double, double>> knots) {
  auto previous = *knots.begin();
  for (const auto& knot : knots) {
    if (u <= knot.first) {
      if (knot.first <= previous.first) return knot.second;
      const double t = (u - previous.first) / (knot.first - previous.first);
      return previous.second + t * (knot.second - previous.second);
    }
    previous = knot;
  }
  return previous.second;
}

double smoothstep(double t) {
  t = std::clamp(t, 0.0, 1.0);
  return t * t * (3 - 2 * t);
}

// Smooth motion as a sum of sinusoids with seeded periods and phases.
struct Wave {
  double amplitude = 0, period = 1, phase = 0;
  double at(double t) const { return amplitude * std::sin(2 * kPi * t / period + phase); }
};

struct Wobble {
  std::vector<Wave> x, y;
  cv::Point2d at(double t) const {
    cv::Point2d p;
    for (const Wave& w : x) p.x += w.at(t);
    for (const Wave& w : y) p.y += w.at(t);
    return p;
  }
};

// Hand-held shake: three components per axis, from `shortest` frames up,
// their amplitudes adding up to `amplitude`.
Wobble make_shake(Random& random, double amplitude, double shortest) {
  Wobble shake;
  const double weights[] = {0.5, 0.3, 0.2}, stretch[] = {1.0, 1.9, 3.3};
  for (int k = 0; k < 3; ++k) {
    shake.x.push_back(
        {amplitude * weights[k], shortest * stretch[k] * random.uniform(0.9, 1.1), random.uniform(0, 2 * kPi)});
    shake.y.push_back(
        {amplitude * weights[k], shortest * stretch[k] * random.uniform(0.9, 1.1), random.uniform(0, 2 * kPi)});
  }
  return shake;
}

// Everything that differs between frames, planned before any is rendered so
// that frames can be rendered in any order.
struct FramePlan {
  cv::Point2d view;    // the view's top-left corner in the (scaled) background
  cv::Point2d center;  // the target's centre, frame pixels (edge coordinates)
  double scale = 1;
  double angle_deg = 0;
  cv::Point2d smear;  // image motion during the exposure, pixels
  double gain = 1, offset = 0;
  int occlusion = -1;  // index of the occluder in front, -1 when none
  cv::Rect occluder;   // frame pixels
  bool distractor = false;
  cv::Point2d distractor_center;
};

// An image drawn at many scales: a pyramid, so that drawing shrinks by at
// most 2 (no aliasing) and rarely magnifies.
struct Sprite {
  cv::Size2d base;              // frame pixels at scale 1
  std::vector<cv::Mat> levels;  // largest first
  std::vector<cv::Mat> alpha;   // each level's coverage (CV_32F, 0..1), or none: the whole rectangle is drawn
  // Turning targets: each level's picture beside its mirror image (one turn
  // round the cylinder), which `levels` show a half of as the target turns.
  std::vector<cv::Mat> wrapped;
};

struct Scene {
  SyntheticScript script;
  cv::Mat background;
  Sprite target, distractor;
  std::vector<cv::Mat> occluders;  // one patch per Occlusion, at its size in the frame
  std::vector<FramePlan> plans;
  double turn_period = 0;  // frames of a turn back and forth (SyntheticScript::turn_deg)
};

cv::Size2d target_base_size(const SyntheticScript& script) {
  const double k = script.target_side / std::max(script.target_crop.width, script.target_crop.height);
  return {script.target_crop.width * k, script.target_crop.height * k};
}

// The part `rect` of the image at `path` (named by `what` in the error).
Result<cv::Mat> crop_of(const std::string& path, const cv::Rect& rect, const std::string& what) {
  const Result<cv::Mat> image = read_image(path);
  if (!image.ok()) return image.status();
  if ((rect & cv::Rect(0, 0, image->cols, image->rows)) != rect || rect.empty())
    return Status::error(what + ": crop rectangle outside the image");
  return (*image)(rect).clone();
}

// The ellipse inscribed in a `size` rectangle, as coverage: 1 inside, 0
// outside, its edge anti-aliased (drawn 4x finer, then area-averaged).
cv::Mat inscribed_ellipse(cv::Size size) {
  constexpr int kFine = 4;
  cv::Mat fine = cv::Mat::zeros(size * kFine, CV_8U), coverage;
  cv::ellipse(fine, cv::RotatedRect(cv::Point2f(fine.cols / 2.0f, fine.rows / 2.0f), cv::Size2f(fine.size()), 0),
              cv::Scalar(255), cv::FILLED);
  cv::resize(fine, coverage, size, 0, 0, cv::INTER_AREA);
  coverage.convertTo(coverage, CV_32F, 1.0 / 255);
  return coverage;
}

Sprite make_sprite(const cv::Mat& image, cv::Size2d base, double max_scale, double min_scale, bool round,
                   bool turning) {
  Sprite sprite;
  sprite.base = base;
  const double k = std::max(1.0, max_scale);
  const cv::Size largest(std::max(1, static_cast<int>(std::lround(base.width * k))),
                         std::max(1, static_cast<int>(std::lround(base.height * k))));
  cv::Mat level;
  const bool magnify = largest.width > image.cols;
  cv::resize(image, level, largest, 0, 0, magnify ? cv::INTER_CUBIC : cv::INTER_AREA);
  sprite.levels.push_back(level);
  const double smallest_side = std::max(base.width, base.height) * std::min(1.0, min_scale) / 2;
  while (std::max(level.cols, level.rows) / 2.0 > std::max(8.0, smallest_side)) {
    cv::resize(level, level, cv::Size((level.cols + 1) / 2, (level.rows + 1) / 2), 0, 0, cv::INTER_AREA);
    sprite.levels.push_back(level);
  }
  if (round)
    for (const cv::Mat& l : sprite.levels) sprite.alpha.push_back(inscribed_ellipse(l.size()));
  if (turning)
    for (const cv::Mat& l : sprite.levels) {
      cv::Mat mirrored, both;
      cv::flip(l, mirrored, 1);
      cv::hconcat(l, mirrored, both);
      sprite.wrapped.push_back(both);
    }
  return sprite;
}

// What a turning sprite's level shows `turned` radians into its turn: the
// wrapped picture seen on a cylinder, column u (-1..1 across) at the angle
// asin(u) + turned, the front half (-pi/2..pi/2) the picture itself.
void turned_level(const cv::Mat& wrapped, double turned, cv::Mat& out, cv::Mat& map_x, cv::Mat& map_y) {
  const int w = wrapped.cols / 2, h = wrapped.rows;
  map_x.create(h, w, CV_32F);
  map_y.create(h, w, CV_32F);
  for (int x = 0; x < w; ++x) {
    const double u = std::clamp((x + 0.5) / (w / 2.0) - 1, -1.0, 1.0);
    double column = (std::asin(u) + turned) / kPi * w + w / 2.0 - 0.5;
    column -= 2.0 * w * std::floor((column + 0.5) / (2.0 * w));
    for (int y = 0; y < h; ++y) {
      map_x.at<float>(y, x) = static_cast<float>(column);
      map_y.at<float>(y, x) = static_cast<float>(y);
    }
  }
  cv::remap(wrapped, out, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_WRAP);
}

// The axis-aligned box around the target rotated by `angle_deg`.
cv::Rect2d rotated_bounds(cv::Point2d center, cv::Size2d size, double angle_deg) {
  const double a = angle_deg * kPi / 180, c = std::abs(std::cos(a)), s = std::abs(std::sin(a));
  const double hw = (size.width * c + size.height * s) / 2, hh = (size.width * s + size.height * c) / 2;
  return {center.x - hw, center.y - hh, 2 * hw, 2 * hh};
}

cv::Rect2d truth_box(cv::Point2d center, cv::Size2d size) {
  return {center.x - size.width / 2, center.y - size.height / 2, size.width, size.height};
}

// --- Planning the motion.

struct Motion {
  Wobble shake, pan, wander;
  std::vector<cv::Point2d> excursion_direction;
  double rotation_period = 150, scale_period = 200, distractor_period = 90;
};

Motion plan_motion(const SyntheticScript& s, Random& random) {
  Motion m;
  m.shake = make_shake(random, s.shake, s.shake_period);
  m.pan.x.push_back({s.pan, 230 * random.uniform(0.8, 1.2), random.uniform(0, 2 * kPi)});
  m.pan.y.push_back({s.pan / 2, 170 * random.uniform(0.8, 1.2), random.uniform(0, 2 * kPi)});
  const double ax = s.wander * s.frame_size.width / 2, ay = s.wander * s.frame_size.height / 2;
  m.wander.x.push_back({ax, s.wander_period * random.uniform(0.9, 1.1), random.uniform(0, 2 * kPi)});
  m.wander.y.push_back({ay, 1.37 * s.wander_period * random.uniform(0.9, 1.1), random.uniform(0, 2 * kPi)});
  for (std::size_t i = 0; i < s.excursions.size(); ++i) {
    // Alternate sides, mostly sideways as a head's pan would.
    const double side = (i % 2 == 0 ? 1.0 : -1.0), tilt = random.uniform(-0.3, 0.3);
    m.excursion_direction.push_back(cv::Point2d(side, tilt) / std::hypot(1.0, tilt));
  }
  m.rotation_period = s.frames / 2.0 * random.uniform(0.8, 1.2);
  m.scale_period = s.frames / 1.5 * random.uniform(0.9, 1.1);
  m.distractor_period = 90 * random.uniform(0.8, 1.2);
  return m;
}

double scale_at(const SyntheticScript& s, const Motion& m, double t) {
  // From 1 up to scale_max, back, down to scale_min, back: log-scale sine.
  const double wave = std::sin(2 * kPi * t / m.scale_period);
  return std::exp(wave > 0 ? std::log(s.scale_max) * wave : -std::log(s.scale_min) * wave);
}

// How far the camera has looked away at frame t.
cv::Point2d excursion_at(const SyntheticScript& s, const Motion& m, int t) {
  const cv::Size2d base = target_base_size(s);
  const double reach = std::hypot(base.width, base.height) * std::max(1.0, s.scale_max) / 2 + s.shake + 12;
  cv::Point2d shift;
  for (std::size_t i = 0; i < s.excursions.size(); ++i) {
    const Excursion& e = s.excursions[i];
    const double away = smoothstep((t - e.start) / 20.0) * smoothstep((e.start + e.length - t) / 20.0);
    const cv::Point2d d = m.excursion_direction[i];  // mostly sideways: |d.x| > 0.95
    // Far enough sideways that the target, wherever it wanders, is wholly outside.
    const double distance = (s.frame_size.width / 2.0 * (1 + s.wander) + reach) / std::abs(d.x);
    shift += away * distance * d;
  }
  return shift;
}

void plan_occlusion(const SyntheticScript& s, const Motion& m, const cv::Size2d& target_size, int t, FramePlan& p) {
  const cv::Size2d base = target_base_size(s);
  for (std::size_t k = 0; k < s.occlusions.size(); ++k) {
    const Occlusion& o = s.occlusions[k];
    if (t < o.start || t >= o.end) continue;
    // Sized once, by the target's size as the occluder comes in.
    const double start_side = std::max(base.width, base.height) * scale_at(s, m, o.start);
    const int side = static_cast<int>(std::lround(o.size * start_side));
    const cv::Rect2d bounds = rotated_bounds(p.center, target_size, p.angle_deg);
    const double reach = (side + bounds.width) / 2 + 4;
    const double u = o.end - o.start > 1 ? (t - o.start) / double(o.end - o.start - 1) : 0.5;
    const double cx = p.center.x - reach + 2 * reach * u, cy = p.center.y + o.offset_y * target_size.height;
    p.occlusion = static_cast<int>(k);
    p.occluder = cv::Rect(static_cast<int>(std::lround(cx - side / 2.0)),
                          static_cast<int>(std::lround(cy - side / 2.0)), side, side);
  }
}

std::vector<FramePlan> plan_frames(const SyntheticScript& s, const cv::Size2d& base, const Motion& m) {
  std::vector<FramePlan> plans(static_cast<std::size_t>(s.frames));
  const cv::Point2d middle(s.frame_size.width / 2.0, s.frame_size.height / 2.0);
  cv::Point2d previous_view;
  for (int t = 0; t < s.frames; ++t) {
    FramePlan& p = plans[static_cast<std::size_t>(t)];
    const cv::Point2d shake = m.shake.at(t), away = excursion_at(s, m, t);
    // The camera follows the target with its pan; shake and looking away move
    // the background and the target alike.
    p.view = m.pan.at(t) + shake + away;
    p.center = middle + m.wander.at(t) - shake - away;
    p.scale = scale_at(s, m, t);
    p.angle_deg = s.rotation_deg * std::sin(2 * kPi * t / m.rotation_period);
    p.smear = t > 0 ? -s.blur * (p.view - previous_view) : cv::Point2d();
    // A camera's exposure is short even while it turns fast: at most a 20th of the frame's width.
    const double smear_length = std::hypot(p.smear.x, p.smear.y), longest = s.frame_size.width / 20.0;
    if (smear_length > longest) p.smear *= longest / smear_length;
    previous_view = p.view;
    const double u = t / double(std::max(1, s.frames - 1));
    p.gain = 1 + s.light * ramp(u, {{0, 0}, {0.15, 0}, {0.35, -1}, {0.5, -1}, {0.7, 1}, {0.85, 1}, {1, 0}});
    p.offset = 40 * s.light * ramp(u, {{0, 0}, {0.2, 0}, {0.4, 0.6}, {0.6, -0.8}, {0.8, 1}, {1, 0}});
    const cv::Size2d size(base.width * p.scale, base.height * p.scale);
    plan_occlusion(s, m, size, t, p);
    if (s.distractor && t >= 10) {
      // Circles the target, passing behind it twice a lap.
      const double a = 2 * kPi * t / m.distractor_period, r = 1.7 * size.width;
      p.distractor = true;
      p.distractor_center = p.center + cv::Point2d(r * std::cos(a), 0.15 * r * std::sin(a));
    }
  }
  return plans;
}

// Invisible: nothing of the target inside the frame, or what is inside lies
// under the occluder (with a pixel to spare for interpolation's blur).
bool target_visible(const FramePlan& p, cv::Size2d target_size, cv::Size frame) {
  const cv::Rect2d inside =
      rotated_bounds(p.center, target_size, p.angle_deg) & cv::Rect2d(0, 0, frame.width, frame.height);
  if (inside.width < 1 || inside.height < 1) return false;
  if (p.occlusion < 0) return true;
  const cv::Rect2d padded(inside.x - 1, inside.y - 1, inside.width + 2, inside.height + 2);
  const cv::Rect2d needed = padded & cv::Rect2d(0, 0, frame.width, frame.height);
  return (cv::Rect2d(p.occluder) & needed) != needed;
}

// --- Building the scene.

// Scales the background so that every view lies inside it, and moves the
// views into it.
cv::Mat fit_background(const cv::Mat& image, cv::Size frame, std::vector<FramePlan>& plans) {
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const FramePlan& p : plans) {
    x0 = std::min(x0, p.view.x), y0 = std::min(y0, p.view.y);
    x1 = std::max(x1, p.view.x), y1 = std::max(y1, p.view.y);
  }
  const double margin = 4, need_w = x1 - x0 + frame.width + 2 * margin, need_h = y1 - y0 + frame.height + 2 * margin;
  const double k = std::max({1.0, need_w / image.cols, need_h / image.rows});
  cv::Mat background;
  if (k > 1)
    cv::resize(image, background, cv::Size(), k, k, cv::INTER_CUBIC);
  else
    background = image;
  // Centre the views' span in the background.
  const cv::Point2d origin((background.cols - (x1 - x0 + frame.width)) / 2 - x0,
                           (background.rows - (y1 - y0 + frame.height)) / 2 - y0);
  for (FramePlan& p : plans) p.view += origin;
  return background;
}

// A dimmer, tinted mirror image of the target: similar, not identical.
cv::Mat look_alike(const cv::Mat& target) {
  cv::Mat mirrored, tinted;
  cv::flip(target, mirrored, 1);
  mirrored.convertTo(tinted, CV_8UC3, 0.85, 0);
  cv::add(tinted, cv::Scalar(14, -6, 8), tinted);
  return tinted;
}

Result<std::vector<cv::Mat>> make_occluders(const SyntheticScript& s, const std::string& data_dir, Random& random,
                                            const std::vector<FramePlan>& plans) {
  std::vector<cv::Mat> patches(s.occlusions.size());
  if (s.occlusions.empty()) return patches;
  const Result<cv::Mat> read = read_image(data_dir + "/" + s.occluder_image);
  if (!read.ok()) return read.status();
  const cv::Mat& source = *read;
  for (const FramePlan& p : plans) {
    if (p.occlusion < 0 || !patches[static_cast<std::size_t>(p.occlusion)].empty()) continue;
    // A random square of the occluder image, a third of its smaller side.
    const int side = std::min(source.cols, source.rows) / 3;
    const int x = static_cast<int>(random.uniform(0, source.cols - side)),
              y = static_cast<int>(random.uniform(0, source.rows - side));
    cv::resize(source(cv::Rect(x, y, side, side)), patches[static_cast<std::size_t>(p.occlusion)], p.occluder.size(), 0,
               0, cv::INTER_AREA);
  }
  return patches;
}

Result<std::shared_ptr<Scene>> build_scene(const SyntheticScript& s, const std::string& data_dir) {
  if (s.frames < 1 || s.frame_size.area() <= 0 || s.scale_min <= 0 || s.scale_max < s.scale_min)
    return Status::error(s.name + ": invalid script");
  auto scene = std::make_shared<Scene>();
  scene->script = s;
  Random random(s.seed);
  const Motion motion = plan_motion(s, random);
  const cv::Size2d base = target_base_size(s);
  scene->plans = plan_frames(s, base, motion);
  // From a generator of its own: everything else stays as without the turn.
  scene->turn_period = 150 * Random(s.seed + 7919).uniform(0.8, 1.2);
  const Result<cv::Mat> background = read_image(data_dir + "/" + s.background);
  if (!background.ok()) return background.status();
  scene->background = fit_background(*background, s.frame_size, scene->plans);
  const Result<cv::Mat> target = crop_of(data_dir + "/" + s.target_image, s.target_crop, s.target_image);
  if (!target.ok()) return target.status();
  scene->target = make_sprite(*target, base, s.scale_max, s.scale_min, s.round, s.turn_deg > 0);
  if (s.distractor)
    scene->distractor = make_sprite(look_alike(*target), base, s.scale_max, s.scale_min, s.round, s.turn_deg > 0);
  auto occluders = make_occluders(s, data_dir, random, scene->plans);
  if (!occluders.ok()) return occluders.status();
  scene->occluders = std::move(occluders).value();
  return scene;
}

// --- Rendering.

// Draws the sprite centred on `centre` (edge coordinates) at `scale` and
// `angle_deg`: exactly over truth_box(centre, base * scale) when unrotated.
void draw_sprite(cv::Mat& frame, const Sprite& sprite, cv::Point2d center, double scale, double angle_deg,
                 double turned) {
  const cv::Size2d size(sprite.base.width * scale, sprite.base.height * scale);
  std::size_t k = 0;
  while (k + 1 < sprite.levels.size() && sprite.levels[k + 1].cols >= size.width) ++k;
  cv::Mat turned_image, map_x, map_y;
  if (!sprite.wrapped.empty()) turned_level(sprite.wrapped[k], turned, turned_image, map_x, map_y);
  const cv::Mat& image = sprite.wrapped.empty() ? sprite.levels[k] : turned_image;
  const double fx = size.width / image.cols, fy = size.height / image.rows;
  const double a = angle_deg * kPi / 180, c = std::cos(a), s = std::sin(a);
  const cv::Rect roi = cv::Rect(rotated_bounds(center, size, angle_deg) + cv::Size2d(2, 2) - cv::Point2d(1, 1)) &
                       cv::Rect(0, 0, frame.cols, frame.rows);
  if (roi.empty()) return;
  // Image pixel centres (i - (n-1)/2) map to the frame's pixel-centre
  // coordinates around centre - 0.5 (pixel centres sit at edge + 0.5).
  const double ix = (image.cols - 1) / 2.0, iy = (image.rows - 1) / 2.0;
  const double tx = center.x - 0.5 - roi.x, ty = center.y - 0.5 - roi.y;
  const cv::Matx23d m(c * fx, -s * fy, tx - (c * fx * ix - s * fy * iy), s * fx, c * fy,
                      ty - (s * fx * ix + c * fy * iy));
  cv::Mat dst = frame(roi);
  if (sprite.alpha.empty()) {
    // Transparent border: only pixels the sprite covers are written.
    cv::warpAffine(image, dst, m, roi.size(), cv::INTER_LINEAR, cv::BORDER_TRANSPARENT);
    return;
  }
  // Round: blended over the frame by the warped coverage.
  cv::Mat drawn, coverage, drawn_f, dst_f;
  cv::warpAffine(image, drawn, m, roi.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::warpAffine(sprite.alpha[k], coverage, m, roi.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
  cv::Mat coverage3;
  cv::merge(std::vector<cv::Mat>(3, coverage), coverage3);
  drawn.convertTo(drawn_f, CV_32FC3);
  dst.convertTo(dst_f, CV_32FC3);
  dst_f += coverage3.mul(drawn_f - dst_f);
  dst_f.convertTo(dst, CV_8UC3);
}

void motion_blur(cv::Mat& frame, cv::Point2d smear) {
  const double length = std::hypot(smear.x, smear.y);
  if (length < 1) return;
  const int half = static_cast<int>(std::ceil(length / 2)), side = 2 * half + 1;
  cv::Mat kernel = cv::Mat::zeros(side, side, CV_32F);
  constexpr int kShift = 4;  // sub-pixel bits of cv::line's coordinates
  const cv::Point2d mid(half, half);
  auto fixed = [](cv::Point2d p) {
    return cv::Point(static_cast<int>(std::lround(p.x * (1 << kShift))),
                     static_cast<int>(std::lround(p.y * (1 << kShift))));
  };
  cv::line(kernel, fixed(mid - smear / 2), fixed(mid + smear / 2), cv::Scalar(1), 1, cv::LINE_AA, kShift);
  kernel /= cv::sum(kernel)[0];
  cv::filter2D(frame, frame, -1, kernel, cv::Point(-1, -1), 0, cv::BORDER_REFLECT);
}

cv::Mat render_frame(const Scene& scene, int i) {
  const SyntheticScript& s = scene.script;
  const FramePlan& p = scene.plans.at(static_cast<std::size_t>(i));
  cv::Mat frame;
  const cv::Matx23d view(1, 0, -p.view.x, 0, 1, -p.view.y);
  cv::warpAffine(scene.background, frame, view, s.frame_size, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  // The look-alike turns the other way.
  const double turned = s.turn_deg * kPi / 180 * std::sin(2 * kPi * i / scene.turn_period);
  if (p.distractor) draw_sprite(frame, scene.distractor, p.distractor_center, p.scale, p.angle_deg, -turned);
  draw_sprite(frame, scene.target, p.center, p.scale, p.angle_deg, turned);
  if (p.occlusion >= 0) {
    const cv::Rect inside = p.occluder & cv::Rect(0, 0, frame.cols, frame.rows);
    const cv::Mat& patch = scene.occluders[static_cast<std::size_t>(p.occlusion)];
    if (!inside.empty()) patch(inside - p.occluder.tl()).copyTo(frame(inside));
  }
  motion_blur(frame, p.smear);
  // Lighting, then sensor noise seeded by the frame's index: any frame
  // renders the same whatever was rendered before it.
  cv::Mat work, noise(frame.size(), CV_16SC3);
  frame.convertTo(work, CV_16SC3, p.gain, p.offset);
  cv::RNG rng(static_cast<uint64_t>(s.seed) * 1000003u + static_cast<uint64_t>(i) + 1);
  rng.fill(noise, cv::RNG::NORMAL, 0, s.noise);
  work += noise;
  work.convertTo(frame, CV_8UC3);
  return frame;
}

}  // namespace

Result<Sequence> generate_sequence(const SyntheticScript& script, const std::string& data_dir) {
  auto built = build_scene(script, data_dir);
  if (!built.ok()) return built.status();
  std::shared_ptr<const Scene> scene = std::move(built).value();
  Sequence sequence;
  sequence.name = script.name;
  sequence.frame_size = script.frame_size;
  const cv::Size2d base = target_base_size(script);
  for (const FramePlan& p : scene->plans) {
    const cv::Size2d size(base.width * p.scale, base.height * p.scale);
    sequence.truth.push_back(truth_box(p.center, size));
    sequence.visible.push_back(target_visible(p, size, script.frame_size));
  }
  sequence.frame = [scene](int i) -> Result<cv::Mat> {
    if (i < 0 || static_cast<std::size_t>(i) >= scene->plans.size()) return no_such_frame(i, scene->plans.size());
    return render_frame(*scene, i);
  };
  return sequence;
}

Result<cv::Mat> target_appearance(const SyntheticScript& script, const std::string& data_dir) {
  const Result<cv::Mat> target = crop_of(data_dir + "/" + script.target_image, script.target_crop, script.target_image);
  if (!target.ok()) return target.status();
  const cv::Size2d base = target_base_size(script);
  cv::Mat out;
  cv::resize(*target, out,
             cv::Size(static_cast<int>(std::lround(base.width)), static_cast<int>(std::lround(base.height))), 0, 0,
             cv::INTER_AREA);
  return out;
}

Result<std::vector<Sequence>> generate_sequences(const std::string& data_dir,
                                                 const std::vector<SyntheticScript>& scripts) {
  std::vector<Sequence> sequences;
  for (const SyntheticScript& script : scripts) {
    auto sequence = generate_sequence(script, data_dir);
    if (!sequence.ok()) return sequence.status();
    sequences.push_back(std::move(sequence).value());
  }
  return sequences;
}

// ---------------------------------------------------------------- scripts

namespace {

// The objects the targets are cut from (rectangles found by eye).
const cv::Rect kOrange(35, 50, 430, 440);      // orange.jpg
const cv::Rect kApple(40, 5, 425, 490);        // apple.jpg
const cv::Rect kButterfly(10, 80, 475, 230);   // butterfly.jpg
const cv::Rect kFish(35, 15, 215, 175);        // HappyFish.jpg
const cv::Rect kBox(0, 0, 324, 223);           // box.png
const cv::Rect kFace(204, 58, 62, 64);         // messi5.jpg
const cv::Rect kSquirrel(140, 100, 210, 250);  // squirrel_cls.jpg
const cv::Rect kDog(60, 40, 360, 340);         // chicky_512.png
const cv::Rect kWhale(196, 84, 126, 104);      // rubberwhale1.png
const cv::Rect kSweet(348, 50, 60, 60);        // smarties.png

SyntheticScript make_script(std::string name, std::string background, std::string target, cv::Rect crop,
                            uint32_t seed) {
  SyntheticScript s;
  s.name = std::move(name);
  s.background = std::move(background);
  s.target_image = std::move(target);
  s.target_crop = crop;
  s.occluder_image = "baboon.jpg";
  s.seed = seed;
  return s;
}

}  // namespace

std::vector<SyntheticScript> standard_scripts() {
  std::vector<SyntheticScript> all;
  {  // A shaky hand: fast jitter and the motion blur it brings.
    SyntheticScript s = make_script("shake_blur", "building.jpg", "orange.jpg", kOrange, 11);
    s.target_side = 56, s.wander = 0.35, s.pan = 60, s.shake = 6, s.shake_period = 7, s.blur = 1.2;
    all.push_back(s);
  }
  {  // The target approaching and receding: 0.5x to 2x.
    SyntheticScript s = make_script("scale", "aero1.jpg", "butterfly.jpg", kButterfly, 12);
    s.target_side = 70, s.wander = 0.25, s.pan = 30, s.scale_min = 0.5, s.scale_max = 2.0;
    all.push_back(s);
  }
  {  // In-plane rotation up to 80 degrees, some scale change.
    SyntheticScript s = make_script("rotation", "home.jpg", "HappyFish.jpg", kFish, 13);
    s.target_side = 64, s.rotation_deg = 80, s.scale_min = 0.8, s.scale_max = 1.25, s.shake = 2;
    all.push_back(s);
  }
  {  // Lighting: the scene darkens to 40 % and brightens to 160 %, with offsets.
    SyntheticScript s = make_script("lighting", "board.jpg", "box.png", kBox, 14);
    s.target_side = 70, s.light = 0.6, s.pan = 50, s.shake = 2;
    all.push_back(s);
  }
  {  // Occluders: one partial, two hiding the face completely for a while.
    SyntheticScript s = make_script("occlusion", "graf1.png", "messi5.jpg", kFace, 15);
    s.target_side = 56, s.wander = 0.25;
    s.occlusions = {{50, 90, 0.45, 1.2}, {130, 190, 0, 1.8}, {230, 280, 0, 1.8}};
    all.push_back(s);
  }
  {  // A look-alike circling the target on a plain table.
    SyntheticScript s = make_script("distractor", "stuff.jpg", "apple.jpg", kApple, 16);
    s.target_side = 56, s.wander = 0.3, s.distractor = true;
    all.push_back(s);
  }
  {  // The camera looks away twice; the target leaves the view and comes back.
    SyntheticScript s = make_script("out_of_view", "starry_night.jpg", "squirrel_cls.jpg", kSquirrel, 17);
    s.target_side = 64, s.wander = 0.2, s.shake = 2;
    s.excursions = {{60, 75}, {190, 65}};
    all.push_back(s);
  }
  {  // Everything a little, on a background of similar colours.
    SyntheticScript s = make_script("mixed", "fruits.jpg", "orange.jpg", kOrange, 18);
    s.target_side = 60, s.scale_min = 0.7, s.scale_max = 1.4, s.rotation_deg = 30, s.shake = 3, s.blur = 0.8;
    s.light = 0.3, s.occlusions = {{150, 200, 0, 2.0}};
    all.push_back(s);
  }
  {  // VGA: scale, rotation, blur, lighting, a partial occluder, a look-alike, a look away.
    SyntheticScript s = make_script("mixed_640", "leuvenA.jpg", "butterfly.jpg", kButterfly, 19);
    s.frame_size = {640, 480}, s.frames = 320, s.target_side = 120, s.scale_min = 0.6, s.scale_max = 1.6;
    s.rotation_deg = 25, s.shake = 4, s.blur = 0.8, s.light = 0.4, s.pan = 80, s.distractor = true;
    s.occlusions = {{100, 150, 0.4, 1.3}}, s.excursions = {{200, 70}};
    all.push_back(s);
  }
  {  // VGA, fast: quick wandering and panning, a full occlusion, a look-alike, a look away.
    SyntheticScript s = make_script("fast_640", "aero3.jpg", "messi5.jpg", kFace, 20);
    s.frame_size = {640, 480}, s.target_side = 110, s.wander = 0.5, s.wander_period = 70, s.pan = 120;
    s.shake = 5, s.blur = 1.0, s.distractor = true;
    s.occlusions = {{90, 150, 0, 1.8}}, s.excursions = {{200, 60}};
    all.push_back(s);
  }
  return all;
}

std::vector<SyntheticScript> holdout_scripts() {
  // Each standard script's motions, lights, occluders and look-alike, with
  // another target over another background and another seed.
  struct Swap {
    const char* background;
    const char* target;
    cv::Rect crop;
  };
  static const std::array<Swap, 10> swaps{{{"aloeL.jpg", "chicky_512.png", kDog},
                                           {"leuvenB.jpg", "rubberwhale1.png", kWhale},
                                           {"graf3.png", "squirrel_cls.jpg", kSquirrel},
                                           {"blox.jpg", "butterfly.jpg", kButterfly},
                                           {"basketball1.png", "smarties.png", kSweet},
                                           {"box_in_scene.png", "HappyFish.jpg", kFish},
                                           {"ela_original.jpg", "orange.jpg", kOrange},
                                           {"smarties.png", "chicky_512.png", kDog},
                                           {"aloeL.jpg", "rubberwhale1.png", kWhale},
                                           {"rubberwhale2.png", "apple.jpg", kApple}}};
  std::vector<SyntheticScript> all = standard_scripts();
  for (std::size_t i = 0; i < all.size() && i < swaps.size(); ++i) {
    SyntheticScript& s = all[i];
    s.name = "holdout_" + s.name;
    s.background = swaps[i].background;
    s.target_image = swaps[i].target;
    s.target_crop = swaps[i].crop;
    s.seed += 100;
  }
  return all;
}

std::vector<SyntheticScript> fresh_scripts(int set) {
  // The targets, and photographs to put them over (opencv-doc's; the
  // occluder's baboon is none of them).
  struct Picture {
    const char* file;
    cv::Rect crop;
  };
  static const std::array<Picture, 10> targets{{{"orange.jpg", kOrange},
                                                {"apple.jpg", kApple},
                                                {"butterfly.jpg", kButterfly},
                                                {"HappyFish.jpg", kFish},
                                                {"box.png", kBox},
                                                {"messi5.jpg", kFace},
                                                {"squirrel_cls.jpg", kSquirrel},
                                                {"chicky_512.png", kDog},
                                                {"rubberwhale1.png", kWhale},
                                                {"smarties.png", kSweet}}};
  static const std::array<const char*, 24> backgrounds{
      {"building.jpg",     "aero1.jpg",       "aero3.jpg",        "home.jpg",         "board.jpg",
       "graf1.png",        "graf3.png",       "stuff.jpg",        "starry_night.jpg", "fruits.jpg",
       "leuvenA.jpg",      "leuvenB.jpg",     "aloeL.jpg",        "ela_original.jpg", "smarties.png",
       "rubberwhale2.png", "cards.png",       "pca_test1.jpg",    "left.jpg",         "licenseplate_motion.jpg",
       "blox.jpg",         "basketball1.png", "box_in_scene.png", "text_motion.jpg"}};
  // mt19937's numbers are the same everywhere (std::shuffle's use of them is not).
  std::mt19937 random(0x5eed0000u + static_cast<uint32_t>(set));
  const auto pick = [&](std::size_t n) { return static_cast<std::size_t>(random() % n); };
  std::vector<SyntheticScript> all = standard_scripts();
  for (SyntheticScript& s : all) {
    const Picture& target = targets[pick(targets.size())];
    std::string background;
    do background = backgrounds[pick(backgrounds.size())];
    while (background == target.file);
    s.name = "fresh" + std::to_string(set) + "_" + s.name;
    s.background = background;
    s.target_image = target.file;
    s.target_crop = target.crop;
    s.seed += 1000u * static_cast<uint32_t>(set);
  }
  return all;
}

// ---------------------------------------------------------------- scoring

cv::Rect2d perturbed_first_box(const cv::Rect2d& truth, int run) {
  if (run == 0) return truth;
  static constexpr double kShifts[][3] = {{0.3, -0.2, 0.15},  {-0.6, 0.4, -0.3}, {0.9, 0.6, 0.45},
                                          {-1.2, -0.8, -0.6}, {1.5, -1.0, 0.75}, {-0.4, 1.2, 0.2}};
  const auto& d = kShifts[static_cast<std::size_t>(run - 1) % std::size(kShifts)];
  return {truth.x + d[0], truth.y + d[1], truth.width + d[2], truth.height - d[2]};
}

double iou(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double overlap = (a & b).area();
  const double join = a.area() + b.area() - overlap;
  return join > 0 ? overlap / join : 0.0;
}

double center_error(const cv::Rect2d& a, const cv::Rect2d& b) {
  return std::hypot(a.x + a.width / 2 - (b.x + b.width / 2), a.y + a.height / 2 - (b.y + b.height / 2));
}

namespace {

// After each reappearance: frames until the tracker claims tracking again
// with IoU >= 0.3, searched while the target stays visible.
void score_reacquisition(const std::vector<cv::Rect2d>& truth, const std::vector<bool>& visible,
                         const std::vector<TrackedFrame>& track, TrackScore& score) {
  const std::size_t n = truth.size();
  for (std::size_t i = 1; i < n; ++i) {
    if (!visible[i] || visible[i - 1]) continue;
    ++score.reappearances;
    bool found = false;
    for (std::size_t j = i; j < n && visible[j]; ++j) {
      if (track[j].tracking && iou(track[j].box, truth[j]) >= 0.3) {
        score.max_reacquire_delay = std::max(score.max_reacquire_delay, static_cast<int>(j - i));
        found = true;
        break;
      }
    }
    if (!found) ++score.reacquire_misses;
  }
}

}  // namespace

Result<TrackScore> score_track(const std::vector<cv::Rect2d>& truth, const std::vector<bool>& visible,
                               const std::vector<TrackedFrame>& track) {
  if (truth.size() != visible.size() || truth.size() != track.size())
    return Status::error("score_track: truth, visibility and track differ in length");
  TrackScore score;
  std::vector<double> overlaps;
  double error_sum = 0;
  int precise = 0, invisible = 0, honest = 0;
  for (std::size_t i = 1; i < truth.size(); ++i) {
    if (!track[i].tracking) ++score.frames_lost;
    if (!visible[i]) {
      ++invisible;
      if (!track[i].tracking) ++honest;
      continue;
    }
    const double error = center_error(track[i].box, truth[i]);
    error_sum += error;
    if (error <= 20) ++precise;
    overlaps.push_back(iou(track[i].box, truth[i]));
    if (track[i].tracking && overlaps.back() <= 0) ++score.claimed_off_target;
  }
  score.ms_per_frame = frame_times(track).mean;
  if (invisible > 0) score.honest_lost = honest / double(invisible);
  score.scored_frames = static_cast<int>(overlaps.size());
  if (!overlaps.empty()) {
    const double n = static_cast<double>(overlaps.size());
    score.mean_center_error = error_sum / n;
    score.precision20 = precise / n;
    // OTB's success plot: thresholds 0:0.05:1, success = IoU strictly above
    // (so a perfect track scores 20/21). k / 20.0 is the nearest double to each.
    for (int k = 0; k <= 20; ++k) {
      const double threshold = k / 20.0;
      const double share = static_cast<double>(std::count_if(overlaps.begin(), overlaps.end(),
                                                             [&](double o) { return o > threshold; })) /
                           n;
      score.success_auc += share / 21;
      if (k == 10) score.success50 = share;
    }
  }
  score_reacquisition(truth, visible, track, score);
  return score;
}

uint64_t frame_hash(const cv::Mat& frame) {
  uint64_t hash = 1469598103934665603ull;
  for (int y = 0; y < frame.rows; ++y) {
    const uint8_t* row = frame.ptr<uint8_t>(y);
    for (std::size_t x = 0; x < frame.cols * frame.elemSize(); ++x) hash = (hash ^ row[x]) * 1099511628211ull;
  }
  return hash;
}

std::vector<int> jump_frames(const std::vector<TrackedFrame>& track) {
  std::vector<int> jumps;
  for (std::size_t i = 1; i < track.size(); ++i) {
    const cv::Rect2d& now = track[i].box;
    if (center_error(track[i - 1].box, now) > 0.75 * std::max(now.width, now.height))
      jumps.push_back(static_cast<int>(i));
  }
  return jumps;
}

WitnessScore witness_score(const std::vector<TrackedFrame>& track) {
  WitnessScore score;
  if (track.size() < 2) return score;
  int claimed = 0;
  for (std::size_t i = 1; i < track.size(); ++i) claimed += track[i].tracking;
  score.jumps = static_cast<int>(jump_frames(track).size());
  score.frames = static_cast<int>(track.size()) - 1;
  score.claimed = static_cast<double>(claimed) / score.frames;
  score.ms_per_frame = frame_times(track).mean;
  return score;
}

FrameTimes frame_times(const std::vector<TrackedFrame>& track) {
  FrameTimes times;
  if (track.size() < 2) return times;
  std::vector<double> ms;
  ms.reserve(track.size() - 1);
  double untracked = 0;
  for (std::size_t i = 1; i < track.size(); ++i) {
    ms.push_back(track[i].ms);
    if (!track[i].tracking) untracked += track[i].ms, ++times.untracked_frames;
  }
  const std::size_t n = ms.size();
  times.mean = std::accumulate(ms.begin(), ms.end(), 0.0) / static_cast<double>(n);  // in frame order
  std::sort(ms.begin(), ms.end());
  const auto rank = [&](double share) {  // nearest rank: the ceil(share n)-th smallest
    return ms[static_cast<std::size_t>(std::max(1.0, std::ceil(share * static_cast<double>(n) - 1e-9))) - 1];
  };
  times.frames = static_cast<int>(n);
  times.median = n % 2 == 1 ? ms[n / 2] : (ms[n / 2 - 1] + ms[n / 2]) / 2;
  times.p99 = rank(0.99);
  times.max = ms.back();
  if (times.untracked_frames > 0) times.untracked_mean = untracked / times.untracked_frames;
  return times;
}

double agreement(const std::vector<TrackedFrame>& a, const std::vector<TrackedFrame>& b, double within) {
  if (a.size() != b.size() || a.size() < 2) return 0;
  int near = 0;
  for (std::size_t i = 1; i < a.size(); ++i) near += center_error(a[i].box, b[i].box) <= within;
  return static_cast<double>(near) / static_cast<double>(a.size() - 1);
}

std::vector<SyntheticScript> with_round_targets(std::vector<SyntheticScript> scripts) {
  for (SyntheticScript& s : scripts) {
    s.round = true;
    s.name += "@round";
  }
  return scripts;
}

std::vector<SyntheticScript> with_turning_targets(std::vector<SyntheticScript> scripts, double degrees) {
  for (SyntheticScript& s : scripts) {
    s.turn_deg = degrees;
    s.name += "@turn" + std::to_string(static_cast<int>(std::lround(degrees)));
  }
  return scripts;
}

}  // namespace saccade::bench
