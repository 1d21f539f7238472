#include <cstdio>
#include <filesystem>

#include <opencv2/imgcodecs.hpp>

#include "mosaic.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::snapshot;

// The node's parameters.
struct SnapshotConfig {
  std::string dir = "out";
  std::string prefix;  // empty: the node's name
  int64_t every = 1;
  int64_t first = 0;
  int scale = 6;
  bool disparity_png16 = false;
};

class Snapshot final : public Node {
 public:
  static constexpr const char* kName = "";

  static void bind(ParamBinder<SnapshotConfig>& b) {
    using C = SnapshotConfig;
    b.field("dir", "folder for the PNGs (created)", &C::dir)
        .field("prefix", "file name prefix (default: the node's name)", &C::prefix)
        .field("every", {1, 1'000'000}, "write one frame in N", &C::every)
        .field("first", {0, 1'000'000'000}, "skip frames before this frame id", &C::first)
        .field("scale", {1, 32}, "enlargement of level images", &C::scale)
        .field("disparity_png16",
               "also write every disparity* map per level as a 16-bit PNG (value = round(disparity x 64) + 1, "
               "0 = invalid, up to 1023.98 px) and as a PFM beside it (32-bit floats, +infinity = invalid)",
               &C::disparity_png16);
  }

  static Contract contract() {
    return Contract(
               "Writes PNG mosaics every N frames: an Image as it is; a Retina as the frame with its level "
               "rectangles, the level strip and the foveated view; FeatureMaps as all of those plus one strip per "
               "feature.")
        .input<Message>("in", "Image, Retina, FeatureMaps or FoveaState (the fovea's track over the frame)")
        .params(&bind);
  }
  Status open(OpenContext& ctx) override {
    in_ = ctx.input<Message>("in");
    config_ = ctx.config(&bind);
    if (config_.prefix.empty()) config_.prefix = ctx.node_name();
    std::error_code ec;
    track_.reserve(kTrackLength);
    std::filesystem::create_directories(config_.dir, ec);
    if (ec) return Status::error("cannot create folder '" + config_.dir + "': " + ec.message());
    return {};
  }
  Status process(ProcessContext& ctx) override {
    auto msg = ctx.get(in_);
    auto fovea = std::dynamic_pointer_cast<const FoveaState>(msg);
    if (fovea) {
      // The track is remembered on every frame, drawn on the frames written.
      if (track_.size() == kTrackLength) track_.erase(track_.begin());
      track_.push_back(
          TrackPoint{fovea->fovea, fovea->target.center(), fovea->target_valid, fovea->state, fovea->gaze_request});
    }
    if (msg->frame_id < config_.first || (msg->frame_id - config_.first) % config_.every != 0) return {};
    if (fovea) return write("track", msg->frame_id, track_overlay(*fovea, track_));
    if (auto image = std::dynamic_pointer_cast<const Image>(msg))
      return write("frame", msg->frame_id, to_display(image->mat));
    const Retina* retina = nullptr;
    auto maps = std::dynamic_pointer_cast<const FeatureMaps>(msg);
    if (maps) retina = maps->retina.get();
    auto as_retina = std::dynamic_pointer_cast<const Retina>(msg);
    if (as_retina) retina = as_retina.get();
    if (retina == nullptr && !maps) return Status::error("cannot draw a " + std::string(msg->type_name()));
    if (retina != nullptr) {
      if (Status s = write("source", msg->frame_id, retina_overlay(*retina)); !s.ok()) return s;
      if (Status s = write("levels", msg->frame_id, level_strip(retina->levels, config_.scale, "retina")); !s.ok())
        return s;
      if (Status s = write("foveated", msg->frame_id, foveated_view(*retina)); !s.ok()) return s;
    }
    if (maps) {
      if (Status s = write("features", msg->frame_id, feature_grid(*maps, config_.scale)); !s.ok()) return s;
      for (std::size_t i = 0; i < maps->names.size(); ++i) {
        const cv::Mat strip = level_strip(maps->maps[i], config_.scale, maps->names[i]);
        if (Status s = write(maps->names[i], msg->frame_id, strip); !s.ok()) return s;
        if (!config_.disparity_png16 || maps->names[i].rfind("disparity", 0) != 0) continue;
        for (std::size_t k = 0; k < maps->maps[i].size(); ++k) {
          if (maps->maps[i][k].type() != CV_32F) continue;
          const std::string level = maps->names[i] + "_L" + std::to_string(k);
          if (Status s = write(level + "_16", msg->frame_id, disparity_png16(maps->maps[i][k])); !s.ok()) return s;
          if (Status s = write_float(level, msg->frame_id, maps->maps[i][k]); !s.ok()) return s;
        }
      }
    }
    return {};
  }

 private:
  Status write(const std::string& what, int64_t frame, const cv::Mat& image) {
    const std::string path = file_name(what, frame) + ".png";
    bool written = false;
    try {  // OpenCV throws for an image its PNG encoder cannot take
      written = !image.empty() && cv::imwrite(path, image);
    } catch (const cv::Exception& e) { return Status::error("cannot write " + path + ": " + e.what()); }
    if (!written) return Status::error("cannot write " + path);
    ++written_;
    return {};
  }
  Status write_float(const std::string& what, int64_t frame, const cv::Mat& disparity) {
    const std::string path = file_name(what, frame) + ".pfm";
    if (!write_pfm(path, disparity)) return Status::error("cannot write " + path);
    ++written_;
    return {};
  }
  std::string file_name(const std::string& what, int64_t frame) const {
    char name[64];
    std::snprintf(name, sizeof name, "_%06lld_", static_cast<long long>(frame));
    return config_.dir + "/" + config_.prefix + name + what;
  }
  static constexpr std::size_t kTrackLength = 300;
  InputHandle<Message> in_;
  std::vector<TrackPoint> track_;
  SnapshotConfig config_;
  int64_t written_ = 0;
};

}  // namespace

SACCADE_PLUGIN("snapshot", Snapshot)
