#pragma once
// Messages travel between nodes as std::shared_ptr<const T>: immutable once emitted,
// shared across fan-out by reference count, never copied.
//
// Each type names its fields once, in `fields(self, visit)`: visit("name", field)
// for every field in order (the stamp's fields come from Message itself). The
// JSON lines sink and the schema tests read messages through it (schema.hpp).
#include <array>
#include <cstdint>
#include <initializer_list>
#include <iterator>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

namespace saccade {

struct Message {
  // Capture (or media) time of the frame this message derives from; sync groups
  // pair inputs on it. Nanoseconds.
  int64_t timestamp_ns = 0;
  // Steady-clock time at which the source produced the frame; end-to-end latency
  // is measured from it.
  int64_t origin_ns = 0;
  int64_t frame_id = 0;

  Message() = default;
  Message(const Message&) = default;
  Message& operator=(const Message&) = default;
  virtual ~Message();
  virtual std::string_view type_name() const = 0;
  // Called by a pool before it hands a recycled message out again: drop any buffer
  // somebody else still references, so writing into it cannot change their data.
  virtual void release_shared_buffers() {}

  void stamp_from(const Message& other) {
    timestamp_ns = other.timestamp_ns;
    origin_ns = other.origin_ns;
    frame_id = other.frame_id;
  }
};
using MessagePtr = std::shared_ptr<const Message>;

// Releases `mat` if its buffer is shared with another header, or comes from an
// allocator other than OpenCV's (a frame ring other processes read), so that
// the next create() allocates a private one; keeps it (no allocation) otherwise.
void make_exclusive(cv::Mat& mat);

// A Mat of `size` and `type` over `data`, bytes inside the buffer `u` holds,
// that keeps that buffer alive as an ROI of it does (one more reference on `u`).
cv::Mat view_of_buffer(cv::UMatData* u, uchar* data, cv::Size size, int type);

// Gives `mats` `count` Mats of `size` and `type` that share one buffer of
// `allocator`, each from a 64-byte boundary: a consumer that sends from that
// allocator's memory (a DDS edge's frame ring) then sends them all at once,
// without a copy. The buffer lives as long as any of them.
void create_together(cv::MatAllocator* allocator, std::size_t count, cv::Size size, int type,
                     std::vector<cv::Mat>& mats);

// Port type name that accepts every message type.
inline constexpr std::string_view kAnyType = "any";

template <class T>
constexpr std::string_view message_type_name() {
  if constexpr (std::is_same_v<T, Message>) {
    return kAnyType;
  } else {
    return T::kTypeName;
  }
}

// A frame from a camera or a file.
struct Image final : Message {
  static constexpr std::string_view kTypeName = "Image";
  std::string_view type_name() const override { return kTypeName; }
  void release_shared_buffers() override { make_exclusive(mat); }
  ~Image() override;

  cv::Mat mat;
  int camera_id = 0;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("camera_id", self.camera_id);
    visit("mat", self.mat);
  }
};

// Where one retina level came from: its region of the source frame, in source
// pixels, and the sampling step (source pixels per level pixel) along x and y.
struct LevelGeometry {
  static constexpr std::string_view kTypeName = "LevelGeometry";
  cv::Rect region;
  double step_x = 1.0;
  double step_y = 1.0;

  // Source-frame coordinates of the centre of level pixel (x, y).
  cv::Point2d to_source(double x, double y) const {
    return {region.x + (x + 0.5) * step_x, region.y + (y + 0.5) * step_y};
  }
  // Level coordinates of source point p (inverse of to_source).
  cv::Point2d from_source(cv::Point2d p) const {
    return {(p.x - region.x) / step_x - 0.5, (p.y - region.y) / step_y - 0.5};
  }

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("region", self.region);
    visit("step_x", self.step_x);
    visit("step_y", self.step_y);
  }
};

// How a retina sampled along rectified geometry maps to its source frame. Its
// levels' regions and steps, and its fovea, are then in the rectified image's
// pixels: a source pixel p (undistorted ray r = camera^-1 p with the lens
// distortion removed) lies at rectified pixel rectified * rotation * r. Both
// retinas of a rectified pair share `rectified`, so their rows are epipolar
// lines and depth = rectified(0,0) * baseline / disparity. Matrices row-major.
struct Rectification {
  static constexpr std::string_view kTypeName = "Rectification";
  bool enabled = false;
  cv::Vec<double, 9> camera{1, 0, 0, 0, 1, 0, 0, 0, 1};     // the source camera's matrix
  cv::Vec<double, 14> distortion;                           // OpenCV's order (k1 k2 p1 p2 k3 ...), unused 0
  cv::Vec<double, 9> rotation{1, 0, 0, 0, 1, 0, 0, 0, 1};   // source camera frame -> rectified frame
  cv::Vec<double, 9> rectified{1, 0, 0, 0, 1, 0, 0, 0, 1};  // the rectified camera's matrix
  double baseline = 0;                                      // metres between the pair's centres (0: unknown)

  bool operator==(const Rectification&) const = default;
  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("enabled", self.enabled);
    visit("camera", self.camera);
    visit("distortion", self.distortion);
    visit("rotation", self.rotation);
    visit("rectified", self.rectified);
    visit("baseline", self.baseline);
  }
};

// The multi-resolution retina: levels[0] is the outermost (whole frame, coarsest),
// levels.back() the fovea (a direct crop, step 1). All levels have the same size.
struct Retina final : Message {
  static constexpr std::string_view kTypeName = "Retina";
  std::string_view type_name() const override { return kTypeName; }
  void release_shared_buffers() override {
    for (auto& level : levels) make_exclusive(level);
    source.reset();
  }
  ~Retina() override;

  std::vector<cv::Mat> levels;
  std::vector<LevelGeometry> geometry;
  cv::Size source_size;
  cv::Point fovea;  // centre of the fovea in source pixels, after clamping
  int camera_id = 0;
  // How the outer levels were sampled, so a consumer can sample another frame
  // the same way (motion resamples the previous frame on this geometry).
  enum class Sampling : uint8_t { kFivePoint, kAreaMean } sampling = Sampling::kFivePoint;
  // When enabled, geometry and fovea are in rectified pixels (see Rectification).
  Rectification rectification;
  // The frame the levels were sampled from (shared, not copied), for overlays.
  std::shared_ptr<const Image> source;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("camera_id", self.camera_id);
    visit("source_size", self.source_size);
    visit("fovea", self.fovea);
    visit("sampling", self.sampling);
    visit("rectification", self.rectification);
    visit("geometry", self.geometry);
    visit("levels", self.levels);
  }
};

// Named per-level maps sharing a Retina's geometry: maps[i][level] is feature
// names[i] on that level.
struct FeatureMaps final : Message {
  static constexpr std::string_view kTypeName = "FeatureMaps";
  std::string_view type_name() const override { return kTypeName; }
  void release_shared_buffers() override {
    for (auto& feature : maps)
      for (auto& level : feature) make_exclusive(level);
    retina.reset();
  }
  ~FeatureMaps() override;

  // Levels of feature `name`, or nullptr when this message does not carry it.
  const std::vector<cv::Mat>* find(std::string_view name) const;

  // Names the features and gives each `levels` maps, keeping the buffers a
  // recycled message already has (no allocation when the layout is unchanged).
  template <class Names>
  void set_layout(const Names& feature_names, std::size_t levels) {
    names.resize(std::size(feature_names));
    std::size_t i = 0;
    for (const auto& name : feature_names) names[i++] = name;
    maps.resize(names.size());
    for (auto& feature : maps) feature.resize(levels);
  }
  void set_layout(std::initializer_list<const char*> feature_names, std::size_t levels) {
    set_layout<std::initializer_list<const char*>>(feature_names, levels);
  }

  std::shared_ptr<const Retina> retina;
  std::vector<std::string> names;
  std::vector<std::vector<cv::Mat>> maps;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("names", self.names);
    visit("maps", self.maps);
  }
};

// Motion between two consecutive retinas, per level (index as in the Retina).
struct Motion final : Message {
  static constexpr std::string_view kTypeName = "Motion";
  std::string_view type_name() const override { return kTypeName; }
  ~Motion() override;

  std::vector<double> energy;         // mean of dI^2 over the level
  std::vector<double> moving;         // fraction of the level's pixels above the threshold
  std::vector<cv::Point2d> centroid;  // of the moving pixels, in source pixels ((-1,-1) when none)
  int camera_id = 0;
  bool first = false;  // the first frame: nothing to compare with, no motion reported

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("camera_id", self.camera_id);
    visit("first", self.first);
    visit("energy", self.energy);
    visit("moving", self.moving);
    visit("centroid", self.centroid);
  }
};

// An axis-aligned box in source pixels: its top-left corner and its size (a
// tracked target, a detection).
struct Box {
  static constexpr std::string_view kTypeName = "Box";
  double x = 0, y = 0, w = 0, h = 0;

  static Box around(cv::Point2d center, cv::Size2d size) {
    return {center.x - size.width / 2, center.y - size.height / 2, size.width, size.height};
  }
  cv::Point2d center() const { return {x + w / 2, y + h / 2}; }
  cv::Rect2d rect() const { return {x, y, w, h}; }
  bool operator==(const Box&) const = default;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("x", self.x);
    visit("y", self.y);
    visit("w", self.w);
    visit("h", self.h);
  }
};

// A point or region in a source frame: a fovea position, a target, a ground truth.
struct Region final : Message {
  static constexpr std::string_view kTypeName = "Region";
  std::string_view type_name() const override { return kTypeName; }
  ~Region() override;

  cv::Point2d center;
  cv::Size2d size;  // zero for a bare point
  double score = 1.0;
  double depth = -1.0;  // metres along the optical axis, when known (< 0: unknown)
  int camera_id = 0;
  std::string label;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("center", self.center);
    visit("size", self.size);
    visit("score", self.score);
    visit("depth", self.depth);
    visit("camera_id", self.camera_id);
    visit("label", self.label);
  }
};

// Where the two cameras' foveas meet: the stereo node's disparity at the left
// fovea's centre, found coarse to fine, and the depth it gives when the
// cameras are calibrated. What the head verges on.
struct StereoFixation final : Message {
  static constexpr std::string_view kTypeName = "StereoFixation";
  std::string_view type_name() const override { return kTypeName; }
  ~StereoFixation() override;

  cv::Point2d pixel;        // the left fovea's centre, source pixels (rectified pixels when `rectified`)
  cv::Size2d fovea;         // the fovea's size there, in the same pixels
  double disparity = -1.0;  // left x minus right x, in the same pixels; < 0: not found
  double score = -1.0;      // the match's NCC at that disparity
  // The right window there matches back to the left one over the whole
  // range: false where repeated texture or a depth edge may have fooled the
  // match, or nothing was found (no gaze request is made from it).
  bool confirmed = false;
  double depth = -1.0;        // metres along the optical axis (< 0: not calibrated or not found)
  double depth_sigma = -1.0;  // one standard deviation of depth, metres (< 0: unknown)
  cv::Vec3d point;            // the fixated point, metres, left camera's optical frame (x right, y down, z ahead)
  cv::Vec3d point_head;       // the same point in the head's base frame (when point_head_valid)
  bool point_head_valid = false;
  bool rectified = false;  // the retinas were sampled along the pair's rectified geometry
  int camera_id = 0;       // of the left retina

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("pixel", self.pixel);
    visit("fovea", self.fovea);
    visit("disparity", self.disparity);
    visit("score", self.score);
    visit("confirmed", self.confirmed);
    visit("depth", self.depth);
    visit("depth_sigma", self.depth_sigma);
    visit("point", self.point);
    visit("point_head", self.point_head);
    visit("point_head_valid", self.point_head_valid);
    visit("rectified", self.rectified);
    visit("camera_id", self.camera_id);
  }
};

// A request to turn the head. The fovea controller sends a direction (the
// pixel it wants at the image centre); other senders may name a 3D point, a
// pixel with its depth or its disparity, or a turn relative to the current gaze.
struct GazeRequest final : Message {
  static constexpr std::string_view kTypeName = "GazeRequest";
  std::string_view type_name() const override { return kTypeName; }
  ~GazeRequest() override;
  enum class Kind : uint8_t {
    kDirection,       // look along `direction` (camera frame); depth unknown
    kPixelDepth,      // `pixel` at `depth` metres along the optical axis
    kPixelDisparity,  // `pixel` in the left image and its `disparity` in the right
    kPoint,           // `point` in the head's base frame, metres
    kRelative,        // turn the gaze by `azimuth` (right +) and `elevation` (up +), radians
  };
  Kind kind = Kind::kDirection;
  cv::Point2d pixel;                  // source pixels of the image it was decided on
  cv::Vec3d direction;                // unit vector to it in the camera frame (x right, y down, z forward)
  cv::Size image_size;                // of that image, so a receiver can tell where the centre was
  double focal_px = 0;                // the sender's focal length in pixels (0: the receiver's own)
  double depth = -1;                  // kPixelDepth (and kDirection when known, > 0)
  double disparity = 0;               // kPixelDisparity: left x minus right x, pixels
  cv::Vec3d point;                    // kPoint
  double azimuth = 0, elevation = 0;  // kRelative
  int camera_id = 0;                  // 0 left, 1 right
  std::string reason;                 // why: "border" (the fovea reached the margin), "target", ...

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("kind", self.kind);
    visit("pixel", self.pixel);
    visit("direction", self.direction);
    visit("image_size", self.image_size);
    visit("focal_px", self.focal_px);
    visit("depth", self.depth);
    visit("disparity", self.disparity);
    visit("point", self.point);
    visit("azimuth", self.azimuth);
    visit("elevation", self.elevation);
    visit("camera_id", self.camera_id);
    visit("reason", self.reason);
  }
};

const char* to_string(GazeRequest::Kind kind);
const char* to_string(Retina::Sampling sampling);

// Where the joints are, as the drives report it; one entry per joint in the
// head's order (neck, vergence left, tilt left, vergence right, tilt right).
struct JointState final : Message {
  static constexpr std::string_view kTypeName = "JointState";
  std::string_view type_name() const override { return kTypeName; }
  ~JointState() override;
  enum class Health : uint8_t {
    kStarting,  // being configured or enabled: no motion yet
    kReady,     // operation enabled, following its targets
    kFault,     // the drive reports a fault (statusword or emergency)
    kSilent,    // no heartbeat or process data within the timeout
  };
  std::vector<double> position;  // rad
  std::vector<double> velocity;  // rad/s
  std::vector<Health> health;
  std::vector<int64_t> updated_ns;   // when each joint's position last arrived (the driver's clock)
  std::vector<uint16_t> error_code;  // the drive's last emergency code (0: none)
  int64_t cycle = 0;                 // control cycles since the start
  std::string detail;                // the first problem in words, empty when every joint is ready
  bool all_ready() const;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("position", self.position);
    visit("velocity", self.velocity);
    visit("health", self.health);
    visit("updated_ns", self.updated_ns);
    visit("error_code", self.error_code);
    visit("cycle", self.cycle);
    visit("detail", self.detail);
  }
};

const char* to_string(JointState::Health health);

// Where the head's cameras are and where they look, from one joint state: each
// camera's optical frame (x right, y down, z along the optical axis) in the
// head's base frame, and the point the two optical axes meet.
struct HeadPose final : Message {
  static constexpr std::string_view kTypeName = "HeadPose";
  std::string_view type_name() const override { return kTypeName; }
  ~HeadPose() override;

  cv::Vec3d left_position, right_position;  // metres, base frame
  cv::Vec4d left_rotation, right_rotation;  // unit quaternions (w, x, y, z): optical frame -> base frame
  cv::Vec3d fixation;                       // metres, base frame: the midpoint of the axes' closest points
  bool fixation_valid = false;              // false: the axes are parallel or meet behind the cameras
  double fixation_gap = 0;                  // metres between the two axes there (0: they meet)

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("left_position", self.left_position);
    visit("left_rotation", self.left_rotation);
    visit("right_position", self.right_position);
    visit("right_rotation", self.right_rotation);
    visit("fixation", self.fixation);
    visit("fixation_valid", self.fixation_valid);
    visit("fixation_gap", self.fixation_gap);
  }
};

// What the head controller asks of the joints this control cycle.
struct JointTargets final : Message {
  static constexpr std::string_view kTypeName = "JointTargets";
  std::string_view type_name() const override { return kTypeName; }
  ~JointTargets() override;
  std::vector<double> position;  // rad
  std::vector<double> velocity;  // rad/s (feed-forward, for drives that take it)
  bool hold = false;             // the head holds after a fault and refuses motion until reset
  int64_t reset = 0;             // incremented by each reset: the driver clears its drives' faults
  std::string fault;             // why it holds
  // Trace of a gaze request to the joint command it causes: on the first
  // targets computed after the head took a request, that request's origin
  // (its camera frame's capture, on the steady clock of the process that
  // stamped it) and when the head took it (this process's clock); 0 otherwise.
  int64_t cause_origin_ns = 0;
  int64_t cause_taken_ns = 0;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("position", self.position);
    visit("velocity", self.velocity);
    visit("hold", self.hold);
    visit("reset", self.reset);
    visit("fault", self.fault);
    visit("cause_origin_ns", self.cause_origin_ns);
    visit("cause_taken_ns", self.cause_taken_ns);
  }
};

// What the fovea controller saw and decided on one frame.
struct FoveaState final : Message {
  static constexpr std::string_view kTypeName = "FoveaState";
  std::string_view type_name() const override { return kTypeName; }
  void release_shared_buffers() override { retina.reset(); }
  ~FoveaState() override;
  // kUncertain: the target is believed near `target` but the tracker is not
  // sure (partly hidden, changing fast) and does not learn from this frame.
  // kLost: the target is gone (hidden, out of view); the tracker looks for it.
  enum class State : uint8_t { kSearching, kTracking, kLost, kUncertain };
  State state = State::kSearching;
  cv::Point2d fovea;  // fovea centre the retina used for this frame, source pixels
  cv::Point2d next;   // fovea centre asked for the next frame
  Box target;         // the target in this frame, source pixels (when target_valid)
  bool target_valid = false;
  double confidence = 0.0;       // the tracker's: a box's peak-to-sidelobe ratio, a template's match (NCC)
  double score = 0.0;            // tracking: as confidence; searching: the attended saliency
  bool attention_shift = false;  // the fovea was sent somewhere new this frame
  bool gaze_request = false;     // a GazeRequest went out this frame
  int64_t attention_shifts = 0;  // since the start
  int64_t gaze_requests = 0;
  int64_t frames_lost = 0;  // consecutive frames in the lost state
  int camera_id = 0;
  std::shared_ptr<const Retina> retina;  // the retina it was decided on, for overlays

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("state", self.state);
    visit("fovea", self.fovea);
    visit("next", self.next);
    visit("target", self.target);
    visit("target_valid", self.target_valid);
    visit("confidence", self.confidence);
    visit("score", self.score);
    visit("attention_shift", self.attention_shift);
    visit("gaze_request", self.gaze_request);
    visit("attention_shifts", self.attention_shifts);
    visit("gaze_requests", self.gaze_requests);
    visit("frames_lost", self.frames_lost);
    visit("camera_id", self.camera_id);
  }
};

const char* to_string(FoveaState::State state);

// What a classifier made of the region it looked at.
struct Classification final : Message {
  static constexpr std::string_view kTypeName = "Classification";
  std::string_view type_name() const override { return kTypeName; }
  ~Classification() override;
  // The paper's three outcomes, from the classifier's thresholds.
  enum class Outcome : uint8_t { kClassified, kProbable, kNotClassified };
  Outcome outcome = Outcome::kNotClassified;
  int best = -1;                                            // index of the best class
  double score = 0.0;                                       // its score, 0..1
  std::vector<float> scores;                                // per class, 0..1
  std::shared_ptr<const std::vector<std::string>> classes;  // class names (shared by every message)
  cv::Rect roi;                                             // source pixels the classifier looked at
  int camera_id = 0;

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("outcome", self.outcome);
    visit("best", self.best);
    visit("score", self.score);
    visit("scores", self.scores);
    visit("classes", self.classes);
    visit("roi", self.roi);
    visit("camera_id", self.camera_id);
  }
  std::string_view label() const {
    return classes && best >= 0 && best < static_cast<int>(classes->size())
               ? std::string_view((*classes)[static_cast<std::size_t>(best)])
               : std::string_view();
  }
};

const char* to_string(Classification::Outcome outcome);

// CAN frames as they crossed a bus, in the kernel's encoding: for watching a
// bus from another process or PC, or bridging one across them (can.tap,
// can.send).
struct CanFrames final : Message {
  static constexpr std::string_view kTypeName = "CanFrames";
  std::string_view type_name() const override { return kTypeName; }
  ~CanFrames() override;
  static constexpr uint32_t kExtended = 0x80000000U, kRemote = 0x40000000U, kError = 0x20000000U;  // in can_id
  static constexpr uint8_t kFd = 0x80, kBitRateSwitch = 0x01, kErrorStateIndicator = 0x02;         // in flags
  struct Frame {
    static constexpr std::string_view kTypeName = "CanFrame";
    uint32_t can_id = 0;  // 11- or 29-bit id with kExtended / kRemote / kError, as linux/can.h
    uint8_t length = 0;   // data bytes: 0..8, 0..64 with kFd
    uint8_t flags = 0;
    std::array<uint8_t, 64> data{};
    int64_t timestamp_ns = 0;  // when the bus delivered it (the bus's clock)
    bool operator==(const Frame&) const = default;

    template <class Self, class Visit>
    static void fields(Self& self, Visit&& visit) {
      visit("can_id", self.can_id);
      visit("length", self.length);
      visit("flags", self.flags);
      visit("data", self.data);
      visit("timestamp_ns", self.timestamp_ns);
    }
  };
  std::vector<Frame> frames;
  std::string bus;  // where they were seen, e.g. "socketcan:can0"

  template <class Self, class Visit>
  static void fields(Self& self, Visit&& visit) {
    visit("bus", self.bus);
    visit("frames", self.frames);
  }
};

}  // namespace saccade
