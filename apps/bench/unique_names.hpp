#pragma once
// Names the benchmarks' tables and exported folders go by, kept apart.
#include <algorithm>
#include <string>
#include <vector>

namespace saccade::bench {

// Gives a name met before in `items` "_2", "_3"... (two folders of one name:
// a Middlebury scene at two sizes, KITTI's training and testing frame 0), so
// that no table row or exported folder stands for two of them. `name_of`
// returns a reference to an item's name.
template <class Item, class NameOf>
void make_names_unique(std::vector<Item>& items, NameOf name_of) {
  std::vector<std::string> seen;
  for (Item& item : items) {
    std::string& name = name_of(item);
    const std::string base = name;
    for (int n = 2; std::find(seen.begin(), seen.end(), name) != seen.end(); ++n) name = base + "_" + std::to_string(n);
    seen.push_back(name);
  }
}

}  // namespace saccade::bench
