#include "saccade/message.hpp"

#include <chrono>

#include "saccade/node.hpp"

namespace saccade {

// Out-of-line virtual members anchor each type's vtable and typeinfo in
// libsaccade, so every plugin library sees the same type.
Message::~Message() = default;
Image::~Image() = default;
Retina::~Retina() = default;
FeatureMaps::~FeatureMaps() = default;
Region::~Region() = default;
EmitSink::~EmitSink() = default;
Node::~Node() = default;

void make_exclusive(cv::Mat& mat) {
  if (mat.u != nullptr && mat.u->refcount > 1) mat.release();
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

int OpenContext::checked_input(std::string_view name, std::string_view type) const {
  int index = slot_->contract->input_index(name);
  if (index < 0) throw std::logic_error("node '" + slot_->name + "' has no input '" + std::string(name) + "'");
  const auto& port = slot_->contract->inputs()[static_cast<std::size_t>(index)];
  if (port.type != type)
    throw std::logic_error("input '" + std::string(name) + "' carries " + port.type + ", not " +
                           std::string(type));
  return index;
}

int OpenContext::checked_output(std::string_view name, std::string_view type) const {
  int index = slot_->contract->output_index(name);
  if (index < 0) throw std::logic_error("node '" + slot_->name + "' has no output '" + std::string(name) + "'");
  const auto& port = slot_->contract->outputs()[static_cast<std::size_t>(index)];
  if (port.type != type)
    throw std::logic_error("output '" + std::string(name) + "' carries " + port.type + ", not " +
                           std::string(type));
  return index;
}

}  // namespace saccade
