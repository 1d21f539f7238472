#include "saccade/message.hpp"

#include <algorithm>
#include <chrono>

#include "saccade/node.hpp"
#include "saccade/stats.hpp"

namespace saccade {

// Out-of-line virtual members anchor each type's vtable and typeinfo in
// libsaccade, so every plugin library sees the same type.
Message::~Message() = default;
Image::~Image() = default;
Retina::~Retina() = default;
FeatureMaps::~FeatureMaps() = default;
Region::~Region() = default;
Motion::~Motion() = default;
GazeRequest::~GazeRequest() = default;
JointState::~JointState() = default;
JointTargets::~JointTargets() = default;

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
  return "?";
}

const char* to_string(JointState::Health health) {
  switch (health) {
    case JointState::Health::kStarting: return "starting";
    case JointState::Health::kReady: return "ready";
    case JointState::Health::kFault: return "fault";
    case JointState::Health::kSilent: return "silent";
  }
  return "?";
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
  }
  return "unknown";
}
EmitSink::~EmitSink() = default;
Node::~Node() = default;

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

void create_together(cv::MatAllocator* allocator, std::size_t count, cv::Size size, int type, std::vector<cv::Mat>& mats) {
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

int64_t steady_now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

namespace {

int checked_port(const NodeSlot& slot, const std::vector<PortSpec>& ports, const char* kind, std::string_view name,
                 std::string_view type) {
  for (std::size_t i = 0; i < ports.size(); ++i) {
    if (ports[i].name != name) continue;
    // A node may take any output as a plain Message (the DDS bridges do).
    if (ports[i].type != type && type != kAnyType)
      throw std::logic_error(std::string(kind) + " '" + std::string(name) + "' carries " + ports[i].type + ", not " +
                             std::string(type));
    return static_cast<int>(i);
  }
  throw std::logic_error("node '" + slot.name + "' has no " + kind + " '" + std::string(name) + "'");
}

}  // namespace

namespace {

// The entry of that name (NamedCounter, NamedTiming), added at the end if new.
template <class Named>
Named& named(const NodeSlot& slot, std::vector<std::unique_ptr<Named>>* all, std::string_view name) {
  if (all == nullptr) throw std::logic_error("node '" + slot.name + "' has no stats to count or time in");
  for (auto& entry : *all)
    if (entry->name == name) return *entry;
  all->push_back(std::make_unique<Named>());
  all->back()->name = std::string(name);
  return *all->back();
}

}  // namespace

std::atomic<uint64_t>& OpenContext::counter(std::string_view name) const {
  return named(*slot_, slot_->stats != nullptr ? &slot_->stats->counters : nullptr, name).value;
}

Histogram& OpenContext::timing(std::string_view name) const {
  return named(*slot_, slot_->stats != nullptr ? &slot_->stats->timings : nullptr, name).histogram;
}

int OpenContext::checked_input(std::string_view name, std::string_view type) const {
  return checked_port(*slot_, slot_->contract->inputs(), "input", name, type);
}

int OpenContext::checked_output(std::string_view name, std::string_view type) const {
  return checked_port(*slot_, slot_->contract->outputs(), "output", name, type);
}

}  // namespace saccade
