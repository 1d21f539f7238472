#pragma once
// The fovea node's parameters, bound to the controller's configuration: named
// once, for the node (plugins/fovea/fovea_plugin.cpp) and for the tools that
// set the box tracker by the node's names (saccade_track_bench --set).
#include "controller.hpp"
#include "saccade/params.hpp"

namespace saccade::fovea {

// Declares (in a contract) or reads (from a node's parameters) every field.
void bind_fovea_params(ParamBinder<ControllerConfig>& b);

}  // namespace saccade::fovea
