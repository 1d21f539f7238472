#pragma once
// The stereo node's parameters, bound to the matcher's configuration: named
// once, for the node (plugins/stereo/stereo_plugin.cpp) and for the tools that
// set the matcher by the node's names (saccade_stereo_bench --set).
#include <string>

#include "retina_stereo.hpp"
#include "saccade/params.hpp"
#include "saccade/status.hpp"

namespace saccade::stereo {

// What the node reads from its parameters: the matcher's configuration, the
// calibration for depth, and a calibration file that overrides it.
struct StereoNodeConfig {
  RetinaStereoConfig stereo;
  StereoCalibration calibration;
  std::string calibration_file;
  // The fixation disparity's standard deviation for its depth's: the RMS
  // error make bench-verge measures on the verging sim head (0.27 px).
  double disparity_sigma = 0.3;
};

// Declares (in a contract) or reads (from a node's parameters) every field.
void bind_stereo_params(ParamBinder<StereoNodeConfig>& b);

// What the parameters' ranges cannot say: an odd window, sgm_p2 >= sgm_p1.
Status check_stereo_params(const StereoNodeConfig& c);

}  // namespace saccade::stereo
