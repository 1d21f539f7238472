#include "controller.hpp"

#include <algorithm>
#include <cmath>

namespace saccade::fovea {

namespace {

double distance(cv::Point2d a, cv::Point2d b) { return std::hypot(a.x - b.x, a.y - b.y); }

}  // namespace

FoveaController::FoveaController(ControllerConfig config)
    : config_(std::move(config)),
      saliency_(config_.saliency),
      tracker_(config_.tracker),
      box_tracker_(config_.box),
      ior_(config_.ior_radius, config_.ior_frames) {}

bool FoveaController::set_template(const cv::Mat& image) {
  if (!tracker_.set_template(image)) return false;
  fixed_template_ = true;
  phase_ = Phase::kLost;
  frames_lost_ = 0;
  return true;
}

void FoveaController::head_moved(cv::Point2d pixel, cv::Size image) {
  const cv::Point2d shift = cv::Point2d(image.width / 2.0, image.height / 2.0) - pixel;
  target_ += shift;
  candidate_ += shift;
  acquire_at_ += shift;
  ior_.shift(shift);
  recenter_shift_ = shift;
  box_tracker_.camera_moved(shift);
  gaze_armed_ = true;
  gaze_wait_ = 0;
}

void FoveaController::look_at(cv::Point2d point, Decision& d) {
  d.next = point;
  d.attention_shift = true;
  ++shifts_;
}

Decision FoveaController::step(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down) {
  Decision d;
  d.next = cv::Point2d(retina.fovea);
  ior_.tick();
  if (gaze_wait_ > 0) --gaze_wait_;
  if (phase_ == Phase::kBox) {
    recenter_shift_.reset();  // the box tracker was told (camera_moved)
    follow_box(retina, d);
    check_border(retina, d);
    return d;
  }
  if (recenter_shift_) {
    // The frame was taken before the head's move was known: the target is
    // where it was, shifted with the scene. Put the fovea there; match again on
    // the next frame.
    recenter_shift_.reset();
    if (phase_ == Phase::kTrack) {
      d.state = FoveaState::State::kTracking;
      d.next = target_ + (config_.predict ? velocity_ : cv::Point2d());
      return d;
    }
  }
  switch (phase_) {
    case Phase::kTrack: track(retina, motion_dI, top_down, d); break;
    case Phase::kLost: reacquire(retina, motion_dI, top_down, d); break;
    case Phase::kAcquire: acquire(retina, motion_dI, top_down, d); break;
    case Phase::kSearch: search(retina, motion_dI, top_down, d); break;
    case Phase::kBox: break;
  }
  if (d.target_valid) {
    d.target_size = cv::Size2d(config_.tracker.template_size);
    d.confidence = d.score;
  }
  check_border(retina, d);
  return d;
}

void FoveaController::track(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down,
                            Decision& d) {
  const TemplateTracker::Match m = tracker_.match(retina);
  if (!m.found) {
    phase_ = Phase::kLost;
    frames_lost_ = 0;
    attempts_ = 0;
    candidate_ = target_;
    d.score = m.score;
    lost(retina, motion_dI, top_down, d);
    return;
  }
  const cv::Point2d measured = m.point - target_;
  velocity_ = dwell_ == 0 ? measured : config_.velocity_gain * measured + (1.0 - config_.velocity_gain) * velocity_;
  target_ = m.point;
  ++dwell_;
  if (centering_ > 0 && !fixed_template_) {
    // Just acquired, maybe on a part of the object: while the fovea
    // settles on it, move the tracked point to the object's centre.
    --centering_;
    saliency_.compute(retina, motion_dI);
    bool cut = false;
    const cv::Point2d center = saliency_.blob_center(static_cast<int>(retina.levels.size()) - 1, target_, 0.5, &cut);
    if (!cut) {
      // Cut the template again around the centre, so that it holds the
      // object rather than the background next to it.
      if (!tracker_.acquire(retina, center)) tracker_.move_point(center - target_);
      target_ = center;
      centering_ = 0;
    } else {
      center_next_ = center;  // bring the whole object into the fovea first
    }
  }
  d.state = FoveaState::State::kTracking;
  d.target = target_;
  d.target_valid = true;
  d.score = m.score;
  d.next = target_ + (config_.predict ? velocity_ : cv::Point2d());
  if (center_next_) {
    d.next = *center_next_ + (config_.predict ? velocity_ : cv::Point2d());
    center_next_.reset();
  }
  if (config_.mode == FoveaMode::kAttend && !config_.track_label.empty() && top_down != nullptr &&
      top_down->label == config_.track_label && distance(top_down->center, target_) < config_.ior_radius)
    recognized_ = true;
  if (config_.mode == FoveaMode::kAttend && dwell_ >= config_.dwell_frames && !recognized_) {
    // Seen long enough: inhibit it and let attention move on.
    ior_.add(target_);
    tracker_.reset();
    phase_ = Phase::kSearch;
    search(retina, motion_dI, top_down, d);
    d.target = target_;
    d.target_valid = true;
  }
}

void FoveaController::reacquire(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down,
                                Decision& d) {
  const TemplateTracker::Match m = tracker_.match(retina);
  if (!m.found) {
    lost(retina, motion_dI, top_down, d);
    return;
  }
  d.reacquired = ever_locked_;  // before start_tracking sets it: the first lock is no re-acquisition
  frames_lost_ = 0;
  start_tracking(m.point, m.score, d);
}

void FoveaController::acquire(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down,
                              Decision& d) {
  cv::Point2d at = acquire_at_;
  if (acquire_refine_) {
    // The place was chosen on a coarse level: look again, at full
    // resolution, for the most salient point of the fovea.
    saliency_.compute(retina, motion_dI);
    const cv::Size t = config_.tracker.template_size;
    const int inner = static_cast<int>(retina.levels.size()) - 1;
    const Candidate c = saliency_.peak_on_level(inner, t.width / 2, t.height / 2);
    bool cut = false;
    if (c.valid() && c.value > 0) at = saliency_.blob_center(inner, c.point, 0.5, &cut);
    if (cut && ++acquire_looks_ < kAcquireLooks) {
      // Part of the object is outside the fovea: centre on what is seen and
      // look again before cutting the template.
      acquire_at_ = at;
      d.next = at;
      return;
    }
  }
  if (tracker_.acquire(retina, at)) {
    centering_ = acquire_refine_ ? kCenteringFrames : 0;
    start_tracking(at, 1.0, d);
  } else {
    ior_.add(acquire_at_);
    phase_ = Phase::kSearch;
    search(retina, motion_dI, top_down, d);
  }
}

void FoveaController::start_tracking(cv::Point2d at, double score, Decision& d) {
  phase_ = Phase::kTrack;
  ever_locked_ = true;
  target_ = at;
  velocity_ = {};  // no motion measured yet: the first match gives it (dwell_ == 0)
  dwell_ = 0;
  d.state = FoveaState::State::kTracking;
  d.target = at;
  d.target_valid = true;
  d.score = score;
  d.next = at;
}

void FoveaController::search(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down,
                             Decision& d) {
  d.state = FoveaState::State::kSearching;
  if (top_down != nullptr && top_down->frame_id != last_top_down_) {
    last_top_down_ = top_down->frame_id;
    acquire_at_ = top_down->center;
    acquire_refine_ = false;
    acquire_looks_ = 0;
    phase_ = Phase::kAcquire;
    look_at(top_down->center, d);
    return;
  }
  saliency_.compute(retina, motion_dI);
  const Candidate c = saliency_.peak(ior_, moving_only(motion_dI));
  if (!c.valid() || c.value < config_.min_saliency) return;
  d.score = c.value;
  acquire_at_ = c.point;
  acquire_refine_ = true;
  acquire_looks_ = 0;
  phase_ = Phase::kAcquire;
  look_at(c.point, d);
}

void FoveaController::lost(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down,
                           Decision& d) {
  ++frames_lost_;
  d.state = ever_locked_ ? FoveaState::State::kLost : FoveaState::State::kSearching;
  if (ever_locked_ && frames_lost_ <= config_.coast_frames) {
    // Out of sight for a moment (a fast move, an occlusion): follow the
    // predicted path before looking elsewhere.
    d.next = target_ + velocity_ * static_cast<double>(frames_lost_ + 1);
    return;
  }
  if (!fixed_template_ && frames_lost_ > config_.lost_frames) {
    recognized_ = false;
    tracker_.reset();
    ior_.add(target_);
    phase_ = Phase::kSearch;
    search(retina, motion_dI, top_down, d);
    return;
  }
  if (top_down != nullptr && top_down->frame_id != last_top_down_) {
    last_top_down_ = top_down->frame_id;
    candidate_ = top_down->center;
    attempts_ = 1;
    look_at(top_down->center, d);
    return;
  }
  // Re-acquisition: go where the scene is most salient (motion weighs most)
  // and match the template there on the next frame. A place that fails
  // `verify_attempts` times in a row is inhibited, so the search moves on.
  saliency_.compute(retina, motion_dI);
  const bool moving = moving_only(motion_dI);
  Candidate c = saliency_.peak(ior_, moving);
  if (c.valid() && distance(c.point, candidate_) < config_.ior_radius) {
    if (++attempts_ >= config_.verify_attempts) {
      ior_.add(c.point);
      attempts_ = 0;
      c = saliency_.peak(ior_, moving);
    }
  } else {
    attempts_ = 1;
  }
  if (!c.valid() || c.value < config_.min_saliency) return;
  d.score = c.value;
  const bool elsewhere = distance(c.point, candidate_) >= config_.ior_radius;
  candidate_ = c.point;
  d.next = c.point;
  if (elsewhere) {
    d.attention_shift = true;
    ++shifts_;
  }
}

Status FoveaController::track_box(const cv::Mat& frame, cv::Rect2d box) {
  if (Status learnt = box_tracker_.init(frame, box); !learnt.ok()) return learnt;
  phase_ = Phase::kBox;
  frames_lost_ = 0;
  ever_locked_ = true;
  box_learnt_ = true;
  return {};
}

void FoveaController::follow_box(const Retina& retina, Decision& d) {
  if (!retina.source) {  // the retina node always attaches its frame; another producer may not
    d.state = FoveaState::State::kLost;
    return;
  }
  // The frame the box was given on was learnt from, not tracked in.
  const TrackEstimate e = box_learnt_ ? box_tracker_.last() : box_tracker_.update(retina.source->mat);
  box_learnt_ = false;
  const cv::Point2d center(e.box.x + e.box.width / 2, e.box.y + e.box.height / 2);
  d.target = center;
  d.target_size = e.box.size();
  d.confidence = d.score = e.confidence;
  d.target_valid = e.state != TrackState::kLost;
  switch (e.state) {
    case TrackState::kTracking: d.state = FoveaState::State::kTracking; break;
    case TrackState::kUncertain: d.state = FoveaState::State::kUncertain; break;
    case TrackState::kLost: d.state = FoveaState::State::kLost; break;
  }
  frames_lost_ = e.state == TrackState::kLost ? frames_lost_ + 1 : 0;
  if (d.target_valid) d.next = center;  // lost: the fovea stays while the tracker sweeps the frame
  target_ = center;
}

void FoveaController::check_border(const Retina& retina, Decision& d) {
  if (retina.geometry.empty()) return;
  const cv::Size frame = retina.source_size;
  const cv::Size fovea = retina.geometry.back().region.size();
  const double m = config_.border_margin;
  const double hw = fovea.width / 2.0, hh = fovea.height / 2.0;
  const cv::Point2d p = d.next;
  const bool near = p.x - hw < m || p.x + hw > frame.width - m || p.y - hh < m || p.y + hh > frame.height - m;
  if (!near) {
    gaze_armed_ = true;
    return;
  }
  if (d.state != FoveaState::State::kTracking) return;
  if (!gaze_armed_ && gaze_wait_ > 0) return;
  gaze_armed_ = false;
  gaze_wait_ = config_.gaze_repeat;
  ++gaze_requests_;
  const double f =
      config_.focal_px > 0 ? config_.focal_px : (frame.width / 2.0) / std::tan(config_.hfov_deg * M_PI / 360.0);
  GazeRequest g;
  g.pixel = d.target_valid ? d.target : d.next;
  const cv::Vec3d ray((g.pixel.x - frame.width / 2.0) / f, (g.pixel.y - frame.height / 2.0) / f, 1.0);
  g.direction = ray / cv::norm(ray);
  g.focal_px = f;
  g.image_size = frame;
  g.camera_id = retina.camera_id;
  g.reason = "border";
  d.gaze = std::move(g);
}

}  // namespace saccade::fovea
