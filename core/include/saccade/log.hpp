#pragma once
#include <memory>

#include <spdlog/spdlog.h>

namespace saccade {
// The library's logger ("saccade"), writing to stderr.
spdlog::logger& log();
}  // namespace saccade
