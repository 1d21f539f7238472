#include "saccade/contract.hpp"

#include "saccade/graph.hpp"

#include "text.hpp"

#include <charconv>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace saccade {

std::string_view to_string(ParamType type) {
  switch (type) {
    case ParamType::kInt: return "int";
    case ParamType::kDouble: return "double";
    case ParamType::kBool: return "bool";
    case ParamType::kString: return "string";
    case ParamType::kSize: return "size";
    case ParamType::kPoint: return "point";
    case ParamType::kEnum: return "enum";
    case ParamType::kFlags: return "flags";
  }
  return "?";
}

std::vector<std::string> comma_list(std::string_view text) { return text::split_list(text, ','); }

namespace {

using text::format_exact;
using text::format_number;
using text::join;
using text::parse_number;
using text::split_list;
using text::trim;

Status check_range(const ParamSpec& spec, double v) {
  if ((spec.min && v < *spec.min) || (spec.max && v > *spec.max)) {
    return Status::error("value " + format_number(v) + " is out of range [" +
                         format_number(spec.min.value_or(-INFINITY)) + ", " +
                         format_number(spec.max.value_or(INFINITY)) + "]");
  }
  return {};
}

}  // namespace

Status read_params(const Contract& contract, const std::vector<std::pair<std::string, std::string>>& settings,
                   Params& params) {
  std::vector<std::string> known;
  for (const ParamSpec& spec : contract.params()) known.push_back(spec.name);
  for (const auto& [name, text] : settings) {
    const ParamSpec* spec = contract.find_param(name);
    if (spec == nullptr) return Status::error("unknown parameter '" + name + "'" + did_you_mean(name, known));
    if (params.has(name)) return Status::error("parameter '" + name + "' given twice");
    ParamValue value;
    if (Status parsed = parse_param(*spec, text, value); !parsed.ok())
      return Status::error("parameter '" + name + "' (" + std::string(to_string(spec->type)) +
                           "): " + parsed.message());
    params.set(name, std::move(value));
  }
  for (const ParamSpec& spec : contract.params()) {
    if (params.has(spec.name)) continue;
    if (spec.required) return Status::error("missing required parameter '" + spec.name + "' (" + spec.doc + ")");
    if (!takes_default(spec)) continue;
    ParamValue value;
    if (Status parsed = parse_param(spec, spec.default_value, value); !parsed.ok())
      return Status::error("default of parameter '" + spec.name + "' is invalid: " + parsed.message());
    params.set(spec.name, std::move(value));
  }
  return {};
}

Result<std::vector<std::pair<std::string, std::string>>> split_settings(const std::vector<std::string>& texts) {
  std::vector<std::pair<std::string, std::string>> settings;
  for (const std::string& text : texts) {
    const auto eq = text.find('=');
    if (eq == std::string::npos) return Status::error("'" + text + "': expected name=value");
    settings.emplace_back(text.substr(0, eq), text.substr(eq + 1));
  }
  return settings;
}

Status parse_param(const ParamSpec& spec, std::string_view text, ParamValue& out) {
  switch (spec.type) {
    case ParamType::kInt: {
      int64_t v = 0;
      if (!parse_number(text, v)) return Status::error("expected an integer, got '" + std::string(text) + "'");
      if (Status e = check_range(spec, static_cast<double>(v)); !e.ok()) return e;
      out = v;
      return {};
    }
    case ParamType::kDouble: {
      double v = 0;
      if (!parse_number(text, v) || !std::isfinite(v))
        return Status::error("expected a number, got '" + std::string(text) + "'");
      if (Status e = check_range(spec, v); !e.ok()) return e;
      out = v;
      return {};
    }
    case ParamType::kBool: {
      auto t = trim(text);
      if (t == "true" || t == "1" || t == "yes" || t == "on") {
        out = true;
      } else if (t == "false" || t == "0" || t == "no" || t == "off") {
        out = false;
      } else {
        return Status::error("expected true or false, got '" + std::string(text) + "'");
      }
      return {};
    }
    case ParamType::kString: out = std::string(text); return {};
    case ParamType::kSize: {
      auto t = trim(text);
      auto x = t.find('x');
      int w = 0, h = 0;
      if (x == std::string_view::npos || !parse_number(t.substr(0, x), w) || !parse_number(t.substr(x + 1), h))
        return Status::error("expected a size WxH such as 32x24, got '" + std::string(text) + "'");
      if (Status e = check_range(spec, w); !e.ok()) return Status::error("width " + e.message());
      if (Status e = check_range(spec, h); !e.ok()) return Status::error("height " + e.message());
      out = cv::Size(w, h);
      return {};
    }
    case ParamType::kPoint: {
      auto parts = split_list(text, ',');
      double x = 0, y = 0;
      if (parts.size() != 2 || !parse_number(parts[0], x) || !parse_number(parts[1], y))
        return Status::error("expected a point x,y such as 320,240, got '" + std::string(text) + "'");
      out = cv::Point2d(x, y);
      return {};
    }
    case ParamType::kEnum: {
      auto t = std::string(trim(text));
      for (const auto& c : spec.choices)
        if (c == t) {
          out = t;
          return {};
        }
      return Status::error("expected one of " + join(spec.choices, ", ") + "; got '" + std::string(text) + "'");
    }
    case ParamType::kFlags: {
      std::vector<std::string> flags;
      for (auto& item : split_list(text, ',')) {
        if (item == "all") {
          flags = spec.choices;
          continue;
        }
        bool known = false;
        for (const auto& c : spec.choices) known = known || c == item;
        if (!known)
          return Status::error("unknown flag '" + item + "'; expected a comma list of " + join(spec.choices, ", ") +
                               " (or all)");
        bool present = false;
        for (const auto& f : flags) present = present || f == item;
        if (!present) flags.push_back(item);
      }
      out = flags;
      return {};
    }
  }
  return Status::error("unknown parameter type");
}

template <class T>
const T& Params::get(const std::string& name) const {
  auto it = values_.find(name);
  if (it == values_.end()) throw std::logic_error("no parameter '" + name + "'");
  const T* v = std::get_if<T>(&it->second);
  if (v == nullptr) throw std::logic_error("parameter '" + name + "' read with the wrong type");
  return *v;
}
template const int64_t& Params::get<int64_t>(const std::string&) const;
template const double& Params::get<double>(const std::string&) const;
template const bool& Params::get<bool>(const std::string&) const;
template const std::string& Params::get<std::string>(const std::string&) const;
template const cv::Size& Params::get<cv::Size>(const std::string&) const;
template const cv::Point2d& Params::get<cv::Point2d>(const std::string&) const;
template const std::vector<std::string>& Params::get<std::vector<std::string>>(const std::string&) const;

bool Params::has_flag(const std::string& name, std::string_view flag) const {
  for (const auto& f : get_flags(name))
    if (f == flag) return true;
  return false;
}

Contract& Contract::add_input(std::string name, std::string_view type, std::string doc, InputKind kind) {
  inputs_.push_back({std::move(name), std::string(type), std::move(doc), kind});
  return *this;
}

Contract& Contract::add_param(ParamSpec spec) {
  params_.push_back(std::move(spec));
  return *this;
}

Contract& Contract::param_int(std::string name, int64_t def, int64_t min, int64_t max, std::string doc) {
  return add_param({std::move(name),
                    ParamType::kInt,
                    std::to_string(def),
                    static_cast<double>(min),
                    static_cast<double>(max),
                    {},
                    std::move(doc)});
}
Contract& Contract::param_double(std::string name, double def, double min, double max, std::string doc) {
  return add_param({std::move(name), ParamType::kDouble, format_exact(def), min, max, {}, std::move(doc)});
}
Contract& Contract::param_bool(std::string name, bool def, std::string doc) {
  return add_param({std::move(name), ParamType::kBool, def ? "true" : "false", {}, {}, {}, std::move(doc)});
}
Contract& Contract::param_string(std::string name, std::string def, std::string doc) {
  return add_param({std::move(name), ParamType::kString, std::move(def), {}, {}, {}, std::move(doc)});
}
Contract& Contract::required_string(std::string name, std::string doc) {
  ParamSpec spec{std::move(name), ParamType::kString, "", {}, {}, {}, std::move(doc)};
  spec.required = true;
  return add_param(std::move(spec));
}
Contract& Contract::param_size(std::string name, cv::Size def, std::string doc) {
  return add_param({std::move(name),
                    ParamType::kSize,
                    std::to_string(def.width) + "x" + std::to_string(def.height),
                    0.0,
                    1e6,
                    {},
                    std::move(doc)});
}
Contract& Contract::param_point(std::string name, std::optional<cv::Point2d> def, std::string doc) {
  std::string text = def ? format_number(def->x) + "," + format_number(def->y) : "";
  ParamSpec spec{std::move(name), ParamType::kPoint, text, {}, {}, {}, std::move(doc)};
  return add_param(std::move(spec));
}
Contract& Contract::param_enum(std::string name, std::string def, std::vector<std::string> choices, std::string doc) {
  return add_param({std::move(name), ParamType::kEnum, std::move(def), {}, {}, std::move(choices), std::move(doc)});
}
Contract& Contract::param_flags(std::string name, std::string def, std::vector<std::string> choices, std::string doc) {
  return add_param({std::move(name), ParamType::kFlags, std::move(def), {}, {}, std::move(choices), std::move(doc)});
}

const PortSpec* Contract::find_input(std::string_view name) const {
  int i = input_index(name);
  return i < 0 ? nullptr : &inputs_[static_cast<std::size_t>(i)];
}
const PortSpec* Contract::find_output(std::string_view name) const {
  int i = output_index(name);
  return i < 0 ? nullptr : &outputs_[static_cast<std::size_t>(i)];
}
const ParamSpec* Contract::find_param(std::string_view name) const {
  for (const auto& p : params_)
    if (p.name == name) return &p;
  return nullptr;
}
int Contract::input_index(std::string_view name) const {
  for (std::size_t i = 0; i < inputs_.size(); ++i)
    if (inputs_[i].name == name) return static_cast<int>(i);
  return -1;
}
int Contract::input_index(const void* key) const {
  for (std::size_t i = 0; i < inputs_.size(); ++i)
    if (inputs_[i].key == key) return static_cast<int>(i);
  return -1;
}
int Contract::output_index(const void* key) const {
  for (std::size_t i = 0; i < outputs_.size(); ++i)
    if (outputs_[i].key == key) return static_cast<int>(i);
  return -1;
}
int Contract::output_index(std::string_view name) const {
  for (std::size_t i = 0; i < outputs_.size(); ++i)
    if (outputs_[i].name == name) return static_cast<int>(i);
  return -1;
}

}  // namespace saccade
