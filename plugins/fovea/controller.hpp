#pragma once
// The moving fovea: chooses where to look (bottom-up saliency with inhibition
// of return, or a top-down target) and keeps looking there (template
// tracking with a constant-velocity prediction, because the fovea it decides
// is used for the next frame). When the fovea reaches the frame's border it
// asks the head to turn.
#include <optional>
#include <string>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"
#include "box_tracker.hpp"
#include "saliency.hpp"
#include "tracker.hpp"

namespace saccade::fovea {

enum class FoveaMode {
  kAttend,  // visit salient places in turn, `dwell_frames` each (following them while there)
  kTrack,   // lock on the most salient place (or the given template) and follow it
};

struct ControllerConfig {
  FoveaMode mode = FoveaMode::kTrack;
  SaliencyConfig saliency;
  TrackerConfig tracker;
  double ior_radius = 40.0;  // source pixels
  int ior_frames = 90;
  int dwell_frames = 20;       // attend: frames on one place before attention moves on
  int coast_frames = 2;        // lost: frames the fovea follows the predicted path before searching
  int lost_frames = 30;        // lost: frames before the target is given up (never, with a given template)
  int verify_attempts = 3;     // failed looks near one place before that place is inhibited
  double min_saliency = 0.05;  // a place less salient than this is not worth a look
  // track: lock on (and search for a lost target) only where something moves,
  // when motion is given; a still scene then gives no target.
  bool lock_on_motion = true;
  bool predict = true;          // place the next fovea where the target will be, not where it was
  double velocity_gain = 0.7;   // weight of the newest velocity measurement
  double border_margin = 16.0;  // pixels between the fovea's edge and the frame's edge that trigger a gaze request
  int gaze_repeat = 30;         // frames after which an unanswered gaze request is repeated
  // attend: a top-down target (a classifier's) with this label, naming the
  // place being tracked, ends the visiting: the fovea keeps tracking it.
  std::string track_label;
  double focal_px = 0.0;  // 0: from hfov_deg
  double hfov_deg = 60.0;
  BoxTrackerConfig box;  // a target given as a box (track_box)
};

struct Decision {
  FoveaState::State state = FoveaState::State::kSearching;
  cv::Point2d next;            // fovea centre for the next frame
  cv::Point2d target{-1, -1};  // the target in this frame
  cv::Size2d target_size;      // and its size, source pixels
  bool target_valid = false;
  double confidence = 0.0;  // the tracker's (box: peak-to-sidelobe ratio; template: NCC)
  double score = 0.0;
  bool attention_shift = false;
  bool reacquired = false;          // the target was found again after being lost
  std::optional<GazeRequest> gaze;  // pixel, direction, image size, reason
};

class FoveaController {
 public:
  explicit FoveaController(ControllerConfig config);
  // A top-down template: the controller searches for it and never drops it.
  bool set_template(const cv::Mat& image);
  // From now on follows the target inside `box` (source pixels) of `frame`
  // with the box tracker: honest states (tracking, uncertain, lost) and
  // re-detection when lost. An error says why not (the controller is then
  // unchanged).
  Status track_box(const cv::Mat& frame, cv::Rect2d box);
  bool tracking_box() const { return phase_ == Phase::kBox; }
  // One frame. `motion_dI`: the motion node's dI per level on this retina's
  // geometry (or nullptr); `top_down`: a place to look at given from outside
  // (a classifier's detection, a user's click), or nullptr.
  Decision step(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down);
  // The head turned so that `pixel` (in the image before the move) is now at
  // the image centre: the scene moved by centre - pixel; recentre on it.
  void head_moved(cv::Point2d pixel, cv::Size image);

  int64_t attention_shifts() const { return shifts_; }
  int64_t gaze_requests() const { return gaze_requests_; }
  int64_t frames_lost() const { return phase_ == Phase::kLost || phase_ == Phase::kBox ? frames_lost_ : 0; }
  const ControllerConfig& config() const { return config_; }

 private:
  enum class Phase { kSearch, kAcquire, kTrack, kLost, kBox };
  void look_at(cv::Point2d point, Decision& d);
  void track(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down, Decision& d);
  void reacquire(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down, Decision& d);
  void acquire(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down, Decision& d);
  void search(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down, Decision& d);
  // The one way into kTrack, from a match of the lost target or a new template cut at `at`.
  void start_tracking(cv::Point2d at, double score, Decision& d);
  void lost(const Retina& retina, const std::vector<cv::Mat>* motion_dI, const Region* top_down, Decision& d);
  void check_border(const Retina& retina, Decision& d);
  void follow_box(const Retina& retina, Decision& d);
  bool moving_only(const std::vector<cv::Mat>* motion_dI) const {
    return config_.mode == FoveaMode::kTrack && config_.lock_on_motion && motion_dI != nullptr;
  }

  ControllerConfig config_;
  Saliency saliency_;
  TemplateTracker tracker_;
  BoxTracker box_tracker_;
  bool box_learnt_ = false;  // the box tracker learnt on this frame: nothing to track yet
  InhibitionOfReturn ior_;
  Phase phase_ = Phase::kSearch;
  bool fixed_template_ = false;
  bool ever_locked_ = false;
  cv::Point2d target_{-1, -1}, velocity_, acquire_at_{-1, -1}, candidate_{-1, -1};
  bool acquire_refine_ = true;
  static constexpr int kAcquireLooks = 3;  // looks at a place cut by the fovea's edge before acquiring anyway
  int acquire_looks_ = 0;
  static constexpr int kCenteringFrames =
      8;  // frames after acquisition in which the point may move to the object's centre
  int centering_ = 0;
  std::optional<cv::Point2d> center_next_;
  int dwell_ = 0, attempts_ = 0;
  int64_t frames_lost_ = 0, shifts_ = 0, gaze_requests_ = 0;
  bool gaze_armed_ = true;
  int gaze_wait_ = 0;
  std::optional<cv::Point2d> recenter_shift_;
  int64_t last_top_down_ = -1;
  bool recognized_ = false;  // attend: the tracked place is what track_label names
};

}  // namespace saccade::fovea
