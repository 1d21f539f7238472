#include "fovea_params.hpp"

namespace saccade::fovea {

namespace {
// The box tracker's (BoxTrackerConfig), named box_*.
void bind_box_params(ParamBinder<ControllerConfig>& b);
void bind_box_limit_params(ParamBinder<ControllerConfig>& b);
}  // namespace

void bind_fovea_params(ParamBinder<ControllerConfig>& b) {
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
      .field("track_label",
             "attend: when a 'target' with this label (a classifier's) names the tracked place, stop "
             "visiting and keep tracking it",
             &C::track_label)
      .field("predict", "place the fovea where the target will be (constant velocity)", &C::predict)
      .field("margin", {0, 10000}, "gaze request when the fovea's edge is this close to the frame's, pixels",
             &C::border_margin)
      .field("gaze_repeat", {1, 1000000}, "frames before an unanswered gaze request is repeated", &C::gaze_repeat)
      .field("focal", {0, 1e6}, "focal length in pixels for gaze directions (0: from hfov)", &C::focal_px)
      .field("hfov", {1, 179}, "horizontal field of view, degrees (when focal is 0)", &C::hfov_deg);
  bind_box_params(b);
}

namespace {

void bind_box_params(ParamBinder<ControllerConfig>& b) {
  using C = ControllerConfig;
  using B = BoxTrackerConfig;
  b.field("box_learning_rate", {0, 1}, "box tracking: model <- (1-a) model + a frame, on confident frames", &C::box,
          &B::learning_rate)
      .field("box_tracking_psr", {0, 1000}, "box tracking: peak-to-sidelobe ratio from which the target is tracked",
             &C::box, &B::tracking_psr)
      .field("box_lost_psr", {0, 1000}, "box tracking: below this peak-to-sidelobe ratio the peak is not trusted",
             &C::box, &B::lost_psr)
      .field("box_lost_frames", {1, 100000}, "box tracking: untrusted frames in a row before the target is lost",
             &C::box, &B::lost_frames)
      .field("box_redetect_psr", {0, 1000},
             "box tracking: peak-to-sidelobe ratio a re-detection must reach (twice, at one place)", &C::box,
             &B::redetect_psr)
      .field("box_redetect_near", {0, 1000},
             "box tracking: within this many times the target's larger side of where it was last tracked, "
             "and of its colour, a re-detection need only reach box_redetect_near_psr (0: nowhere)",
             &C::box, &B::redetect_near)
      .field("box_redetect_near_psr", {0, 1000},
             "box tracking: peak-to-sidelobe ratio a re-detection near where the target was last tracked, "
             "of its colour, must reach (twice, at one place)",
             &C::box, &B::redetect_near_psr)
      .field("box_near_shared_tones", {0, 1},
             "box tracking: a target without colours (a monochrome camera's) found near where it was last tracked "
             "under box_redetect_psr, at box_redetect_near_psr or more, must share at least this much of its tones, as "
             "a target with colours must be of its colour (0: it must reach box_redetect_psr); and in a monochrome "
             "camera's frames a lower peak it has held becomes its usual one only on a frame sharing this much (0: "
             "not asked; docs/tracking.md)",
             &C::box, &B::near_shared_tones)
      .field("box_redetect_margin", {0, 1000},
             "box tracking: while the target is unsure but its peak is still trusted where it sits, a "
             "re-detection elsewhere must reach this many times that peak or be nearer the target's colour "
             "(0: not asked)",
             &C::box, &B::redetect_margin)
      .field("box_redetect_margin_frames", {0, 100000},
             "box tracking: unsure frames during which box_redetect_margin is asked (longer while the peak "
             "where the target sits still reaches box_redetect_psr)",
             &C::box, &B::redetect_margin_frames)
      .field("box_color_change", {0, 1},
             "box tracking: how far the target's chromaticity may move before a sure peak is doubted (as well "
             "as four times its usual deviation; 1: colour never doubts)",
             &C::box, &B::min_chroma_change)
      .field("box_min_shared_colors", {0, 1},
             "box tracking: while the target's colour is checked, a re-detection, also a sure one, must share "
             "at least this much of the target's chromaticity histogram: a look-alike of another tint is "
             "refused, a target partly hidden is not (0: not asked; docs/tracking.md)",
             &C::box, &B::min_shared_colors)
      .field("box_min_shared_tones", {0, 1},
             "box tracking: a re-detection, also a sure one, must share at least this much of the target's "
             "histogram of gray relative to its mean gray (its tones): background or a look-alike of other "
             "contrast is refused, in a monochrome camera's frames too (0: not asked; docs/tracking.md)",
             &C::box, &B::min_shared_tones)
      .field("box_follow_lost_colors", {0, 1},
             "box tracking: lost, the local look moves to a peak near where the target was lost that shares this "
             "much of the target's colours (a target without colours: box_min_shared_tones of its tones), and looks "
             "there at other sizes too (0: it stays where the target was lost; docs/tracking.md)",
             &C::box, &B::follow_lost_colors)
      .field("box_color_proposals", {0, 16},
             "box tracking: lost, or unsure on a sure peak of another colour (a look-alike), places per size the "
             "whole-frame search proposes by the target's look and colour together, besides those by its look alone "
             "(while its colour is checked; 0: none; docs/tracking.md)",
             &C::box, &B::color_proposals)
      .field("box_balance_colors",
             "box tracking: follow the camera's white balance from frame to frame (how every surface's red and "
             "blue change against green) and read every colour with those changes undone: a white balance "
             "drifting, or the light's colour changing, then moves no colour the tracker learnt (false: the "
             "frames' colours as they come; docs/tracking.md)",
             &C::box, &B::balance_colors)
      .field("box_scale_turn_min", {0, 360},
             "box tracking: degrees the target must have turned before the scale filter sees it turned as the "
             "patch does (upright under it; docs/tracking.md)",
             &C::box, &B::scale_turn_min);
  bind_box_limit_params(b);
}

// Where and at what size a target not tracked may be found again.
void bind_box_limit_params(ParamBinder<ControllerConfig>& b) {
  using C = ControllerConfig;
  using B = BoxTrackerConfig;
  b.field("box_max_size_change", {0, 10},
          "box tracking: a re-detection's size may differ from the size the target was last tracked at by "
          "this share per frame since (0: any of the sizes searched; docs/tracking.md)",
          &C::box, &B::max_size_change)
      .field("box_rescale_frames", {0, 100000},
             "box tracking: for this many frames from a re-detection elsewhere than where the tracker sat (its own "
             "frame counted), frames too unsure to learn from still measure the target's size (the "
             "re-detection's is the search's nearest; 0 and 1: tracked frames only; docs/tracking.md)",
             &C::box, &B::rescale_frames)
      .field("box_look_size_frames", {0, 100000},
             "box tracking: for this many frames from a re-detection elsewhere than where the tracker sat, and "
             "from each size this gives, a tracked frame on which the scale filter finds no size better than the "
             "others (box_flat_scale) looks with the position's filter at box_look_size_step times the target's "
             "size and 1 / that, and a peak higher there gives the target that size (0: never; docs/tracking.md)",
             &C::box, &B::look_size_frames)
      .field("box_flat_scale", {0, 1},
             "box tracking: the scale filter's answer counts as flat when it is its middle scale and its response "
             "two scales either side is this share of its top or more (box_look_size_frames)",
             &C::box, &B::flat_scale)
      .field("box_look_size_step", {1, 4},
             "box tracking: the sizes box_look_size_frames looks at, times and divided by the target's", &C::box,
             &B::look_size_step)
      .field("box_reentry_speed", {0, 100},
             "box tracking: a target whose centre left the frame comes back across that border: a re-detection "
             "must lie within the target's size of it, plus how far the camera turned back since, plus this many "
             "times the target's size per frame since (0: not asked; docs/tracking.md)",
             &C::box, &B::reentry_speed)
      .field("box_reach_speed", {0, 100},
             "box tracking: while the target is not tracked, a re-detection elsewhere than where the tracker sits "
             "must lie within the target's size of where it was last tracked (moved as the camera's measured and "
             "told moves moved the image), plus this many times its size per frame since, unless it peaks nearly "
             "as high as the target's tracked frames usually do (0: not asked; docs/tracking.md)",
             &C::box, &B::reach_speed)
      .field("box_resize_ratio", {0, 100},
             "box tracking: while the target is unsure, a look near where the tracker sits at a larger size whose "
             "peak is this many times the one at the target's size (and reaches the re-detection's bar, of the "
             "target's colours and tones) gives the target that size: it came nearer (0: never; a ratio under 1 "
             "counts as 1; docs/tracking.md)",
             &C::box, &B::resize_ratio);
}

}  // namespace

}  // namespace saccade::fovea
