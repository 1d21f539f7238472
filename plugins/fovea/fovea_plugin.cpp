#include <opencv2/imgcodecs.hpp>

#include "controller.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;
using namespace saccade::fovea;

// "B,G,R" -> colour; "" -> none.
std::optional<cv::Vec3d> parse_color(const std::string& text, std::string* error) {
  if (text.empty()) return std::nullopt;
  cv::Vec3d c;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%lf,%lf,%lf%c", &c[0], &c[1], &c[2], &tail) != 3) {
    *error = "color: expected B,G,R (three numbers), got '" + text + "'";
    return std::nullopt;
  }
  return c;
}

class FoveaNode final : public Node {
 public:
  static constexpr const char* kName = "";
  static constexpr In<Retina> kRetina{"retina", "the retina (gray or BGR) the decision is made on"};
  static constexpr OptionalIn<FeatureMaps> kMotion{"motion", "the motion node's maps of the same retina (uses dI); sync with 'retina'"};
  static constexpr SideIn<Region> kTarget{"target", "a place to look at from outside (a classifier's detection, a click)"};
  static constexpr SideIn<Region> kHead{"head", "the head turned: 'center' is the pixel (before the move) now at the image centre"};
  static constexpr Out<Region> kFovea{"fovea", "fovea centre for the next frame; label = state"};
  static constexpr Out<FoveaState> kState{"state", "state, target, score, attention shifts, gaze requests; carries the retina"};
  static constexpr Out<GazeRequest> kGaze{"gaze", "emitted when the tracked fovea reaches the border margin"};

  static void bind(ParamBinder<ControllerConfig>& b) {
    using C = ControllerConfig;
    using T = TrackerConfig;
    using S = SaliencyConfig;
    b.field("mode", {{"track", FoveaMode::kTrack}, {"attend", FoveaMode::kAttend}},
            "track: lock on one target and follow it; attend: visit salient places in turn", &C::mode)
        .field("dwell", {1, 100000}, "attend: frames on one place before attention moves on", &C::dwell_frames)
        .field("coast", {0, 1000}, "lost: frames following the predicted path before searching", &C::coast_frames)
        .field("lost_frames", {1, 1000000}, "lost: frames before the target is given up (not with a template)",
               &C::lost_frames)
        .field("verify_attempts", {1, 1000}, "failed looks near one place before it is inhibited", &C::verify_attempts)
        .field("template_size", "tracking template, pixels", &C::tracker, &T::template_size)
        .field("search_size", "window around the fovea searched by the tracker (0x0: the fovea level)", &C::tracker,
               &T::search_size)
        .field("min_score", {-1, 1}, "tracking: a template match (NCC) below this is lost", &C::tracker, &T::min_score)
        .field("update_rate", {0, 1}, "tracking: template <- (1-a) template + a match", &C::tracker, &T::update_rate)
        .field("ior_radius", {1, 100000}, "inhibition of return: radius, source pixels", &C::ior_radius)
        .field("ior_frames", {1, 1000000}, "inhibition of return: frames until a place is free again", &C::ior_frames)
        .field("min_saliency", {0, 10}, "places less salient than this are not worth a look", &C::min_saliency)
        .field("lock_on", {{"moving", true}, {"salient", false}},
               "track with the motion input: lock on (and look for a lost target) only where something moves",
               &C::lock_on_motion)
        .field("level_boost", {0, 1},
               "saliency normalisation: 0 over all levels together, 1 each level alone (outer levels count more)",
               &C::saliency, &S::level_boost)
        .field("contrast_weight", {0, 100}, "saliency: centre-surround contrast across levels", &C::saliency,
               &S::contrast_weight)
        .field("edge_weight", {0, 100}, "saliency: gradient magnitude", &C::saliency, &S::edge_weight)
        .field("motion_weight", {0, 100}, "saliency: |dI| (with the motion input)", &C::saliency, &S::motion_weight)
        .field("color_weight", {0, 100}, "saliency: similarity to 'color' (BGR retina)", &C::saliency, &S::color_weight)
        .field("color_tolerance", {1, 500}, "colour distance where similarity falls to exp(-1/2)", &C::saliency,
               &S::color_tolerance)
        .field("track_label", "attend: when a 'target' with this label (a classifier's) names the tracked place, stop "
               "visiting and keep tracking it", &C::track_label)
        .field("predict", "place the fovea where the target will be (constant velocity)", &C::predict)
        .field("margin", {0, 10000}, "gaze request when the fovea's edge is this close to the frame's, pixels",
               &C::border_margin)
        .field("gaze_repeat", {1, 1000000}, "frames before an unanswered gaze request is repeated", &C::gaze_repeat)
        .field("focal", {0, 1e6}, "focal length in pixels for gaze directions (0: from hfov)", &C::focal_px)
        .field("hfov", {1, 179}, "horizontal field of view, degrees (when focal is 0)", &C::hfov_deg);
  }

  static Contract contract() {
    return Contract("The moving fovea: bottom-up attention (saliency from centre-surround contrast across levels, "
                    "edges, motion, colour; inhibition of return) or a top-down target, template tracking with "
                    "prediction, and gaze requests when the fovea reaches the frame's border. Feed 'fovea' back to "
                    "the retina's fovea input through a delayed edge.")
        .ports(kRetina, kMotion, kTarget, kHead, kFovea, kState, kGaze)
        .params(&bind)
        .param_string("template", "", "image file of the target to look for (top-down); empty: lock on saliency")
        .param_string("color", "", "wanted colour B,G,R (BGR retina); empty: none");
  }

  Status open(OpenContext& ctx) override {
    ControllerConfig c = ctx.config(&bind);
    std::string error;
    c.saliency.color = parse_color(ctx.params().get_string("color"), &error);
    if (!error.empty()) return Status::error(error);
    if (c.tracker.template_size.width < 3 || c.tracker.template_size.height < 3)
      return Status::error("template_size must be at least 3x3");
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
    auto target = ctx.get(kTarget);
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
    state->target = d.target;
    state->target_valid = d.target_valid;
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
  std::unique_ptr<FoveaController> controller_;
  std::shared_ptr<const Region> last_head_;  // held, so the pool cannot reuse it for the next move
};

}  // namespace

SACCADE_PLUGIN("fovea", FoveaNode)
