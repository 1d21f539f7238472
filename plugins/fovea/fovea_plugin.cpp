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
  static Contract contract() {
    return Contract("The moving fovea: bottom-up attention (saliency from centre-surround contrast across levels, "
                    "edges, motion, colour; inhibition of return) or a top-down target, template tracking with "
                    "prediction, and gaze requests when the fovea reaches the frame's border. Feed 'fovea' back to "
                    "the retina's fovea input through a delayed edge.")
        .input<Retina>("retina", "the retina (gray or BGR) the decision is made on")
        .optional_input<FeatureMaps>("motion", "the motion node's maps of the same retina (uses dI); sync with 'retina'")
        .side_input<Region>("target", "a place to look at from outside (a classifier's detection, a click)")
        .side_input<Region>("head", "the head turned: 'center' is the pixel (before the move) now at the image centre")
        .output<Region>("fovea", "fovea centre for the next frame; label = state")
        .output<FoveaState>("state", "state, target, score, attention shifts, gaze requests; carries the retina")
        .output<GazeRequest>("gaze", "emitted when the tracked fovea reaches the border margin")
        .param_enum("mode", "track", {"track", "attend"},
                    "track: lock on one target and follow it; attend: visit salient places in turn")
        .param_int("dwell", 20, 1, 100000, "attend: frames on one place before attention moves on")
        .param_int("coast", 2, 0, 1000, "lost: frames following the predicted path before searching")
        .param_int("lost_frames", 30, 1, 1000000, "lost: frames before the target is given up (not with a template)")
        .param_int("verify_attempts", 3, 1, 1000, "failed looks near one place before it is inhibited")
        .param_size("template_size", {12, 12}, "tracking template, pixels")
        .param_size("search_size", {40, 32}, "window around the fovea searched by the tracker (0x0: the fovea level)")
        .param_double("min_score", 0.6, -1.0, 1.0, "tracking: a template match (NCC) below this is lost")
        .param_double("update_rate", 0.0, 0.0, 1.0, "tracking: template <- (1-a) template + a match")
        .param_string("template", "", "image file of the target to look for (top-down); empty: lock on saliency")
        .param_double("ior_radius", 40.0, 1.0, 100000.0, "inhibition of return: radius, source pixels")
        .param_int("ior_frames", 90, 1, 1000000, "inhibition of return: frames until a place is free again")
        .param_double("min_saliency", 0.05, 0.0, 10.0, "places less salient than this are not worth a look")
        .param_enum("lock_on", "moving", {"moving", "salient"},
                    "track with the motion input: lock on (and look for a lost target) only where something moves")
        .param_double("level_boost", 0.0, 0.0, 1.0,
                      "saliency normalisation: 0 over all levels together, 1 each level alone (outer levels count more)")
        .param_double("contrast_weight", 1.0, 0.0, 100.0, "saliency: centre-surround contrast across levels")
        .param_double("edge_weight", 1.0, 0.0, 100.0, "saliency: gradient magnitude")
        .param_double("motion_weight", 2.0, 0.0, 100.0, "saliency: |dI| (with the motion input)")
        .param_double("color_weight", 1.0, 0.0, 100.0, "saliency: similarity to 'color' (BGR retina)")
        .param_string("color", "", "wanted colour B,G,R (BGR retina); empty: none")
        .param_double("color_tolerance", 40.0, 1.0, 500.0, "colour distance where similarity falls to exp(-1/2)")
        .param_string("track_label", "",
                      "attend: when a 'target' with this label (a classifier's) names the tracked place, stop visiting "
                      "and keep tracking it")
        .param_bool("predict", true, "place the fovea where the target will be (constant velocity)")
        .param_double("margin", 16.0, 0.0, 10000.0, "gaze request when the fovea's edge is this close to the frame's, pixels")
        .param_int("gaze_repeat", 30, 1, 1000000, "frames before an unanswered gaze request is repeated")
        .param_double("focal", 0.0, 0.0, 1e6, "focal length in pixels for gaze directions (0: from hfov)")
        .param_double("hfov", 60.0, 1.0, 179.0, "horizontal field of view, degrees (when focal is 0)");
  }

  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    retina_ = ctx.input<Retina>("retina");
    motion_ = ctx.input<FeatureMaps>("motion");
    target_ = ctx.input<Region>("target");
    head_ = ctx.input<Region>("head");
    fovea_out_ = ctx.output<Region>("fovea");
    state_out_ = ctx.output<FoveaState>("state");
    gaze_out_ = ctx.output<GazeRequest>("gaze");
    ControllerConfig c;
    c.mode = p.get_string("mode") == "attend" ? FoveaMode::kAttend : FoveaMode::kTrack;
    c.dwell_frames = static_cast<int>(p.get_int("dwell"));
    c.coast_frames = static_cast<int>(p.get_int("coast"));
    c.lost_frames = static_cast<int>(p.get_int("lost_frames"));
    c.verify_attempts = static_cast<int>(p.get_int("verify_attempts"));
    c.tracker.template_size = p.get_size("template_size");
    c.tracker.search_size = p.get_size("search_size");
    c.tracker.min_score = p.get_double("min_score");
    c.tracker.update_rate = p.get_double("update_rate");
    c.ior_radius = p.get_double("ior_radius");
    c.ior_frames = static_cast<int>(p.get_int("ior_frames"));
    c.min_saliency = p.get_double("min_saliency");
    c.lock_on_motion = p.get_string("lock_on") == "moving";
    c.saliency.level_boost = p.get_double("level_boost");
    c.saliency.contrast_weight = p.get_double("contrast_weight");
    c.saliency.edge_weight = p.get_double("edge_weight");
    c.saliency.motion_weight = p.get_double("motion_weight");
    c.saliency.color_weight = p.get_double("color_weight");
    std::string error;
    c.saliency.color = parse_color(p.get_string("color"), &error);
    if (!error.empty()) return Status::error(error);
    c.saliency.color_tolerance = p.get_double("color_tolerance");
    c.predict = p.get_bool("predict");
    c.track_label = p.get_string("track_label");
    c.border_margin = p.get_double("margin");
    c.gaze_repeat = static_cast<int>(p.get_int("gaze_repeat"));
    c.focal_px = p.get_double("focal");
    c.hfov_deg = p.get_double("hfov");
    if (c.tracker.template_size.width < 3 || c.tracker.template_size.height < 3)
      return Status::error("template_size must be at least 3x3");
    controller_ = std::make_unique<FoveaController>(c);
    if (const std::string path = p.get_string("template"); !path.empty()) {
      cv::Mat image = cv::imread(path, cv::IMREAD_GRAYSCALE);
      if (image.empty()) return Status::error("template: cannot read image '" + path + "'");
      if (!controller_->set_template(image)) return Status::error("template '" + path + "' is flat: nothing to match");
    }
    return {};
  }

  Status process(ProcessContext& ctx) override {
    auto retina = ctx.get(retina_);
    if (retina->levels.empty()) return Status::error("empty retina");
    auto motion = ctx.get(motion_);
    const std::vector<cv::Mat>* dI = motion ? motion->find("dI") : nullptr;
    if (auto head = ctx.get(head_); head && head != last_head_) {
      last_head_ = head;
      controller_->head_moved(head->center, retina->source_size);
    }
    auto target = ctx.get(target_);
    const Decision d = controller_->step(*retina, dI, target.get());

    auto fovea = ctx.make(fovea_out_);
    fovea->center = d.next;
    fovea->size = cv::Size2d(retina->geometry.back().region.size());
    fovea->score = d.score;
    fovea->camera_id = retina->camera_id;
    fovea->label = to_string(d.state);
    ctx.emit(fovea_out_, std::move(fovea));

    if (d.gaze) {
      auto gaze = ctx.make(gaze_out_);
      gaze->pixel = d.gaze->pixel;
      gaze->direction = d.gaze->direction;
      gaze->image_size = d.gaze->image_size;
      gaze->camera_id = d.gaze->camera_id;
      gaze->focal_px = d.gaze->focal_px;
      gaze->reason = d.gaze->reason;
      ctx.emit(gaze_out_, std::move(gaze));
    }

    auto state = ctx.make(state_out_);
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
    ctx.emit(state_out_, std::move(state));
    return {};
  }

 private:
  InputHandle<Retina> retina_;
  InputHandle<FeatureMaps> motion_;
  InputHandle<Region> target_, head_;
  OutputHandle<Region> fovea_out_;
  OutputHandle<FoveaState> state_out_;
  OutputHandle<GazeRequest> gaze_out_;
  std::unique_ptr<FoveaController> controller_;
  std::shared_ptr<const Region> last_head_;  // held, so the pool cannot reuse it for the next move
};

}  // namespace

SACCADE_PLUGIN("fovea", FoveaNode)
