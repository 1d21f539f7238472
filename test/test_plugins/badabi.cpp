// A plugin whose descriptor carries another ABI version.
#include "saccade/plugin.hpp"

namespace {
const saccade::PluginDescriptor kDescriptor = {{999, 1, 1, 1, 1, 1}, "badabi", nullptr, 0};
const saccade::PluginDescriptor* entry() { return &kDescriptor; }
}  // namespace

BOOST_DLL_ALIAS_SECTIONED(entry, saccade_plugin_entry, saccade)
