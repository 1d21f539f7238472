#include "saccade/diagnostics.hpp"

#include <algorithm>

namespace saccade {

std::string Diagnostic::format() const {
  std::string out = file.empty() ? std::string("<graph>") : file;
  if (line > 0) out += ":" + std::to_string(line);
  out += warning ? ": warning: " : ": error: ";
  if (!node.empty()) out += "node '" + node + "' ";
  if (!port.empty()) out += "port '" + port + "' ";
  if (!node.empty() || !port.empty()) {
    out.pop_back();
    out += ": ";
  }
  return out + message;
}

void Diagnostics::error(std::string file, int line, std::string node, std::string port, std::string message) {
  items_.push_back({std::move(file), line, std::move(node), std::move(port), std::move(message), false});
}

void Diagnostics::warn(std::string file, int line, std::string node, std::string port, std::string message) {
  items_.push_back({std::move(file), line, std::move(node), std::move(port), std::move(message), true});
}

void Diagnostics::append(const Diagnostics& other) {
  items_.insert(items_.end(), other.items_.begin(), other.items_.end());
}

bool Diagnostics::has_errors() const { return error_count() > 0; }

std::size_t Diagnostics::error_count() const {
  std::size_t n = 0;
  for (const auto& d : items_) n += d.warning ? 0 : 1;
  return n;
}

std::string Diagnostics::format() const {
  // In file order, as an editor would walk them.
  std::vector<const Diagnostic*> sorted;
  for (const auto& d : items_) sorted.push_back(&d);
  std::stable_sort(sorted.begin(), sorted.end(), [](const Diagnostic* a, const Diagnostic* b) {
    return a->file == b->file ? a->line < b->line : a->file < b->file;
  });
  std::string out;
  for (const Diagnostic* d : sorted) out += d->format() + "\n";
  return out;
}

}  // namespace saccade
