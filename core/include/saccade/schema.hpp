#pragma once
// Messages read through the fields each type names once (Message types'
// `fields`): as JSON, and the JSON Schema of each type, for the JSON lines
// sink, the docs and any tool that reads what saccade writes.
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "saccade/message.hpp"

namespace saccade {

template <class... T>
struct TypeList {};

// A type that names its fields (message.hpp's `fields`): the JSON writer, the
// CDR writer and reader and the IDL walk them.
template <class V>
concept Described = requires(const V& v) {
  V::fields(v, [](const char*, const auto&) {});
};
// An enum whose values have names (a to_string overload; "unknown" for any other value).
template <class E>
concept NamedEnum = std::is_enum_v<E> && requires(E e) {
  to_string(e);
};

// Every message type core defines: the one list the JSON writer, the schemas
// and their tests walk.
using MessageTypes = TypeList<Image, Retina, FeatureMaps, Motion, Region, StereoFixation, GazeRequest, JointState,
                              JointTargets, HeadPose, FoveaState, Classification, CanFrames>;

template <class F, class... T>
bool visit_message_as(const Message& message, F&& f, TypeList<T...>) {
  const std::string_view type = message.type_name();
  return ((type == T::kTypeName ? (f(static_cast<const T&>(message)), true) : false) || ...);
}

// Calls `f` with `message` as its concrete type; false for a type this
// version of saccade does not describe (a plugin's own Message subclass).
template <class F>
bool visit_message(const Message& message, F&& f) {
  return visit_message_as(message, std::forward<F>(f), MessageTypes{});
}

// The names of the message types visit_message knows, in its order.
std::vector<std::string_view> described_message_types();

// Appends `message` as one JSON object, without a newline:
//   {"type":"Region","frame":12,"stamp_ns":...,"origin_ns":...,<its fields>}
// Images and other matrices appear by shape ({"rows","cols","type","channels"}),
// not by pixels. Not-a-number and infinities are written as null. A type
// visit_message does not know gets its stamp alone. Reuses `out`'s capacity.
void append_json(std::string& out, const Message& message);

// The JSON Schema (draft 2020-12) of the objects append_json writes for
// `type_name`; empty for a type visit_message does not know.
std::string json_schema(std::string_view type_name);

}  // namespace saccade
