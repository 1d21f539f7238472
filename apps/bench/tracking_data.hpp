#pragma once
// Sequences for the tracking benchmark and the measures it scores them with.
//
// Sequences come from the two standard layouts (OTB and VOT folders) or from
// a generator that renders real images (Debian's opencv-doc sample data) into
// moving-camera sequences with exact ground truth: pans and hand-held shake,
// scale changes, in-plane rotation, motion blur, lighting ramps, occluders, a
// look-alike distractor and the target leaving the view.
//
// Box convention everywhere: cv::Rect2d in pixel-edge coordinates (a box
// covering pixels 0..w-1 is x = 0, width = w), as OTB and VOT files give them.
#include <cmath>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/status.hpp"

namespace saccade::bench {

struct Sequence {
  std::string name;
  cv::Size frame_size;
  std::vector<cv::Rect2d> truth;  // per frame; may lie partly (or, when invisible, wholly) outside the frame
  std::vector<bool> visible;      // false where the target is fully occluded or out of view
  // Frame i (0-based) as 8-bit BGR, read or rendered on demand: a few
  // sequences of hundreds of frames at 640x480 would not fit in memory. An
  // error names a frame file that can no longer be read, or an index outside
  // the sequence.
  std::function<Result<cv::Mat>(int)> frame;
  std::string note;  // what a reader assumed in pairing the truth with the images, for the user to check; or empty
  bool truth_known = true;  // false: only frame 0's box is known (a video without truth: witness measures)
  int size() const { return static_cast<int>(truth.size()); }
};

// Keeps the first `frames` frames (all when frames <= 0 or more than there are).
void truncate(Sequence& sequence, int frames);

// The sequence as a camera of another frame rate or resolution would see it:
// every `every`th frame (1: each), each resized by `scale` (area averaging
// when it shrinks, bilinear when it grows), the truth with it; the name gains
// "@every<N>" and "@scale<F>" for what changed. An error names a value out of
// range (every 1..100, scale 0.1..8) or a frame smaller than 2x2 once scaled.
Status resample(Sequence& sequence, int every, double scale);

// The sequence as a monochrome camera sees it: each frame's gray (OpenCV's
// weights), in all three channels, as a gray image file reads (OTB's gray
// sequences do); the name gains "@gray".
void make_gray(Sequence& sequence);

// The sequence as a camera that compresses its frames sees it: each frame
// encoded as a JPEG of `quality` (1-100, OpenCV's encoder, 4:2:0 chroma) and
// decoded, as the frames of a recorded video or a network camera are; the name
// gains "@jpeg<quality>". An error names a quality out of range.
Status make_jpeg(Sequence& sequence, int quality);

// The sequence as a camera whose white balance drifts sees it: frame i's red
// channel times 1 + amount sin(2 pi i / kWhiteBalancePeriod) and its blue
// times 1 - that sine's amount, green unchanged (saturated to 0..255), as an
// automatic white balance warms and cools the whole image when the view or
// the light changes; the first frame is unchanged, the truth too (and a
// frame of other than three channels: a monochrome camera has no white
// balance). The name gains "@wb<amount>". An error names an amount outside 0.01..0.5.
inline constexpr double kWhiteBalancePeriod = 150;
Status make_white_balance(Sequence& sequence, double amount);

// --- Readers. Each returns the sequence, or an error naming the file (and
// line) at fault.

// OTB layout: DIR/img/0001.jpg ... and DIR/groundtruth_rect.txt, one x,y,w,h
// row per frame (separated by commas, tabs or spaces; CRLF allowed). Rows of
// NaN or with a zero width or height mark frames without the target.
// The images are taken in the order of their numbers, whatever their digits
// and first number (OTB's Board has five digits, its BlurCar1 starts at
// 0247), and must follow each other without a gap. The rows belong to the
// images from number `first_image` on (0: from the first image), fewer rows
// than images leaving the rest out (OTB's Football1, Freeman3, Freeman4 and
// Diving from the first; its David from 300: Sequence::note then says which
// images were taken). `truth_name` is the ground truth's file in DIR.
Result<Sequence> read_otb(const std::string& dir, int first_image = 0,
                          const std::string& truth_name = "groundtruth_rect.txt");

// An OTB folder as the tracking benchmark's --otb names it: "DIR", or
// "DIR:FIRST" with FIRST the image number its truth starts at (OTB's David is
// "David:300"); a folder whose own name ends in ':' and digits is taken whole.
struct OtbFolder {
  std::string dir;
  int first_image = 0;  // 0: the first image
};
Result<OtbFolder> parse_otb_folder(const std::string& spec);

// A video and the box to follow in it, without truth, as the tracking
// benchmark's --video names it: "FILE:FIRST:x,y,w,h" or
// "FILE:FIRST:x,y,w,h:COUNT" (FIRST the box's frame, 0-based; COUNT the
// frames to follow, to the video's end when left out); the path may hold ':'.
struct VideoTarget {
  std::string path;
  int first_frame = 0;
  cv::Rect2d box;
  int frames = 0;  // 0: to the video's end
};
Result<VideoTarget> parse_video_target(const std::string& spec);

// The video's frames from first_frame on (frame 0 the box's), read in order
// (a frame asked for at or before the last one read opens the video again),
// named "<file stem>@<first>+<x>+<y>+<w>+<h>", truth_known false; a note when
// the video ends before `frames`. An error names the video that cannot be
// opened, has no frame after first_frame, or whose frames the box misses.
Result<Sequence> read_video(const VideoTarget& target);

// Every target of an OTB folder: groundtruth_rect.txt's, or else one
// sequence per groundtruth_rect.N.txt (N from 1), named as OTB names them
// (Jogging.1, Jogging.2).
Result<std::vector<Sequence>> read_otb_targets(const std::string& dir, int first_image = 0);

// Writes a sequence with truth in the OTB layout into `dir` (made if
// missing), for other trackers' tools: img/0001.png ... (PNG, lossless, so
// read_otb gives back every pixel; as many digits as the count needs, at
// least 4) and groundtruth_rect.txt, one x,y,w,h row per frame, each number
// as few digits as give it back exactly, NaN,NaN,NaN,NaN where the target is
// hidden or out of view. An error names the file that could not be written,
// or the sequence without truth (a video's).
Status write_otb(const Sequence& sequence, const std::string& dir);

// VOT layout: DIR/00000001.jpg ... (or DIR/color/00000001.jpg ..., or as
// LaSOT DIR/img/00000001.jpg ...; GOT-10k's folders read too) and
// DIR/groundtruth.txt, one row per frame of 4 numbers (x,y,w,h) or 8 (the
// polygon x1,y1,...,x4,y4, scored as its axis-aligned bounding box); NaN rows
// or empty boxes mark frames without the target. The images as read_otb
// takes them, the rows from the first image on.
Result<Sequence> read_vot(const std::string& dir);

// One ground-truth row: its box, and whether the target is in the frame
// (false for NaN or empty rows).
struct TruthRow {
  cv::Rect2d box;
  bool visible = true;
};
// The row, or an error prefixed with `where` ("file:line").
Result<TruthRow> parse_truth_row(const std::string& row, const std::string& where);

// --- The generator.

// An occluder crossing the target horizontally, from just left of it to just
// right of it, over frames [start, end).
struct Occlusion {
  int start = 0;
  int end = 0;
  double offset_y = 0;  // the occluder's centre below the target's, in target heights (0: through the middle)
  double size = 1.6;    // the occluder's side, in the target's larger side (> 1.3 with offset 0 hides it fully)
};

// The camera looks away from the target over frames [start, start + length):
// it pans away in 20 frames, stays, and pans back in 20 frames.
struct Excursion {
  int start = 0;
  int length = 80;
};

// What one generated sequence shows and which difficulties it stresses.
struct SyntheticScript {
  std::string name;
  cv::Size frame_size{320, 240};
  int frames = 300;
  uint32_t seed = 1;
  std::string background;    // image file in the data folder, viewed by the moving camera
  std::string target_image;  // image file the target is cut from ...
  cv::Rect target_crop;      // ... this rectangle of it (pixels)
  std::string occluder_image;
  double target_side = 60;     // the target's larger side at scale 1, frame pixels
  double wander = 0.3;         // the target's motion in the frame, share of half the frame
  double wander_period = 160;  // frames
  double pan = 40;             // the camera's slow pan (following the target), background pixels
  double shake = 1.5;          // hand-held shake amplitude, pixels
  double shake_period = 12;    // shortest shake period, frames
  double blur = 0;             // exposure as a share of the frame interval (motion blur along the camera's motion)
  double scale_min = 1, scale_max = 1;
  double rotation_deg = 0;  // in-plane rotation amplitude
  double light = 0;         // lighting ramps: gain within 1 +- light, offset within +-40 light
  std::vector<Occlusion> occlusions;
  bool distractor = false;  // a dimmer, tinted copy of the target circling it (passing behind it)
  std::vector<Excursion> excursions;
  double noise = 2.0;  // sensor noise, grey levels (standard deviation)
  bool round = false;  // the target (and its look-alike) cut as the ellipse inscribed in target_crop, not the
                       // whole rectangle: the box's corners show what is behind it, which moves as the target
                       // does, as around a real ball or face (the truth is the same box)
  // The target turning about its vertical axis, back and forth by up to this
  // many degrees (0: it does not): its picture wrapped round a cylinder, the
  // front half the picture and the back half its mirror image, so what the box
  // shows changes as it turns, the middle moving fastest, as on a head or a
  // ball turning (the truth is the same box).
  double turn_deg = 0;
};

// The scripts with round targets (SyntheticScript::round), each name gaining "@round".
std::vector<SyntheticScript> with_round_targets(std::vector<SyntheticScript> scripts);
// The scripts with turning targets (SyntheticScript::turn_deg), each name
// gaining "@turn<degrees>".
std::vector<SyntheticScript> with_turning_targets(std::vector<SyntheticScript> scripts, double degrees);

// The benchmark's standard set: 8 sequences at 320x240 and 2 at 640x480, 300+
// frames each, each stressing a different mix.
std::vector<SyntheticScript> standard_scripts();
// The same scripts with other targets, backgrounds and seeds (`holdout_<name>`):
// sequences no setting was tuned on, to tell a tracker that generalises from
// one fitted to the standard set.
std::vector<SyntheticScript> holdout_scripts();
// Fresh sets, as many as wanted (`fresh<set>_<name>`, set >= 1): each standard
// script's motions with a target and a background drawn by the set's number
// from opencv-doc's pictures, and another seed. Nothing was ever tuned on
// them: a tracker's figures there are what it does on sequences it has not
// seen.
std::vector<SyntheticScript> fresh_scripts(int set);

// Renders a script from the images in `data_dir`. The same script gives the
// same frames and truth on every run (seeded, no wall-clock or thread
// dependence). An error names an image that is missing or a script that
// cannot be rendered.
Result<Sequence> generate_sequence(const SyntheticScript& script, const std::string& data_dir);
Result<std::vector<Sequence>> generate_sequences(const std::string& data_dir,
                                                 const std::vector<SyntheticScript>& scripts = standard_scripts());

// The target's appearance at scale 1 and no rotation (BGR), as the generator
// renders it: the script's crop resized to target_side; or the error naming
// the image.
Result<cv::Mat> target_appearance(const SyntheticScript& script, const std::string& data_dir);

// --- Scoring.

// What a tracker reported for one frame.
struct TrackedFrame {
  cv::Rect2d box;
  bool tracking = true;              // the tracker claims to follow the target
  double ms = 0;                     // wall clock of this frame's update
  const char* state = "";            // the tracker's own word for it, where it has one
  double confidence = std::nan("");  // likewise
};

// OTB/VOT measures of one track. Frame 0 (the initialisation, given to the
// tracker) is never scored; frames where the target is invisible are left out
// of the centre error, precision and success (as VOT does): a box reported
// there costs nothing except through `honest_lost`.
struct TrackScore {
  int scored_frames = 0;         // visible frames after frame 0
  double mean_center_error = 0;  // pixels, over scored frames
  double precision20 = 0;        // share of scored frames with centre error <= 20 px
  double success_auc = 0;        // mean over IoU thresholds 0, 0.05, ..., 1 of the share with IoU > threshold (OTB)
  double success50 = 0;          // share with IoU > 0.5
  int frames_lost = 0;           // frames after frame 0 where the tracker did not claim tracking
  double honest_lost = -1;       // share of invisible frames where it did not claim tracking; -1 without any
  // Visible frames after frame 0 where it claimed tracking with a box that
  // does not touch the target (IoU 0, VOT's failure): a false lock, which
  // honest_lost does not see, as the target is in view.
  int claimed_off_target = 0;
  int reappearances = 0;         // invisible -> visible transitions
  int max_reacquire_delay = -1;  // frames from a reappearance until tracking with IoU >= 0.3; -1 without any
  int reacquire_misses = 0;      // reappearances not re-acquired while the target stayed visible
  double ms_per_frame = 0;       // mean over frames after frame 0
};

double iou(const cv::Rect2d& a, const cv::Rect2d& b);
double center_error(const cv::Rect2d& a, const cv::Rect2d& b);

// `track` has one entry per frame (entry 0 is ignored); an error when the
// three differ in length.
Result<TrackScore> score_track(const std::vector<cv::Rect2d>& truth, const std::vector<bool>& visible,
                               const std::vector<TrackedFrame>& track);

// Without truth, what a track shows of itself (a video followed from a
// given box): the share of frames after frame 0 where the tracker claimed
// tracking, and its jumps: frames where the box's centre moved more than 0.75
// of the box's larger side since the frame before, which no walking person or
// driven car does in one frame; most often a switch to another object (and a
// switch back is a second jump), though a right re-detection after a long
// absence counts too.
struct WitnessScore {
  int frames = 0;
  double claimed = 0;
  int jumps = 0;
  double ms_per_frame = 0;
};
WitnessScore witness_score(const std::vector<TrackedFrame>& track);

// The frames (after frame 0) where the track jumps, as WitnessScore counts them.
std::vector<int> jump_frames(const std::vector<TrackedFrame>& track);

// What a tracker's frames after frame 0 took (TrackedFrame::ms): the mean,
// the median and the 99th percentile (nearest rank: the value at or under
// which 99% of them lie) and the slowest, and the mean over the frames where
// it did not claim tracking (-1 without any), where a tracker searches: a
// real-time budget is set by those, not by the mean.
struct FrameTimes {
  int frames = 0;
  double mean = 0, median = 0, p99 = 0, max = 0;
  int untracked_frames = 0;
  double untracked_mean = -1;
};
FrameTimes frame_times(const std::vector<TrackedFrame>& track);

// The share of frames after frame 0 where the two tracks' box centres lie
// within `within` pixels (tracks of one sequence; 0 when they differ in
// length or have no such frame).
double agreement(const std::vector<TrackedFrame>& a, const std::vector<TrackedFrame>& b, double within = 20);

// Run r's first box: the truth's, moved and resized by up to a pixel and a
// half in a fixed pattern (run 0: the truth's), as VOT restarts a tracker
// from a perturbed box: a tracker whose outcome hangs on a fraction of a
// pixel shows it as a spread over the runs.
cv::Rect2d perturbed_first_box(const cv::Rect2d& truth, int run);

// FNV-1a over a frame's pixels: cheap evidence that two renders are equal.
uint64_t frame_hash(const cv::Mat& frame);

}  // namespace saccade::bench
