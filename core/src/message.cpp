#include "saccade/message.hpp"

#include <algorithm>

namespace saccade {

// Out-of-line virtual members anchor each type's vtable and typeinfo in
// libsaccade, so every plugin library sees the same type.
Message::~Message() = default;
Image::~Image() = default;
Retina::~Retina() = default;
FeatureMaps::~FeatureMaps() = default;
Region::~Region() = default;
StereoFixation::~StereoFixation() = default;
Motion::~Motion() = default;
GazeRequest::~GazeRequest() = default;
JointState::~JointState() = default;
JointTargets::~JointTargets() = default;
HeadPose::~HeadPose() = default;

bool JointState::all_ready() const {
  if (health.empty()) return false;
  for (Health h : health)
    if (h != Health::kReady) return false;
  return true;
}

const char* to_string(GazeRequest::Kind kind) {
  switch (kind) {
    case GazeRequest::Kind::kDirection: return "direction";
    case GazeRequest::Kind::kPixelDepth: return "pixel+depth";
    case GazeRequest::Kind::kPixelDisparity: return "pixel+disparity";
    case GazeRequest::Kind::kPoint: return "point";
    case GazeRequest::Kind::kRelative: return "relative";
  }
  return "unknown";
}

const char* to_string(Retina::Sampling sampling) {
  switch (sampling) {
    case Retina::Sampling::kFivePoint: return "five_point";
    case Retina::Sampling::kAreaMean: return "area_mean";
  }
  return "unknown";
}

const char* to_string(JointState::Health health) {
  switch (health) {
    case JointState::Health::kStarting: return "starting";
    case JointState::Health::kReady: return "ready";
    case JointState::Health::kFault: return "fault";
    case JointState::Health::kSilent: return "silent";
  }
  return "unknown";
}
FoveaState::~FoveaState() = default;
Classification::~Classification() = default;
CanFrames::~CanFrames() = default;

const char* to_string(Classification::Outcome outcome) {
  switch (outcome) {
    case Classification::Outcome::kClassified: return "classified";
    case Classification::Outcome::kProbable: return "probable";
    case Classification::Outcome::kNotClassified: return "not classified";
  }
  return "unknown";
}

const char* to_string(FoveaState::State state) {
  switch (state) {
    case FoveaState::State::kSearching: return "searching";
    case FoveaState::State::kTracking: return "tracking";
    case FoveaState::State::kLost: return "lost";
    case FoveaState::State::kUncertain: return "uncertain";
  }
  return "unknown";
}

void make_exclusive(cv::Mat& mat) {
  if (mat.u == nullptr) return;
  // A buffer of another allocator (a shared-memory frame ring, whose frames
  // other processes may still read) is never rewritten in place: releasing it
  // lets that allocator hand out a buffer nobody holds. Nor is one from
  // another allocator than the Mat now asks for (its producer switched to a
  // frame ring).
  const cv::MatAllocator* owner = mat.u->currAllocator;
  if (mat.u->refcount > 1 || (owner != cv::Mat::getStdAllocator() && owner != cv::Mat::getDefaultAllocator()) ||
      (mat.allocator != nullptr && mat.allocator != owner))
    mat.release();
}

void create_together(cv::MatAllocator* allocator, std::size_t count, cv::Size size, int type,
                     std::vector<cv::Mat>& mats) {
  const std::size_t bytes = static_cast<std::size_t>(size.area()) * CV_ELEM_SIZE(type);
  const std::size_t stride = (bytes + 63) / 64 * 64;
  cv::Mat buffer;
  buffer.allocator = allocator;
  buffer.create(1, static_cast<int>(std::max<std::size_t>(stride * count, 1)), CV_8U);
  mats.resize(count);
  for (std::size_t k = 0; k < count; ++k) mats[k] = view_of_buffer(buffer.u, buffer.data + k * stride, size, type);
}

cv::Mat view_of_buffer(cv::UMatData* u, uchar* data, cv::Size size, int type) {
  cv::Mat view(size, type, data);
  view.u = u;
  CV_XADD(&u->refcount, 1);
  return view;
}

const std::vector<cv::Mat>* FeatureMaps::find(std::string_view name) const {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return &maps[i];
  return nullptr;
}

}  // namespace saccade
