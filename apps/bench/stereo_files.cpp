#include "stereo_files.hpp"

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <utility>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "mosaic.hpp"
#include "stereo_truth.hpp"

namespace saccade::bench {
namespace {

namespace fs = std::filesystem;

// A positive number, the whole of `text`; 0 when it is not one.
double positive_number(const std::string& text) {
  if (text.empty()) return 0;
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  return errno == 0 && end == text.c_str() + text.size() && std::isfinite(v) && v > 0 ? v : 0;
}

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> out(1);
  for (const char c : text) {
    if (c == separator)
      out.emplace_back();
    else
      out.back() += c;
  }
  return out;
}

// The first of `names` that is a file in `dir`, or empty.
std::string first_file(const fs::path& dir, std::initializer_list<const char*> names) {
  for (const char* name : names)
    if (fs::is_regular_file(dir / name)) return (dir / name).string();
  return {};
}

std::string listed(std::initializer_list<const char*> names) {
  std::string out;
  for (const char* name : names) out += std::string(out.empty() ? "" : " or ") + name;
  return out;
}

// One year's layout: the names each of the three files may have.
struct Layout {
  const char* years;
  std::initializer_list<const char*> left, right, truth;
};

// The first layout whose three files `dir` holds, into `out`; false when
// none is whole, `missing` then naming what the first layout found in part
// lacks (a folder of one year may hold another's names too: the 2001 sets'
// nine views are im0..im8).
bool find_layout(const fs::path& dir, StereoPairFiles& out, std::string& years, std::string& missing) {
  static const Layout kLayouts[] = {
      {"2014, 2021", {"im0.png"}, {"im1.png"}, {"disp0.pfm", "disp0GT.pfm"}},
      {"2005, 2006", {"view1.png"}, {"view5.png"}, {"disp1.png"}},
      {"2001, 2003", {"im2.ppm", "im2.png"}, {"im6.ppm", "im6.png"}, {"disp2.pgm", "disp2.png"}},
  };
  for (const Layout& layout : kLayouts) {
    const std::string left = first_file(dir, layout.left), right = first_file(dir, layout.right),
                      truth = first_file(dir, layout.truth);
    if (!left.empty() && !right.empty() && !truth.empty()) {
      out.left = left, out.right = right, out.truth = truth;
      years = layout.years;
      return true;
    }
    if (missing.empty() && !(left.empty() && right.empty() && truth.empty())) {
      years = layout.years;
      missing = listed(left.empty() ? layout.left : right.empty() ? layout.right : layout.truth);
    }
  }
  return false;
}

// The scale of a 2005-2006 folder's truth from its images' width: the truth
// is the full size's disparity, so a half-size folder's is twice its own.
Result<double> scale_from_width(const StereoPairFiles& files) {
  const cv::Mat left = cv::imread(files.left, cv::IMREAD_GRAYSCALE);
  if (left.empty()) return Status::error(files.left + ": cannot be read as an image");
  return left.cols >= 1000 ? 1.0 : left.cols >= 600 ? 2.0 : 3.0;
}

Result<cv::Mat> read_image(const std::string& path, const cv::Mat* like, const std::string& like_path) {
  cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  if (image.empty()) return Status::error(path + ": cannot be read as an image");
  // Gray would keep a 16-bit image's top 8 bits: 12-bit data would come out
  // nearly black and score badly with no word said.
  if (image.depth() != CV_8U)
    return Status::error(path + ": not an 8-bit image; the matchers take 8 bits (convert it, scaled as it should be)");
  if (like != nullptr && image.size() != like->size())
    return Status::error(path + ": " + std::to_string(image.cols) + "x" + std::to_string(image.rows) + ", but " +
                         like_path + " is " + std::to_string(like->cols) + "x" + std::to_string(like->rows));
  return image;
}

Result<cv::Mat> read_truth(const StereoPairFiles& files, cv::Size size) {
  // A PFM by the snapshot's reader: OpenCV's divides by the header's scale,
  // whose size the stereo benchmarks' files do not mean as one.
  const bool pfm = fs::path(files.truth).extension() == ".pfm";
  const cv::Mat raw = pfm ? snapshot::read_pfm(files.truth) : cv::imread(files.truth, cv::IMREAD_UNCHANGED);
  if (raw.empty())
    return Status::error(files.truth +
                         (pfm ? ": cannot be read as a one-channel PFM (\"Pf\")" : ": cannot be read as an image"));
  if (raw.channels() != 1)
    return Status::error(files.truth + ": " + std::to_string(raw.channels()) + " channels; a disparity map has one");
  if (raw.size() != size)
    return Status::error(files.truth + ": " + std::to_string(raw.cols) + "x" + std::to_string(raw.rows) + ", but " +
                         files.left + " is " + std::to_string(size.width) + "x" + std::to_string(size.height));
  const bool is_float = raw.depth() == CV_32F || raw.depth() == CV_64F;
  if (!is_float && files.scale <= 0)
    return Status::error(files.truth +
                         ": an integer disparity map needs its scale (the value of one pixel of disparity: KITTI "
                         "256; Middlebury 2001 Tsukuba 16, Venus 8; 2003 Teddy and Cones 4)");
  const double scale = files.scale > 0 ? files.scale : 1.0;
  cv::Mat truth;
  raw.convertTo(truth, CV_32F, 1.0 / scale);
  for (int y = 0; y < truth.rows; ++y) {
    float* row = truth.ptr<float>(y);
    for (int x = 0; x < truth.cols; ++x) {
      // An integer map's 0 is "unknown"; a float one's infinities and NaNs.
      const bool unknown = is_float ? !std::isfinite(row[x]) || row[x] < 0 : row[x] <= 0;
      if (unknown) row[x] = -1;
    }
  }
  if (cv::countNonZero(truth >= 0) == 0) return Status::error(files.truth + ": no pixel of known disparity");
  // A disparity as wide as the image: a wrong scale, or a PFM of the other byte order.
  double largest = 0;
  cv::minMaxLoc(truth, nullptr, &largest);
  if (largest >= size.width)
    return Status::error(files.truth + ": a disparity of " + number_text(largest) + " px in an image " +
                         std::to_string(size.width) + " px wide (is its " +
                         (is_float ? "scale or byte order" : "scale " + number_text(scale)) + " right?)");
  return truth;
}

}  // namespace

Result<StereoPairFiles> parse_stereo_pair(const std::string& spec) {
  const std::vector<std::string> parts = split(spec, ',');
  if (parts.size() < 3 || parts.size() > 4)
    return Status::error("'" + spec + "': expected LEFT,RIGHT,TRUTH or LEFT,RIGHT,TRUTH,SCALE");
  StereoPairFiles files;
  files.left = parts[0], files.right = parts[1], files.truth = parts[2];
  for (const std::string* path : {&files.left, &files.right, &files.truth})
    if (path->empty()) return Status::error("'" + spec + "': an empty file name");
  if (parts.size() == 4 && (files.scale = positive_number(parts[3])) <= 0)
    return Status::error("'" + spec + "': the scale '" + parts[3] + "' is not a positive number");
  const fs::path left(files.left);
  const std::string folder = left.parent_path().filename().string();
  files.name = (folder.empty() ? "" : folder + "/") + left.stem().string();
  return files;
}

Result<StereoPairFiles> find_middlebury_pair(const std::string& spec) {
  std::string dir = spec;
  double scale = 0;
  // "DIR:SCALE", unless the whole is a folder (whose own name may hold ':').
  if (const std::size_t colon = spec.rfind(':'); !fs::is_directory(spec) && colon != std::string::npos) {
    dir = spec.substr(0, colon);
    const std::string given = spec.substr(colon + 1);
    if ((scale = positive_number(given)) <= 0)
      return Status::error(spec + ": the scale '" + given + "' is not a positive number");
  }
  if (!fs::is_directory(dir)) return Status::error(dir + ": no such folder");
  StereoPairFiles files;
  std::string years, missing;
  if (!find_layout(dir, files, years, missing)) {
    if (!missing.empty()) return Status::error(dir + ": a Middlebury " + years + " folder without " + missing);
    return Status::error(dir +
                         ": no Middlebury pair: looked for im0.png, im1.png, disp0.pfm (2014, 2021); view1.png, "
                         "view5.png, disp1.png (2005, 2006); im2, im6 (.ppm or .png), disp2 (.pgm or .png) (2001, "
                         "2003)");
  }
  // Named as the folder, also when given as "." or "Teddy/".
  const fs::path whole = fs::absolute(dir).lexically_normal();
  files.name = (whole.has_filename() ? whole : whole.parent_path()).filename().string();
  files.scale = scale;
  if (scale > 0 || years == std::string("2014, 2021")) return files;
  if (years == std::string("2001, 2003"))
    return Status::error(dir +
                         ": a Middlebury 2001 or 2003 truth's scale differs by scene: give it as DIR:SCALE (Teddy "
                         "and Cones 4; Venus, Sawtooth, Bull, Poster, Barn1, Barn2 8)");
  Result<double> inferred = scale_from_width(files);
  if (!inferred.ok()) return inferred.status();
  files.scale = *inferred;
  files.note = "the truth's scale taken as " + number_text(files.scale) +
               " from the images' width (Middlebury 2005-2006: full size 1, half 2, third 3); give DIR:SCALE if "
               "it is not";
  return files;
}

Result<StereoPairImages> read_stereo_pair(const StereoPairFiles& files) {
  StereoPairImages pair;
  Result<cv::Mat> left = read_image(files.left, nullptr, {});
  if (!left.ok()) return left.status();
  pair.left = *left;
  Result<cv::Mat> right = read_image(files.right, &pair.left, files.left);
  if (!right.ok()) return right.status();
  pair.right = *right;
  Result<cv::Mat> truth = read_truth(files, pair.left.size());
  if (!truth.ok()) return truth.status();
  pair.truth = *truth;
  return pair;
}

Status write_middlebury_pair(const std::string& dir, const StereoPairImages& pair) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) return Status::error(dir + ": cannot be made (" + ec.message() + ")");
  const fs::path d(dir);
  for (const auto& [name, image] : {std::pair{"im0.png", &pair.left}, std::pair{"im1.png", &pair.right}})
    if (!cv::imwrite((d / name).string(), *image)) return Status::error((d / name).string() + ": cannot be written");
  // (The snapshot's PFM: unknown as infinity, the bottom row first.)
  if (!snapshot::write_pfm((d / "disp0.pfm").string(), pair.truth))
    return Status::error((d / "disp0.pfm").string() + ": cannot be written");
  std::ofstream calib(d / "calib.txt");
  calib << "width=" << pair.left.cols << "\nheight=" << pair.left.rows << "\nndisp=" << disparities_over(pair.truth)
        << "\n";
  if (!calib) return Status::error((d / "calib.txt").string() + ": cannot be written");
  return {};
}

}  // namespace saccade::bench
