#include <charconv>
#include <cmath>
#include <optional>
#include <sstream>
#include <vector>

#include <opencv2/imgcodecs.hpp>

#include "controller.hpp"
#include "fovea_params.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::fovea;

// "B,G,R" -> colour; "" -> none; anything else is an error.
Result<std::optional<cv::Vec3d>> parse_color(const std::string& text) {
  if (text.empty()) return std::optional<cv::Vec3d>();
  cv::Vec3d c;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &c[0], &c[1], &c[2], &tail) != 3)
    return Status::error("color: expected B,G,R (three numbers), got '" + text + "'");
  return std::optional<cv::Vec3d>(c);
}

struct InitBox {
  cv::Rect2d box;
  int64_t frame = -1;  // the frame id to start on; -1: the first frame
  std::string text;    // as written, for errors
};

// "x,y,w,h" or "x,y,w,h,frame" -> a box; "" -> none. An error when the text
// is not a box a tracker can follow.
Result<std::optional<InitBox>> parse_init(const std::string& text, double min_side) {
  if (text.empty()) return std::optional<InitBox>();
  std::vector<double> v;
  bool numbers = true;
  std::stringstream items(text);
  for (std::string item; std::getline(items, item, ',');) {
    const auto first = item.find_first_not_of(' '), last = item.find_last_not_of(' ');
    double value = 0;
    const char* end = item.data() + (last == std::string::npos ? 0 : last + 1);
    const auto [ptr, ec] = std::from_chars(item.data() + (first == std::string::npos ? 0 : first), end, value);
    numbers = numbers && ec == std::errc() && ptr == end && first != std::string::npos;
    v.push_back(value);
  }
  if (!numbers || (v.size() != 4 && v.size() != 5))
    return Status::error("expected x,y,w,h or x,y,w,h,frame (numbers), got '" + text + "'");
  if (!(v[2] >= min_side && v[3] >= min_side))
    return Status::error("box '" + text + "': width and height must be at least " +
                         std::to_string(static_cast<int>(min_side)) + " pixels");
  const double frame = v.size() == 5 ? v[4] : -1;
  if (v.size() == 5 && (frame < 0 || frame != std::floor(frame)))
    return Status::error("box '" + text + "': the frame must be a whole number >= 0");
  return std::optional<InitBox>(InitBox{{v[0], v[1], v[2], v[3]}, static_cast<int64_t>(frame), text});
}

class FoveaNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Retina> kRetina{"retina", "the retina (gray or BGR) the decision is made on"};
  static constexpr OptionalIn<FeatureMaps> kMotion{
      "motion", "the motion node's maps of the same retina (uses dI); sync with 'retina'"};
  static constexpr SideIn<Region> kTarget{"target",
                                          "a place to look at from outside (a classifier's detection, a click)"};
  static constexpr SideIn<Region> kHead{
      "head", "the head turned: 'center' is the pixel (before the move) now at the image centre"};
  static constexpr Out<Region> kFovea{"fovea", "fovea centre for the next frame; label = state"};
  static constexpr Out<FoveaState> kState{"state",
                                          "state, target, score, attention shifts, gaze requests; carries the retina"};
  static constexpr Out<GazeRequest> kGaze{"gaze", "emitted when the tracked fovea reaches the border margin"};

  static Contract contract() {
    return Contract(
               "The moving fovea: bottom-up attention (saliency from centre-surround contrast across levels, "
               "edges, motion, colour; inhibition of return) or a top-down target, template tracking with "
               "prediction, and gaze requests when the fovea reaches the frame's border. Feed 'fovea' back to "
               "the retina's fovea input through a delayed edge.")
        .ports(kRetina, kMotion, kTarget, kHead, kFovea, kState, kGaze)
        .params(&bind_fovea_params)
        .param_string("template", "", "image file of the target to look for (top-down); empty: lock on saliency")
        .param_string("init", "",
                      "the target as a box x,y,w,h in source pixels (optionally x,y,w,h,frame: on that frame id), "
                      "followed by the box tracker; empty: none (a 'target' with a size also gives one)")
        .param_string("color", "", "wanted colour B,G,R (BGR retina); empty: none");
  }

  Status open(OpenContext& ctx) override {
    ControllerConfig c = ctx.config(&bind_fovea_params);
    Result<std::optional<cv::Vec3d>> color = parse_color(ctx.params().get_string("color"));
    if (!color.ok()) return color.status();
    c.saliency.color = *color;
    const cv::Size t = c.tracker.template_size, w = c.tracker.search_size;
    if (t.width < 3 || t.height < 3) return Status::error("template_size must be at least 3x3");
    if (w.area() > 0 && (t.width > w.width || t.height > w.height))
      return Status::error("template_size " + std::to_string(t.width) + "x" + std::to_string(t.height) +
                           " is larger than search_size " + std::to_string(w.width) + "x" + std::to_string(w.height) +
                           ": the template could never be found");
    Result<std::optional<InitBox>> init = parse_init(ctx.params().get_string("init"), c.box.min_target);
    if (!init.ok()) return Status::error("init: " + init.error());
    init_ = std::move(init).value();
    track_mode_ = c.mode == FoveaMode::kTrack;
    bad_targets_ = &ctx.counter("bad_targets");
    controller_ = std::make_unique<FoveaController>(c);
    if (const std::string path = ctx.params().get_string("template"); !path.empty()) {
      cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
      if (image.empty()) return Status::error("template: cannot read image '" + path + "'");
      if (!controller_->set_template(image)) return Status::error("template '" + path + "' is flat: nothing to match");
    }
    return {};
  }

  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(kRetina);
    if (retina->levels.empty()) return Status::error("empty retina");
    auto motion = ctx.get(kMotion);
    const std::vector<cv::Mat>* dI = motion ? motion->find("dI") : nullptr;
    if (auto head = ctx.get(kHead); head && head != last_head_) {
      last_head_ = head;
      controller_->head_moved(head->center, retina->source_size);
    }
    if (Status s = start_box(*retina); !s.ok()) return s;
    auto target = ctx.get(kTarget);
    if (take_target_box(ctx, *retina, target)) target.reset();
    const Decision d = controller_->step(*retina, dI, target.get());

    auto fovea = ctx.make(kFovea);
    fovea->center = d.next;
    fovea->size = cv::Size2d(retina->geometry.back().region.size());
    fovea->score = d.score;
    fovea->camera_id = retina->camera_id;
    fovea->label = to_string(d.state);
    ctx.emit(kFovea, std::move(fovea));

    if (d.gaze) {
      auto gaze = ctx.make(kGaze);
      gaze->pixel = d.gaze->pixel;
      gaze->direction = d.gaze->direction;
      gaze->image_size = d.gaze->image_size;
      gaze->camera_id = d.gaze->camera_id;
      gaze->focal_px = d.gaze->focal_px;
      gaze->reason = d.gaze->reason;
      ctx.emit(kGaze, std::move(gaze));
    }

    auto state = ctx.make(kState);
    state->state = d.state;
    state->fovea = cv::Point2d(retina->fovea);
    state->next = d.next;
    state->target = Box::around(d.target, d.target_size);
    state->target_valid = d.target_valid;
    state->confidence = d.confidence;
    state->score = d.score;
    state->attention_shift = d.attention_shift;
    state->gaze_request = d.gaze.has_value();
    state->attention_shifts = controller_->attention_shifts();
    state->gaze_requests = controller_->gaze_requests();
    state->frames_lost = controller_->frames_lost();
    state->camera_id = retina->camera_id;
    state->retina = retina;
    ctx.emit(kState, std::move(state));
    return {};
  }

 private:
  // A new `target` with a size (a detection, a click) is a box to follow from
  // this frame; true when it was one (taken, or refused: logged and counted).
  bool take_target_box(const ProcessContext& ctx, const Retina& retina, const std::shared_ptr<const Region>& target) {
    if (!target || target == last_target_ || !track_mode_ || target->size.area() <= 0) return false;
    last_target_ = target;
    const cv::Rect2d box = Box::around(target->center, target->size).rect();
    const Status taken =
        retina.source ? controller_->track_box(retina.source->mat, box) : Status::error("no frame with the retina");
    if (!taken.ok()) {
      log().warn("{}: target ignored: {}", ctx.node_name(), taken.message());
      bad_targets_->fetch_add(1, std::memory_order_relaxed);
    }
    return true;
  }

  // The `init` box, until the frame it names arrives.
  Status start_box(const Retina& retina) {
    if (!init_ || (init_->frame >= 0 && retina.frame_id < init_->frame)) return {};
    const InitBox box = *init_;
    init_.reset();
    if (!retina.source) return Status::error("init: the retina carries no frame to learn the target from");
    if (Status taken = controller_->track_box(retina.source->mat, box.box); !taken.ok())
      return Status::error("init " + box.text + ": " + taken.message());
    return {};
  }

  std::unique_ptr<FoveaController> controller_;
  std::optional<InitBox> init_;
  std::shared_ptr<const Region> last_target_;
  bool track_mode_ = true;
  std::atomic<uint64_t>* bad_targets_ = nullptr;
  std::shared_ptr<const Region> last_head_;  // held, so the pool cannot reuse it for the next move
};

}  // namespace

SACCADE_PLUGIN("fovea", FoveaNode)
