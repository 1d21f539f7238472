#pragma once
// One static contract per node type: typed ports and parameters with defaults,
// ranges and docs. Validation, `saccade plugins` and the docs all read it.
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

#include <opencv2/core.hpp>

#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade {

enum class ParamType { kInt, kDouble, kBool, kString, kSize, kPoint, kEnum, kFlags };
std::string_view to_string(ParamType type);

struct ParamSpec {
  std::string name;
  ParamType type = ParamType::kString;
  std::string default_value;  // as written in XML; empty with required = true
  std::optional<double> min;
  std::optional<double> max;
  std::vector<std::string> choices;  // kEnum: one of them; kFlags: a comma list of them
  std::string doc;
  bool required = false;
  // Taken from a field of the node's configuration struct (Contract::params):
  // the default is the struct's, and the node reads it back into that field.
  bool bound = false;
};

enum class InputKind {
  kTrigger,   // required; the node runs when every trigger input holds a message
  kOptional,  // triggers like kTrigger when connected, may stay unconnected
  kSide,      // never triggers: the node sees the newest message that arrived, if any
};

struct PortSpec {
  std::string name;
  std::string type;  // message type name, or "any"
  std::string doc;
  InputKind kind = InputKind::kTrigger;
  // The node's port constant (In / Out) this port was declared from, so that
  // process code finds the port by the constant itself; nullptr for ports
  // declared by name.
  const void* key = nullptr;
};

// A node's port, declared once as a constant and used by both its contract
// and its process code (MediaPipe api2's Input<T> kIn{"IN"}):
//   static constexpr In<Retina> kRetina{"retina", "the retina to smooth"};
//   static constexpr Out<FeatureMaps> kMaps{"maps", "the filtered levels"};
//   Contract("...").ports(kRetina, kMaps)      ctx.get(kRetina), ctx.make(kMaps)
// The message type is part of the constant, so a port cannot be read as
// another type than it carries.
template <class T, InputKind Kind = InputKind::kTrigger>
struct In {
  using type = T;
  static constexpr InputKind kind = Kind;
  std::string_view name;
  std::string_view doc;
};
// Triggers like In when connected; may stay unconnected (get() gives nullptr).
template <class T>
using OptionalIn = In<T, InputKind::kOptional>;
// Never triggers: the node sees the newest message that arrived, if any.
template <class T>
using SideIn = In<T, InputKind::kSide>;

template <class T>
struct Out {
  using type = T;
  std::string_view name;
  std::string_view doc;
};

template <class Config>
class ParamBinder;

using ParamValue = std::variant<int64_t, double, bool, std::string, cv::Size, cv::Point2d, std::vector<std::string>>;

// Parses `text` as `spec` requires (whole string, range, choices) into `out`;
// an error saying why when it does not fit.
Status parse_param(const ParamSpec& spec, std::string_view text, ParamValue& out);

// Whether a parameter not given takes its default (an optional one without
// a default stays absent; a text or a list defaults to empty).
inline bool takes_default(const ParamSpec& spec) {
  return !spec.default_value.empty() || spec.type == ParamType::kString || spec.type == ParamType::kFlags;
}

// `params` from `settings` (name, value as a graph's XML writes it) for the
// parameters `contract` declares, each parsed as parse_param does, the rest
// at their defaults; an error names a setting that is unknown or does not fit.
class Contract;
class Params;
Status read_params(const Contract& contract, const std::vector<std::pair<std::string, std::string>>& settings,
                   Params& params);

// "name=value" texts (a tool's --set arguments) as (name, value) settings for
// read_params / configure; an error names the text without '='.
Result<std::vector<std::pair<std::string, std::string>>> split_settings(const std::vector<std::string>& texts);

// "a, b,,c" -> {"a", "b", "c"}: a parameter that names several things (topics,
// joints), items trimmed, empty ones dropped.
std::vector<std::string> comma_list(std::string_view text);

// A node's parameters after validation: every declared one is present.
class Params {
 public:
  void set(const std::string& name, ParamValue value) { values_[name] = std::move(value); }
  bool has(const std::string& name) const { return values_.count(name) != 0; }

  int64_t get_int(const std::string& name) const { return get<int64_t>(name); }
  double get_double(const std::string& name) const { return get<double>(name); }
  bool get_bool(const std::string& name) const { return get<bool>(name); }
  const std::string& get_string(const std::string& name) const { return get<std::string>(name); }
  cv::Size get_size(const std::string& name) const { return get<cv::Size>(name); }
  cv::Point2d get_point(const std::string& name) const { return get<cv::Point2d>(name); }
  const std::vector<std::string>& get_flags(const std::string& name) const {
    return get<std::vector<std::string>>(name);
  }
  bool has_flag(const std::string& name, std::string_view flag) const;
  const std::map<std::string, ParamValue>& all() const { return values_; }

 private:
  template <class T>
  const T& get(const std::string& name) const;
  std::map<std::string, ParamValue> values_;
};

class Contract {
 public:
  Contract() = default;
  explicit Contract(std::string doc) : doc_(std::move(doc)) {}

  template <class T>
  Contract& input(std::string name, std::string doc) {
    return add_input(std::move(name), message_type_name<T>(), std::move(doc), InputKind::kTrigger);
  }
  template <class T>
  Contract& optional_input(std::string name, std::string doc) {
    return add_input(std::move(name), message_type_name<T>(), std::move(doc), InputKind::kOptional);
  }
  template <class T>
  Contract& side_input(std::string name, std::string doc) {
    return add_input(std::move(name), message_type_name<T>(), std::move(doc), InputKind::kSide);
  }
  template <class T>
  Contract& output(std::string name, std::string doc) {
    outputs_.push_back({std::move(name), std::string(message_type_name<T>()), std::move(doc)});
    return *this;
  }

  // Ports from their constants (In, OptionalIn, SideIn, Out), in order.
  template <class... Ports>
  Contract& ports(const Ports&... ports) {
    (add_port(ports), ...);
    return *this;
  }

  // Parameters bound to the fields of a configuration struct: `bind` names
  // each field once (ParamBinder::field), the contract takes each default
  // from a default-constructed Config, and OpenContext::config fills a
  // Config from a node's parameters through the same function.
  template <class Config>
  Contract& params(void (*bind)(ParamBinder<Config>&));

  Contract& param_int(std::string name, int64_t def, int64_t min, int64_t max, std::string doc);
  Contract& param_double(std::string name, double def, double min, double max, std::string doc);
  Contract& param_bool(std::string name, bool def, std::string doc);
  Contract& param_string(std::string name, std::string def, std::string doc);
  Contract& required_string(std::string name, std::string doc);
  Contract& param_size(std::string name, cv::Size def, std::string doc);
  Contract& param_point(std::string name, std::optional<cv::Point2d> def, std::string doc);
  Contract& param_enum(std::string name, std::string def, std::vector<std::string> choices, std::string doc);
  Contract& param_flags(std::string name, std::string def, std::vector<std::string> choices, std::string doc);

  const std::string& doc() const { return doc_; }
  const std::vector<PortSpec>& inputs() const { return inputs_; }
  const std::vector<PortSpec>& outputs() const { return outputs_; }
  const std::vector<ParamSpec>& params() const { return params_; }
  // Runs on its own, at its own pace: no input triggers it (side inputs,
  // such as a driver's targets, only give it their newest value).
  bool is_source() const {
    for (const PortSpec& in : inputs_)
      if (in.kind != InputKind::kSide) return false;
    return true;
  }

  // What is wrong with the contract itself (a bound default that does not
  // survive its own text, a default outside its range, ...); empty when sound.
  const std::vector<std::string>& problems() const { return problems_; }
  void add_problem(std::string problem) { problems_.push_back(std::move(problem)); }
  void mark_last_param_bound() { params_.back().bound = true; }

  const PortSpec* find_input(std::string_view name) const;
  const PortSpec* find_output(std::string_view name) const;
  const ParamSpec* find_param(std::string_view name) const;
  int input_index(std::string_view name) const;   // -1 when absent
  int output_index(std::string_view name) const;  // -1 when absent
  int input_index(const void* key) const;         // by port constant; -1 when absent
  int output_index(const void* key) const;

 private:
  template <class T, InputKind Kind>
  void add_port(const In<T, Kind>& port) {
    add_input(std::string(port.name), message_type_name<T>(), std::string(port.doc), Kind);
    inputs_.back().key = &port;
  }
  template <class T>
  void add_port(const Out<T>& port) {
    output<T>(std::string(port.name), std::string(port.doc));
    outputs_.back().key = &port;
  }
  Contract& add_input(std::string name, std::string_view type, std::string doc, InputKind kind);
  Contract& add_param(ParamSpec spec);
  std::string doc_;
  std::vector<PortSpec> inputs_;
  std::vector<PortSpec> outputs_;
  std::vector<ParamSpec> params_;
  std::vector<std::string> problems_;
};

// True when a message of type `produced` may travel into an input of type `accepted`.
inline bool port_types_match(std::string_view produced, std::string_view accepted) {
  return accepted == kAnyType || produced == accepted;
}

}  // namespace saccade

#include "saccade/params.hpp"
