#include "saccade/schema.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <memory>
#include <type_traits>

namespace saccade {
namespace {

void append_string(std::string& out, std::string_view text) {
  out += '"';
  for (const char c : text) {
    switch (c) {
      case '"': out += "\\\""; break;
      case '\\': out += "\\\\"; break;
      case '\n': out += "\\n"; break;
      case '\r': out += "\\r"; break;
      case '\t': out += "\\t"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20) {
          constexpr char kHex[] = "0123456789abcdef";
          out += "\\u00";
          out += kHex[(c >> 4) & 0xf];
          out += kHex[c & 0xf];
        } else {
          out += c;
        }
    }
  }
  out += '"';
}

template <class N>
void append_number(std::string& out, N v) {
  if constexpr (std::is_floating_point_v<N>) {
    if (!std::isfinite(v)) {
      out += "null";
      return;
    }
  }
  std::array<char, 32> buffer;
  const auto [end, ec] = std::to_chars(buffer.data(), buffer.data() + buffer.size(), v);
  out.append(buffer.data(), ec == std::errc() ? end : buffer.data());
}

// Appends `"name":` and what `write` makes of the field, for each of v's
// fields, separated by commas (one before the first too when `after_others`).
template <class V, class Write>
void append_members(std::string& out, const V& v, bool after_others, Write&& write) {
  bool first = !after_others;
  V::fields(v, [&](const char* name, const auto& field) {
    if (!first) out += ',';
    first = false;
    append_string(out, name);
    out += ':';
    write(field);
  });
}

// Writes one value as JSON; the overloads mirror the field types messages use.
struct JsonValue {
  std::string& out;

  void operator()(bool v) const { out += v ? "true" : "false"; }
  void operator()(const std::string& v) const { append_string(out, v); }
  template <class V>
  requires std::is_arithmetic_v<V>
  void operator()(V v) const {
    if constexpr (sizeof(V) == 1 && std::is_integral_v<V>)
      append_number(out, static_cast<int>(v));  // uint8_t as a number, not a character
    else
      append_number(out, v);
  }
  template <class V>
  requires std::is_enum_v<V>
  void operator()(V v) const {
    if constexpr (NamedEnum<V>)
      append_string(out, to_string(v));
    else
      append_number(out, static_cast<int64_t>(v));
  }
  template <class T>
  void operator()(const cv::Point_<T>& p) const {
    object<T>({{"x", p.x}, {"y", p.y}});
  }
  template <class T>
  void operator()(const cv::Size_<T>& s) const {
    object<T>({{"width", s.width}, {"height", s.height}});
  }
  template <class T>
  void operator()(const cv::Rect_<T>& r) const {
    object<T>({{"x", r.x}, {"y", r.y}, {"width", r.width}, {"height", r.height}});
  }
  template <class T, int N>
  void operator()(const cv::Vec<T, N>& v) const {
    sequence(v.val, v.val + N);
  }
  void operator()(const cv::Mat& m) const {
    out += "{\"rows\":";
    append_number(out, m.rows);
    out += ",\"cols\":";
    append_number(out, m.cols);
    out += ",\"depth\":";
    append_number(out, m.depth());
    out += ",\"channels\":";
    append_number(out, m.channels());
    out += '}';
  }
  template <class T>
  void operator()(const std::vector<T>& v) const {
    sequence(v.begin(), v.end());
  }
  template <class T, std::size_t N>
  void operator()(const std::array<T, N>& v) const {
    sequence(v.begin(), v.end());
  }
  template <class T>
  void operator()(const std::shared_ptr<const T>& p) const {
    if (p)
      (*this)(*p);
    else
      out += "null";
  }
  template <class V>
  requires Described<V>
  void operator()(const V& v) const {
    out += '{';
    append_members(out, v, false, *this);
    out += '}';
  }

 private:
  template <class It>
  void sequence(It begin, It end) const {
    out += '[';
    for (It it = begin; it != end; ++it) {
      if (it != begin) out += ',';
      (*this)(*it);
    }
    out += ']';
  }
  template <class T>
  void object(std::initializer_list<std::pair<const char*, T>> members) const {
    out += '{';
    bool first = true;
    for (const auto& [name, value] : members) {
      if (!first) out += ',';
      first = false;
      append_string(out, name);
      out += ':';
      (*this)(value);
    }
    out += '}';
  }
};

// The JSON Schema of one value type, from the same overloads' point of view.
struct SchemaOf {
  std::string& out;

  static std::string object_of(std::initializer_list<const char*> names, const char* type) {
    std::string s = "{\"type\":\"object\",\"properties\":{";
    bool first = true;
    for (const char* name : names) {
      s += first ? "" : ",";
      first = false;
      s += std::string("\"") + name + "\":{\"type\":\"" + type + "\"}";
    }
    return s + "}}";
  }

  void operator()(const bool&) const { out += R"({"type":"boolean"})"; }
  void operator()(const std::string&) const { out += R"({"type":"string"})"; }
  template <class V>
  requires std::is_arithmetic_v<V>
  void operator()(const V&) const {
    out += std::is_integral_v<V> ? R"({"type":"integer"})" : R"({"type":["number","null"]})";
  }
  template <class V>
  requires std::is_enum_v<V>
  void operator()(const V&) const { out += NamedEnum<V> ? R"({"type":"string"})" : R"({"type":"integer"})"; }
  template <class T>
  void operator()(const cv::Point_<T>&) const {
    out += object_of({"x", "y"}, std::is_integral_v<T> ? "integer" : "number");
  }
  template <class T>
  void operator()(const cv::Size_<T>&) const {
    out += object_of({"width", "height"}, std::is_integral_v<T> ? "integer" : "number");
  }
  template <class T>
  void operator()(const cv::Rect_<T>&) const {
    out += object_of({"x", "y", "width", "height"}, std::is_integral_v<T> ? "integer" : "number");
  }
  template <class T, int N>
  void operator()(const cv::Vec<T, N>&) const {
    out += R"({"type":"array","items":)";
    (*this)(T{});
    out += ",\"minItems\":" + std::to_string(N) + ",\"maxItems\":" + std::to_string(N) + "}";
  }
  void operator()(const cv::Mat&) const { out += object_of({"rows", "cols", "depth", "channels"}, "integer"); }
  template <class T>
  void operator()(const std::vector<T>&) const {
    out += R"({"type":"array","items":)";
    (*this)(T{});
    out += '}';
  }
  template <class T, std::size_t N>
  void operator()(const std::array<T, N>&) const {
    (*this)(std::vector<T>{});
  }
  template <class T>
  void operator()(const std::shared_ptr<const T>&) const {
    out += R"({"anyOf":[{"type":"null"},)";
    (*this)(T{});
    out += "]}";
  }
  template <class V>
  requires Described<V>
  void operator()(const V& v) const {
    out += R"({"type":"object","properties":{)";
    append_members(out, v, false, *this);
    out += "}}";
  }
};

void append_stamp(std::string& out, const Message& m) {
  out += "{\"type\":";
  append_string(out, m.type_name());
  out += ",\"frame\":";
  append_number(out, m.frame_id);
  out += ",\"stamp_ns\":";
  append_number(out, m.timestamp_ns);
  out += ",\"origin_ns\":";
  append_number(out, m.origin_ns);
}

template <class... T>
std::vector<std::string_view> type_names(TypeList<T...>) {
  return {T::kTypeName...};
}

template <class... T>
std::string schema_of(std::string_view type_name, TypeList<T...>) {
  std::string out;
  auto one = [&](auto* tag) {
    using M = std::remove_pointer_t<decltype(tag)>;
    if (type_name != M::kTypeName) return;
    out = R"({"$schema":"https://json-schema.org/draft/2020-12/schema","title":")" + std::string(M::kTypeName) +
          R"(","type":"object","properties":{"type":{"const":")" + std::string(M::kTypeName) +
          R"("},"frame":{"type":"integer"},"stamp_ns":{"type":"integer"},"origin_ns":{"type":"integer"})";
    const M defaults{};
    append_members(out, defaults, true, SchemaOf{out});
    out += R"(},"required":["type","frame","stamp_ns"]})";
  };
  (one(static_cast<T*>(nullptr)), ...);
  return out;
}

}  // namespace

std::vector<std::string_view> described_message_types() { return type_names(MessageTypes{}); }

void append_json(std::string& out, const Message& message) {
  append_stamp(out, message);
  visit_message(message, [&](const auto& m) { append_members(out, m, true, JsonValue{out}); });
  out += '}';
}

std::string json_schema(std::string_view type_name) { return schema_of(type_name, MessageTypes{}); }

}  // namespace saccade
