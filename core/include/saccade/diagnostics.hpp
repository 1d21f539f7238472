#pragma once
// Errors about a graph file, each tied to a line, a node and a port.
#include <string>
#include <vector>

namespace saccade {

struct Diagnostic {
  std::string file;
  int line = 0;  // 0: not from a line of the file (command line, plugin folder)
  std::string node;
  std::string port;
  std::string message;
  bool warning = false;

  // "file:line: error: node 'n' port 'p': message"
  std::string format() const;
};

class Diagnostics {
 public:
  void error(std::string file, int line, std::string node, std::string port, std::string message);
  void warn(std::string file, int line, std::string node, std::string port, std::string message);
  void append(const Diagnostics& other);
  bool has_errors() const;
  std::size_t error_count() const;
  const std::vector<Diagnostic>& all() const { return items_; }
  std::string format() const;  // one line each

 private:
  std::vector<Diagnostic> items_;
};

}  // namespace saccade
