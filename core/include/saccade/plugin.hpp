#pragma once
// The one entry a plugin library exports: SACCADE_PLUGIN("lib", NodeA, NodeB, ...).
// Each node class provides `static saccade::Contract contract()` and a short
// `static constexpr const char* kName` (the type is "<lib>.<kName>", or "<lib>"
// when kName is empty).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include <boost/dll/alias.hpp>

#include "saccade/node.hpp"

namespace saccade {

// Bumped whenever Node, Contract, messages or the descriptor change layout.
inline constexpr uint32_t kAbiVersion = 9;

// Stamped into every plugin at its build and compared by the host at load.
struct AbiStamp {
  uint32_t abi_version;
  uint32_t compiler_major;
  uint32_t cxx11_abi;
  uint32_t sizeof_contract;
  uint32_t sizeof_node_slot;
  uint32_t sizeof_image;
  bool operator==(const AbiStamp&) const = default;
};

constexpr AbiStamp current_abi_stamp() {
  return {kAbiVersion,
          static_cast<uint32_t>(__GNUC__),
          static_cast<uint32_t>(_GLIBCXX_USE_CXX11_ABI),
          static_cast<uint32_t>(sizeof(Contract)),
          static_cast<uint32_t>(sizeof(NodeSlot)),
          static_cast<uint32_t>(sizeof(Image))};
}

struct NodeFactory {
  const char* name;  // short name inside the library ("" = the library's own name)
  Contract (*contract)();
  Result<Node*> (*create)() noexcept;  // a new node, or why there is none
  void (*destroy)(Node*) noexcept;
};

struct PluginDescriptor {
  AbiStamp abi;
  const char* library;
  const NodeFactory* factories;
  std::size_t count;
};

namespace detail {

// Wraps a node so that no exception leaves the plugin library: this template is
// instantiated inside the plugin, so its try/catch is the plugin's.
template <class T>
class Guarded final : public Node {
 public:
  Status open(OpenContext& ctx) override {
    try {
      return inner_.open(ctx);
    } catch (const std::exception& e) { return Status::error(std::string("open threw: ") + e.what()); } catch (...) {
      return Status::error("open threw a non-standard exception");
    }
  }
  Status process(ProcessContext& ctx) override {
    try {
      return inner_.process(ctx);
    } catch (const std::exception& e) { return Status::error(std::string("process threw: ") + e.what()); } catch (...) {
      return Status::error("process threw a non-standard exception");
    }
  }
  void inputs_ended() override {
    try {
      inner_.inputs_ended();
    } catch (...) {}
  }
  void close() override {
    try {
      inner_.close();
    } catch (...) {}
  }

 private:
  T inner_;
};

template <class T>
NodeFactory make_factory() {
  return NodeFactory{
      T::kName,
      +[]() { return T::contract(); },
      +[]() noexcept -> Result<Node*> {
        try {
          return static_cast<Node*>(new Guarded<T>());
        } catch (const std::exception& e) { return Status::error(e.what()); }
      },
      +[](Node* node) noexcept { delete node; },
  };
}

}  // namespace detail
}  // namespace saccade

#define SACCADE_PLUGIN(LIBRARY, ...)                                                                           \
  namespace saccade_plugin_entry_ns {                                                                          \
  static const ::saccade::NodeFactory kFactories[] = {SACCADE_PLUGIN_FACTORIES_(__VA_ARGS__)};                 \
  static const ::saccade::PluginDescriptor kDescriptor = {::saccade::current_abi_stamp(), LIBRARY, kFactories, \
                                                          sizeof(kFactories) / sizeof(kFactories[0])};         \
  const ::saccade::PluginDescriptor* saccade_plugin_entry() { return &kDescriptor; }                           \
  }                                                                                                            \
  BOOST_DLL_ALIAS_SECTIONED(saccade_plugin_entry_ns::saccade_plugin_entry, saccade_plugin_entry, saccade)

#define SACCADE_PLUGIN_F1_(T) ::saccade::detail::make_factory<T>()
#define SACCADE_PLUGIN_FACTORIES_(...) SACCADE_PLUGIN_MAP_(SACCADE_PLUGIN_F1_, __VA_ARGS__)
// A small for-each over up to 16 node classes.
#define SACCADE_PLUGIN_MAP_(F, ...)                                                                                    \
  SACCADE_PLUGIN_GET_(__VA_ARGS__, SACCADE_M16_, SACCADE_M15_, SACCADE_M14_, SACCADE_M13_, SACCADE_M12_, SACCADE_M11_, \
                      SACCADE_M10_, SACCADE_M9_, SACCADE_M8_, SACCADE_M7_, SACCADE_M6_, SACCADE_M5_, SACCADE_M4_,      \
                      SACCADE_M3_, SACCADE_M2_, SACCADE_M1_)                                                           \
  (F, __VA_ARGS__)
#define SACCADE_PLUGIN_GET_(_1, _2, _3, _4, _5, _6, _7, _8, _9, _10, _11, _12, _13, _14, _15, _16, NAME, ...) NAME
#define SACCADE_M1_(F, x) F(x)
#define SACCADE_M2_(F, x, ...) F(x), SACCADE_M1_(F, __VA_ARGS__)
#define SACCADE_M3_(F, x, ...) F(x), SACCADE_M2_(F, __VA_ARGS__)
#define SACCADE_M4_(F, x, ...) F(x), SACCADE_M3_(F, __VA_ARGS__)
#define SACCADE_M5_(F, x, ...) F(x), SACCADE_M4_(F, __VA_ARGS__)
#define SACCADE_M6_(F, x, ...) F(x), SACCADE_M5_(F, __VA_ARGS__)
#define SACCADE_M7_(F, x, ...) F(x), SACCADE_M6_(F, __VA_ARGS__)
#define SACCADE_M8_(F, x, ...) F(x), SACCADE_M7_(F, __VA_ARGS__)
#define SACCADE_M9_(F, x, ...) F(x), SACCADE_M8_(F, __VA_ARGS__)
#define SACCADE_M10_(F, x, ...) F(x), SACCADE_M9_(F, __VA_ARGS__)
#define SACCADE_M11_(F, x, ...) F(x), SACCADE_M10_(F, __VA_ARGS__)
#define SACCADE_M12_(F, x, ...) F(x), SACCADE_M11_(F, __VA_ARGS__)
#define SACCADE_M13_(F, x, ...) F(x), SACCADE_M12_(F, __VA_ARGS__)
#define SACCADE_M14_(F, x, ...) F(x), SACCADE_M13_(F, __VA_ARGS__)
#define SACCADE_M15_(F, x, ...) F(x), SACCADE_M14_(F, __VA_ARGS__)
#define SACCADE_M16_(F, x, ...) F(x), SACCADE_M15_(F, __VA_ARGS__)
