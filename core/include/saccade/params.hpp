#pragma once
// Parameters bound to the fields of a node's configuration struct, named once:
//
//   static void bind(ParamBinder<TrackerConfig>& b) {
//     b.field("template_size", "tracking template, pixels", &TrackerConfig::template_size)
//      .field("min_score", {-1, 1}, "a match below this is lost", &TrackerConfig::min_score)
//      .field("mode", {{"track", Mode::kTrack}, {"attend", Mode::kAttend}}, "what to do", &TrackerConfig::mode);
//   }
//   Contract("...").params(&bind)            // defaults from TrackerConfig{}
//   TrackerConfig c = ctx.config(&bind);     // in open(): the node's values
//
// The first argument is the name users write in XML; the last ones are the
// path to the field (&Outer::inner, &Inner::field for a nested struct). The
// default is the struct's, so the contract and the algorithm cannot disagree.
#include <charconv>
#include <initializer_list>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include "saccade/contract.hpp"
#include "saccade/status.hpp"

namespace saccade {

struct Range {
  double min;
  double max;
};

// One of the names a parameter takes, and the field value it stands for.
template <class V>
struct Choice {
  std::string_view name;
  V value;
};

namespace detail {

template <class Config, class... Path>
using field_t = std::remove_cvref_t<decltype((std::declval<Config&>().*....*std::declval<Path>()))>;

template <class F>
inline constexpr bool kPlainField = std::is_same_v<F, bool> || std::is_same_v<F, std::string> ||
                                    std::is_same_v<F, cv::Size> || std::is_same_v<F, cv::Point2d>;
template <class F>
inline constexpr bool kNumberField = std::is_arithmetic_v<F> && !std::is_same_v<F, bool>;

template <class Config, class... Path>
auto& field_at(Config& config, Path... path) {
  return (config.*....*path);
}

}  // namespace detail

template <class Config>
class ParamBinder {
 public:
  // Declares each field as a parameter of `contract`, its default from Config{}.
  explicit ParamBinder(Contract& contract) : contract_(&contract) {}
  // Loads each field of `config` from a node's validated `params`.
  ParamBinder(const Params& params, Config& config) : params_(&params), config_(&config) {}

  // A bool, text, size (WxH) or point (x,y) field.
  template <class... Path>
  requires detail::kPlainField<detail::field_t<Config, Path...>> ParamBinder& field(std::string_view name,
                                                                                    std::string_view doc,
                                                                                    Path... path) {
    using F = detail::field_t<Config, Path...>;
    bind<F>(name, doc, Range{}, {}, path...);
    return *this;
  }

  // A number, within `range`.
  template <class... Path>
  requires detail::kNumberField<detail::field_t<Config, Path...>> ParamBinder& field(std::string_view name, Range range,
                                                                                     std::string_view doc,
                                                                                     Path... path) {
    using F = detail::field_t<Config, Path...>;
    bind<F>(name, doc, range, {}, path...);
    return *this;
  }

  // A field of any type whose values have names (an enum, a mode as a bool).
  template <class... Path>
  ParamBinder& field(std::string_view name, std::initializer_list<Choice<detail::field_t<Config, Path...>>> choices,
                     std::string_view doc, Path... path) {
    using F = detail::field_t<Config, Path...>;
    bind<F>(name, doc, Range{}, std::vector<Choice<F>>(choices), path...);
    return *this;
  }

 private:
  template <class F>
  static F read(const Params& params, const std::string& name, const std::vector<Choice<F>>& choices) {
    if (!choices.empty()) {
      const std::string& text = params.get_string(name);
      for (const Choice<F>& c : choices)
        if (c.name == text) return c.value;
      throw std::logic_error("parameter '" + name + "' has no choice '" + text + "'");
    }
    if constexpr (!detail::kPlainField<F> && !detail::kNumberField<F>) {
      throw std::logic_error("parameter '" + name + "' has no choices");
    } else if constexpr (std::is_same_v<F, bool>) {
      return params.get_bool(name);
    } else if constexpr (std::is_integral_v<F>) {
      return static_cast<F>(params.get_int(name));
    } else if constexpr (std::is_floating_point_v<F>) {
      return static_cast<F>(params.get_double(name));
    } else if constexpr (std::is_same_v<F, std::string>) {
      return params.get_string(name);
    } else if constexpr (std::is_same_v<F, cv::Size>) {
      return params.get_size(name);
    } else {
      return params.get_point(name);
    }
  }

  template <class F>
  void declare(std::string name, std::string doc, const F& def, Range range, const std::vector<Choice<F>>& choices) {
    Contract& c = *contract_;
    if (!choices.empty()) {
      std::vector<std::string> names;
      std::string def_name;
      for (const Choice<F>& choice : choices) {
        names.emplace_back(choice.name);
        if (def_name.empty() && choice.value == def) def_name = choice.name;
      }
      if (def_name.empty()) c.add_problem("parameter '" + name + "': the struct's default is none of its choices");
      c.param_enum(std::move(name), std::move(def_name), std::move(names), std::move(doc));
      return;
    }
    if constexpr (!detail::kPlainField<F> && !detail::kNumberField<F>) {
      c.add_problem("parameter '" + name + "': a field of this type needs choices");
    } else if constexpr (std::is_same_v<F, bool>) {
      c.param_bool(std::move(name), def, std::move(doc));
    } else if constexpr (std::is_integral_v<F>) {
      c.param_int(std::move(name), static_cast<int64_t>(def), static_cast<int64_t>(range.min),
                  static_cast<int64_t>(range.max), std::move(doc));
    } else if constexpr (std::is_floating_point_v<F>) {
      c.param_double(std::move(name), as_written(def), range.min, range.max, std::move(doc));
    } else if constexpr (std::is_same_v<F, std::string>) {
      c.param_string(std::move(name), def, std::move(doc));
    } else if constexpr (std::is_same_v<F, cv::Size>) {
      c.param_size(std::move(name), def, std::move(doc));
    } else {
      c.param_point(std::move(name), def, std::move(doc));
    }
  }

  // A float's default as its own shortest text says it (0.2f as 0.2, not as
  // the double 0.20000000298023224), which reads back as the same float.
  template <class F>
  static double as_written(F value) {
    if constexpr (std::is_same_v<F, float>) {
      char text[32];
      const auto written = std::to_chars(text, text + sizeof text, value);
      double d = value;
      std::from_chars(text, written.ptr, d);
      return d;
    } else {
      return static_cast<double>(value);
    }
  }

  // The default as the contract writes it must read back as the struct's.
  template <class F>
  void check_round_trip(const F& def, const std::vector<Choice<F>>& choices) {
    Contract& c = *contract_;
    const ParamSpec& spec = c.params().back();
    ParamValue value;
    if (Status parsed = parse_param(spec, spec.default_value, value); !parsed.ok()) {
      c.add_problem("parameter '" + spec.name + "': default '" + spec.default_value + "': " + parsed.message());
      return;
    }
    Params one;
    one.set(spec.name, std::move(value));
    if (!(read<F>(one, spec.name, choices) == def))
      c.add_problem("parameter '" + spec.name + "': default '" + spec.default_value +
                    "' does not read back as the struct's value");
  }

  template <class F, class... Path>
  void bind(std::string_view name, std::string_view doc, Range range, const std::vector<Choice<F>>& choices,
            Path... path) {
    if (contract_ != nullptr) {
      const Config defaults{};
      const F& def = detail::field_at(defaults, path...);
      const std::size_t problems = contract_->problems().size();
      declare<F>(std::string(name), std::string(doc), def, range, choices);
      contract_->mark_last_param_bound();
      if (contract_->problems().size() == problems) check_round_trip<F>(def, choices);
    } else {
      detail::field_at(*config_, path...) = read<F>(*params_, std::string(name), choices);
    }
  }

  Contract* contract_ = nullptr;
  const Params* params_ = nullptr;
  Config* config_ = nullptr;
};

template <class Config>
Contract& Contract::params(void (*bind)(ParamBinder<Config>&)) {
  ParamBinder<Config> binder(*this);
  bind(binder);
  return *this;
}

// A Config at the struct's defaults changed by `settings` (name, value as a
// graph's XML writes it), each checked as a node's parameter is: for tools
// and tests that set an algorithm by its node's parameter names. An error
// names the setting that is unknown or does not fit.
template <class Config>
Result<Config> configure(void (*bind)(ParamBinder<Config>&),
                         const std::vector<std::pair<std::string, std::string>>& settings) {
  Contract contract;
  contract.params(bind);
  if (!contract.problems().empty()) return Status::error(contract.problems().front());
  Params params;
  if (Status read = read_params(contract, settings, params); !read.ok()) return read;
  Config config;
  ParamBinder<Config> loader(params, config);
  bind(loader);
  return config;
}

}  // namespace saccade
