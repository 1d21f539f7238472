#pragma once
// Recycles messages once nobody but the pool holds them, so a node in steady state
// allocates neither message objects, shared_ptr control blocks nor (for buffers of
// an unchanged size) pixel memory.
#include <cstddef>
#include <memory>
#include <vector>

#include "saccade/message.hpp"

namespace saccade {

class MessagePool {
 public:
  explicit MessagePool(std::size_t reserve = 16) { slots_.reserve(reserve); }

  // Only the owning node's thread acquires. A slot whose use_count is 1 is held by
  // the pool alone and nobody can obtain it again but through acquire().
  template <class T>
  std::shared_ptr<T> acquire() {
    for (std::size_t i = 0; i < slots_.size(); ++i) {
      std::size_t k = (next_ + i) % slots_.size();
      auto& slot = slots_[k];
      if (slot.use_count() != 1) continue;
      // Copying the pointer is an acq_rel increment of the count that the last
      // holder released: everything it did with the message happens before us.
      std::shared_ptr<Message> held = slot;
      if (held.use_count() != 2) continue;
      auto* typed = dynamic_cast<T*>(held.get());
      if (typed == nullptr) continue;
      next_ = (k + 1) % slots_.size();
      typed->release_shared_buffers();
      return std::shared_ptr<T>(std::move(held), typed);
    }
    auto fresh = std::make_shared<T>();
    slots_.push_back(fresh);
    ++allocations_;
    return fresh;
  }

  std::size_t size() const { return slots_.size(); }
  std::size_t allocations() const { return allocations_; }

 private:
  std::vector<std::shared_ptr<Message>> slots_;
  std::size_t next_ = 0;
  std::size_t allocations_ = 0;
};

}  // namespace saccade
