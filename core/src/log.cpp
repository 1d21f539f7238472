#include "saccade/log.hpp"

#include <spdlog/sinks/stdout_color_sinks.h>

namespace saccade {

spdlog::logger& log() {
  static std::shared_ptr<spdlog::logger> logger = [] {
    auto l = spdlog::get("saccade");
    if (!l) l = spdlog::stderr_color_mt("saccade");
    l->set_pattern("[%H:%M:%S.%e] [%^%l%$] %v");
    return l;
  }();
  return *logger;
}

}  // namespace saccade
