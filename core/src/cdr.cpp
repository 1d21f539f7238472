#include "saccade/cdr.hpp"

#include <algorithm>
#include <bit>
#include <cstring>
#include <set>
#include <type_traits>

#include "saccade/schema.hpp"

namespace saccade::cdr {
namespace {

static_assert(std::endian::native == std::endian::little, "the CDR writer writes the host's bytes as little endian");

// Alignment counts from the end of the 4-byte encapsulation header.
constexpr std::size_t kHeader = 4;
constexpr uint8_t kLittleEndianHeader[kHeader] = {0x00, 0x01, 0x00, 0x00};

// The longest side a matrix read from CDR may have.
constexpr int kMaxMatSide = 1 << 16;

// The retina a message refers to, when its type has one.
template <class M>
concept CarriesRetina = requires(M& m) {
  { m.retina } -> std::convertible_to<std::shared_ptr<const Retina>>;
};

// Appends CDR, storing only what fits in `capacity` bytes (nothing when
// `data` is null: it then only counts them).
class Writer {
 public:
  Writer(uint8_t* data, std::size_t capacity) : data_(data), capacity_(capacity) {}

  void header() { bytes(kLittleEndianHeader, kHeader); }
  void align(std::size_t n) {
    const std::size_t pad = (n - (pos_ - kHeader) % n) % n;
    if (data_ != nullptr && pos_ + pad <= capacity_) std::memset(data_ + pos_, 0, pad);
    pos_ += pad;
  }
  template <class T>
  void primitive(T v) {
    align(sizeof(T));
    bytes(&v, sizeof(T));
  }
  void bytes(const void* p, std::size_t n) {
    if (data_ != nullptr && n > 0 && pos_ + n <= capacity_) std::memcpy(data_ + pos_, p, n);
    pos_ += n;
  }
  std::size_t size() const { return pos_; }

 private:
  uint8_t* data_;
  std::size_t capacity_;
  std::size_t pos_ = 0;
};

class Reader {
 public:
  Reader(const uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  bool header() {
    if (size_ < kHeader || data_[0] != 0 || data_[1] > 1)
      return fail("not CDR: no plain CDR encapsulation header (00 00 or 00 01) at the start");
    swap_ = data_[1] == 0;  // 00 00: big endian
    pos_ = kHeader;
    return true;
  }
  bool align(std::size_t n) {
    pos_ += (n - (pos_ - kHeader) % n) % n;
    return pos_ <= size_ || fail("ends inside its padding");
  }
  template <class T>
  bool primitive(T& v) {
    const uint8_t* p = take(sizeof(T), sizeof(T));
    if (p == nullptr) return false;
    std::memcpy(&v, p, sizeof(T));
    if (swap_) reverse(v);
    return true;
  }
  // `count` elements of `n` bytes each, aligned to n.
  template <class T>
  bool array(T* out, std::size_t count) {
    if (count == 0) return true;
    const uint8_t* p = take(sizeof(T) * count, sizeof(T));
    if (p == nullptr) return false;
    std::memcpy(out, p, sizeof(T) * count);
    if (swap_ && sizeof(T) > 1)
      for (std::size_t i = 0; i < count; ++i) reverse(out[i]);
    return true;
  }
  // A sequence's length, refused when even `min_bytes` per element would
  // run past the end (a hostile length must not make anyone allocate).
  bool length(uint32_t& n, std::size_t min_bytes) {
    if (!primitive(n)) return false;
    if (static_cast<std::size_t>(n) * std::max<std::size_t>(min_bytes, 1) > size_ - pos_)
      return fail("a sequence of " + std::to_string(n) + " elements in " + std::to_string(size_ - pos_) +
                  " bytes left");
    return true;
  }
  const uint8_t* take(std::size_t n, std::size_t alignment = 1) {
    if (!align(alignment)) return nullptr;
    if (n > size_ - pos_) {
      fail("too short: " + std::to_string(n) + " more bytes wanted at byte " + std::to_string(pos_) + " of " +
           std::to_string(size_));
      return nullptr;
    }
    const uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }
  std::size_t position() const { return pos_; }
  void rewind(std::size_t pos) { pos_ = pos; }

  bool fail(std::string why) {
    if (why_.empty()) why_ = std::move(why);
    return false;
  }
  const std::string& why() const { return why_; }
  void set_field(const char* name) { field_ = name; }
  const char* field() const { return field_; }

 private:
  template <class T>
  static void reverse(T& v) {
    auto* b = reinterpret_cast<uint8_t*>(&v);
    std::reverse(b, b + sizeof(T));
  }

  const uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
  bool swap_ = false;
  std::string why_;
  const char* field_ = "";
};

// --- writing: one overload per kind of field messages use ---

struct Write {
  Writer& w;

  void operator()(const bool& v) const { w.primitive<uint8_t>(v ? 1 : 0); }
  template <class V>
  requires std::is_arithmetic_v<V>
  void operator()(const V& v) const { w.primitive(v); }
  template <class E>
  requires std::is_enum_v<E>
  void operator()(const E& v) const {
    static_assert(sizeof(E) == 1, "enums travel as one octet");
    w.primitive(static_cast<uint8_t>(v));
  }
  void operator()(const std::string& v) const {
    w.primitive(static_cast<uint32_t>(v.size() + 1));
    w.bytes(v.data(), v.size());
    w.primitive<uint8_t>(0);
  }
  template <class T>
  void operator()(const cv::Point_<T>& p) const {
    w.primitive(p.x);
    w.primitive(p.y);
  }
  template <class T>
  void operator()(const cv::Size_<T>& s) const {
    w.primitive(s.width);
    w.primitive(s.height);
  }
  template <class T>
  void operator()(const cv::Rect_<T>& r) const {
    w.primitive(r.x);
    w.primitive(r.y);
    w.primitive(r.width);
    w.primitive(r.height);
  }
  template <class T, int N>
  void operator()(const cv::Vec<T, N>& v) const {
    for (int i = 0; i < N; ++i) w.primitive(v[i]);
  }
  template <class T, std::size_t N>
  void operator()(const std::array<T, N>& v) const {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      w.align(sizeof(T));
      w.bytes(v.data(), sizeof(T) * N);
    } else {
      for (const T& e : v) (*this)(e);
    }
  }
  // rows, cols, OpenCV's type code, then the pixels as a sequence of octets,
  // rows packed without padding.
  void operator()(const cv::Mat& m) const {
    const bool empty = m.empty() || m.dims > 2;
    w.primitive<int32_t>(empty ? 0 : m.rows);
    w.primitive<int32_t>(empty ? 0 : m.cols);
    w.primitive<int32_t>(m.type());
    const std::size_t row_bytes = empty ? 0 : static_cast<std::size_t>(m.cols) * m.elemSize();
    w.primitive(static_cast<uint32_t>(row_bytes * static_cast<std::size_t>(empty ? 0 : m.rows)));
    if (empty) return;
    if (m.isContinuous())
      w.bytes(m.data, row_bytes * static_cast<std::size_t>(m.rows));
    else
      for (int r = 0; r < m.rows; ++r) w.bytes(m.ptr(r), row_bytes);
  }
  template <class T>
  void operator()(const std::vector<T>& v) const {
    w.primitive(static_cast<uint32_t>(v.size()));
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      if (v.empty()) return;
      w.align(sizeof(T));
      w.bytes(v.data(), v.size() * sizeof(T));
    } else {
      for (const T& e : v) (*this)(e);
    }
  }
  template <class T>
  void operator()(const std::shared_ptr<const std::vector<T>>& p) const {
    if (p)
      (*this)(*p);
    else
      w.primitive<uint32_t>(0);
  }
  template <class V>
  requires Described<V>
  void operator()(const V& v) const {
    V::fields(v, [this](const char*, const auto& field) { (*this)(field); });
  }
};

// --- reading: the same kinds, each checked ---

// An enum value is one its type names (to_string gives "unknown" for any other).
template <class E>
bool known(E e) {
  const char* name = to_string(e);
  return std::strcmp(name, "unknown") != 0;
}

struct Read {
  Reader& r;

  bool operator()(bool& v) const {
    uint8_t b = 0;
    if (!r.primitive(b)) return false;
    if (b > 1) return r.fail(std::string(r.field()) + ": a boolean of " + std::to_string(b));
    v = b == 1;
    return true;
  }
  template <class V>
  requires std::is_arithmetic_v<V>
  bool operator()(V& v) const { return r.primitive(v); }
  template <class E>
  requires std::is_enum_v<E>
  bool operator()(E& v) const {
    uint8_t b = 0;
    if (!r.primitive(b)) return false;
    v = static_cast<E>(b);
    if constexpr (NamedEnum<E>)
      if (!known(v)) return r.fail(std::string(r.field()) + ": " + std::to_string(b) + " is not a value it names");
    return true;
  }
  bool operator()(std::string& v) const {
    uint32_t n = 0;
    if (!r.length(n, 1)) return false;
    const uint8_t* p = r.take(n);
    if (p == nullptr) return false;
    // The length counts the terminating NUL; a writer that sent none (0) is read as empty.
    const std::size_t chars = n > 0 && p[n - 1] == 0 ? n - 1 : n;
    v.assign(reinterpret_cast<const char*>(p), chars);
    return true;
  }
  template <class T>
  bool operator()(cv::Point_<T>& p) const {
    return r.primitive(p.x) && r.primitive(p.y);
  }
  template <class T>
  bool operator()(cv::Size_<T>& s) const {
    return r.primitive(s.width) && r.primitive(s.height);
  }
  template <class T>
  bool operator()(cv::Rect_<T>& v) const {
    return r.primitive(v.x) && r.primitive(v.y) && r.primitive(v.width) && r.primitive(v.height);
  }
  template <class T, int N>
  bool operator()(cv::Vec<T, N>& v) const {
    return r.array(v.val, N);
  }
  template <class T, std::size_t N>
  bool operator()(std::array<T, N>& v) const {
    return elements(v.data(), N);
  }
  bool operator()(cv::Mat& m) const;
  template <class T>
  bool operator()(std::vector<T>& v) const {
    uint32_t n = 0;
    if (!r.length(n, min_bytes<T>())) return false;
    v.resize(n);
    return elements(v.data(), n);
  }
  // Class names rarely change: the names a message already holds are kept
  // (still shared with earlier messages) when the bytes say the same.
  bool operator()(std::shared_ptr<const std::vector<std::string>>& p) const {
    const std::size_t start = r.position();
    uint32_t n = 0;
    if (!r.length(n, 5)) return false;
    if (p && p->size() == n && same_strings(*p)) return true;
    r.rewind(start);
    auto fresh = std::make_shared<std::vector<std::string>>();
    if (!(*this)(*fresh)) return false;
    p = std::move(fresh);
    return true;
  }
  template <class V>
  requires Described<V>
  bool operator()(V& v) const {
    bool ok = true;
    V::fields(v, [&](const char*, auto& field) { ok = ok && (*this)(field); });
    return ok;
  }

  // The least bytes one element of T takes, to bound a sequence's length.
  template <class T>
  static constexpr std::size_t min_bytes() {
    if constexpr (std::is_arithmetic_v<T> || std::is_enum_v<T>) return sizeof(T);
    if constexpr (std::is_same_v<T, std::string>) return 5;
    if constexpr (std::is_same_v<T, cv::Mat>) return 16;
    return 1;
  }

 private:
  // n elements in a row: numbers at once, anything else one by one.
  template <class T>
  bool elements(T* data, std::size_t n) const {
    if constexpr (std::is_arithmetic_v<T> && !std::is_same_v<T, bool>) {
      return r.array(data, n);
    } else {
      for (std::size_t i = 0; i < n; ++i)
        if (!(*this)(data[i])) return false;
      return true;
    }
  }

  bool same_strings(const std::vector<std::string>& names) const {
    for (const std::string& name : names) {
      uint32_t n = 0;
      if (!r.length(n, 1)) return false;
      const uint8_t* p = r.take(n);
      if (p == nullptr) return false;
      const std::size_t chars = n > 0 && p[n - 1] == 0 ? n - 1 : n;
      if (std::string_view(reinterpret_cast<const char*>(p), chars) != name) return false;
    }
    return true;
  }
};

bool Read::operator()(cv::Mat& m) const {
  int32_t rows = 0, cols = 0, type = 0;
  uint32_t n = 0;
  if (!r.primitive(rows) || !r.primitive(cols) || !r.primitive(type) || !r.length(n, 1)) return false;
  const uint8_t* p = r.take(n);
  if (p == nullptr) return false;
  if (rows == 0 || cols == 0) {
    if (n != 0) return r.fail(std::string(r.field()) + ": an empty matrix with " + std::to_string(n) + " bytes");
    m.release();
    return true;
  }
  // A header no Mat can have (an element type OpenCV does not know, sides
  // past a limit) must not make OpenCV throw or allocate without bound.
  if (rows < 0 || cols < 0 || rows > kMaxMatSide || cols > kMaxMatSide || type < 0 || CV_MAT_DEPTH(type) > CV_16F ||
      type != CV_MAKETYPE(CV_MAT_DEPTH(type), CV_MAT_CN(type)))
    return r.fail(std::string(r.field()) + ": no matrix is " + std::to_string(rows) + "x" + std::to_string(cols) +
                  " of type " + std::to_string(type));
  const std::size_t bytes = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols) * CV_ELEM_SIZE(type);
  if (bytes != n)
    return r.fail(std::string(r.field()) + ": a " + std::to_string(rows) + "x" + std::to_string(cols) +
                  " matrix of type " + std::to_string(type) + " is " + std::to_string(bytes) + " bytes, not " +
                  std::to_string(n));
  make_exclusive(m);
  m.create(rows, cols, type);
  std::memcpy(m.data, p, bytes);
  return true;
}

void write_stamp(Writer& w, const Message& m, const Envelope& e) {
  w.primitive(m.timestamp_ns);
  w.primitive(m.origin_ns);
  w.primitive(m.frame_id);
  w.primitive(e.flags);
  w.primitive(e.mailbox);
  w.primitive(e.post);
}

bool read_stamp(Reader& r, Message& m, Envelope& e) {
  return r.primitive(m.timestamp_ns) && r.primitive(m.origin_ns) && r.primitive(m.frame_id) && r.primitive(e.flags) &&
         r.primitive(e.mailbox) && r.primitive(e.post);
}

// A Retina inside another message: its stamp and fields, no header.
void write_message_body(Writer& w, const Retina& retina) {
  write_stamp(w, retina, Envelope{});
  Write write{w};
  Retina::fields(retina, [&](const char*, const auto& field) { write(field); });
}

template <class M>
void write_message(Writer& w, const M& m, const Envelope& e) {
  w.header();
  write_stamp(w, m, e);
  Write write{w};
  M::fields(m, [&](const char*, const auto& field) { write(field); });
  if constexpr (CarriesRetina<M>) {
    w.primitive<uint32_t>(m.retina ? 1 : 0);
    if (m.retina) write_message_body(w, *m.retina);
  }
}

bool read_retina(Reader& r, std::shared_ptr<const Retina>& out, std::shared_ptr<Retina>* spare) {
  uint32_t n = 0;
  if (!r.length(n, 48)) return false;
  if (n > 1) return r.fail("retina: a sequence of at most one, not " + std::to_string(n));
  if (n == 0) {
    out.reset();
    return true;
  }
  std::shared_ptr<Retina> retina;
  if (spare != nullptr && *spare && spare->use_count() == 1)
    retina = *spare;
  else
    retina = std::make_shared<Retina>();
  if (spare != nullptr) *spare = retina;
  Envelope ignored;
  if (!read_stamp(r, *retina, ignored)) return false;
  Read read{r};
  bool ok = true;
  Retina::fields(*retina, [&](const char* name, auto& field) {
    r.set_field(name);
    ok = ok && read(field);
  });
  retina->source.reset();  // the frame itself does not travel
  out = std::move(retina);
  return ok;
}

template <class M>
bool read_message(Reader& r, M& m, Envelope& e, std::shared_ptr<Retina>* spare) {
  if (!r.header() || !read_stamp(r, m, e)) return false;
  Read read{r};
  bool ok = true;
  M::fields(m, [&](const char* name, auto& field) {
    r.set_field(name);
    ok = ok && read(field);
  });
  if constexpr (std::is_same_v<M, Retina>) m.source.reset();
  if constexpr (CarriesRetina<M>) ok = ok && read_retina(r, m.retina, spare);
  return ok;
}

// --- the IDL of the same bytes ---

// A member's IDL type, and what follows its name (an array's bounds).
struct IdlType {
  std::string type;
  std::string suffix;
};

class Idl {
 public:
  // Appends every described message type to `out`.
  template <class... T>
  std::string all(TypeList<T...>) {
    (message<T>(), ...);
    std::string out =
        "// saccade's messages as they travel in CDR (DDS, MCAP's cdr channels, the live view).\n"
        "// Generated from core/include/saccade/message.hpp by `saccade idl`: do not edit;\n"
        "// test Idl.TheCommittedFileIsWhatSaccadeWrites fails when it differs from what saccade writes.\n"
        "module saccade_idl {\n"
        "  // Building blocks; their own module, since IDL names are case-insensitive and\n"
        "  // a member may not share a type's name in one scope.\n"
        "  module common {\n"
        "    // Message::timestamp_ns, origin_ns and frame_id, and what the stream adds.\n"
        "    struct Stamp {\n"
        "      long long timestamp_ns;  // capture time of the frame it derives from\n"
        "      long long origin_ns;     // steady clock of the process that captured it\n"
        "      long long frame_id;\n"
        "      unsigned long flags;     // bit 0: end of stream (the producer has finished)\n"
        "      unsigned long long mailbox;  // the writer's same-host mailbox; 0: none. Not part of the message\n"
        "      unsigned long long post;     // this message's post number there\n"
        "    };\n";
    out += common_;
    out += "  };\n";
    out += messages_;
    out += "};\n";
    return out;
  }

  IdlType operator()(const bool&) { return {"boolean", ""}; }
  IdlType operator()(const int32_t&) { return {"long", ""}; }
  IdlType operator()(const int64_t&) { return {"long long", ""}; }
  IdlType operator()(const uint8_t&) { return {"octet", ""}; }
  IdlType operator()(const uint16_t&) { return {"unsigned short", ""}; }
  IdlType operator()(const uint32_t&) { return {"unsigned long", ""}; }
  IdlType operator()(const uint64_t&) { return {"unsigned long long", ""}; }
  IdlType operator()(const float&) { return {"float", ""}; }
  IdlType operator()(const double&) { return {"double", ""}; }
  template <class E>
  requires std::is_enum_v<E> IdlType operator()(const E&) { return {"octet", ""}; }
  IdlType operator()(const std::string&) { return {"string", ""}; }
  template <class T>
  IdlType operator()(const cv::Point_<T>&) {
    return pair<T>(std::is_integral_v<T> ? "Point2i" : "Point2d", "x", "y");
  }
  template <class T>
  IdlType operator()(const cv::Size_<T>&) {
    return pair<T>(std::is_integral_v<T> ? "Size2i" : "Size2d", "width", "height");
  }
  template <class T>
  IdlType operator()(const cv::Rect_<T>&) {
    const std::string element = (*this)(T{}).type;
    const std::string name = std::is_integral_v<T> ? "Rect2i" : "Rect2d";
    define(name, "    struct " + name + " { " + element + " x; " + element + " y; " + element + " width; " + element +
                     " height; };\n");
    return {"common::" + name, ""};
  }
  template <class T, int N>
  IdlType operator()(const cv::Vec<T, N>&) {
    return {(*this)(T{}).type, "[" + std::to_string(N) + "]"};
  }
  template <class T, std::size_t N>
  IdlType operator()(const std::array<T, N>&) {
    return {(*this)(T{}).type, "[" + std::to_string(N) + "]"};
  }
  IdlType operator()(const cv::Mat&) {
    define("Mat",
           "    // A cv::Mat: rows x cols of OpenCV type `cv_type` (CV_8UC1 = 0, CV_32FC1 = 5, ...),\n"
           "    // rows packed without padding.\n"
           "    struct Mat { long rows; long cols; long cv_type; sequence<octet> data; };\n");
    return {"common::Mat", ""};
  }
  template <class T>
  IdlType operator()(const std::vector<T>&) {
    const IdlType element = (*this)(T{});
    if (element.type.starts_with("sequence<")) {
      // A sequence of sequences, through a named one (not every IDL reader takes them nested).
      std::string inner = element.type.substr(9, element.type.size() - 10);
      if (inner.starts_with("common::")) inner = inner.substr(8);
      const std::string name = inner + "Sequence";
      define(name, "    typedef " + element.type + " " + name + ";\n");
      return {"sequence<common::" + name + ">", ""};
    }
    return {"sequence<" + element.type + ">", ""};
  }
  template <class T>
  IdlType operator()(const std::shared_ptr<const T>&) {
    return (*this)(T{});
  }
  template <class V>
  requires Described<V> IdlType operator()(const V& v) {
    const std::string name(V::kTypeName);
    if (!defined_.contains(name)) {
      std::string body = "    struct " + name + " {\n" + members(v, "      ") + "    };\n";
      define(name, body);
    }
    return {"common::" + name, ""};
  }

 private:
  template <class M>
  void message() {
    const M defaults{};
    std::string body = "  struct " + std::string(M::kTypeName) + " {\n    common::Stamp stamp;\n";
    body += members(defaults, "    ");
    if constexpr (CarriesRetina<M>)
      body += "    sequence<Retina, 1> source_retina;  // the retina it was computed on\n";
    messages_ += body + "  };\n\n";
  }

  template <class V>
  std::string members(const V& v, const char* indent) {
    std::string out;
    V::fields(v, [&](const char* name, const auto& field) {
      const IdlType t = (*this)(field);
      out += indent + t.type + " " + name + t.suffix + ";" + enum_comment(field) + "\n";
    });
    return out;
  }

  // The values an enum's octet takes, by name.
  template <class F>
  static std::string enum_comment(const std::vector<F>&) {
    return enum_comment(F{});
  }
  template <class F>
  static std::string enum_comment(const F&) {
    if constexpr (NamedEnum<F>) {
      std::string out = "  //";
      for (int v = 0; v < 256; ++v) {
        if (!known(static_cast<F>(v))) break;
        out += (v == 0 ? " " : ", ") + std::to_string(v) + " " + to_string(static_cast<F>(v));
      }
      return out;
    } else {
      return "";
    }
  }

  template <class T>
  IdlType pair(const std::string& name, const char* a, const char* b) {
    const std::string element = (*this)(T{}).type;
    define(name, "    struct " + name + " { " + element + " " + a + "; " + element + " " + b + "; };\n");
    return {"common::" + name, ""};
  }

  void define(const std::string& name, const std::string& text) {
    if (defined_.insert(name).second) common_ += text;
  }

  std::set<std::string> defined_;
  std::string common_;
  std::string messages_;
};

}  // namespace

template <class M>
std::size_t size_of(const M& message) {
  Writer counter(nullptr, 0);
  write_message(counter, message, Envelope{});
  return counter.size();
}

// One walk: the Writer stores only what fits, so a message larger than
// `capacity` is found at its end, without counting it first.
template <class M>
std::size_t write(const M& message, const Envelope& envelope, uint8_t* out, std::size_t capacity) {
  Writer writer(out, capacity);
  write_message(writer, message, envelope);
  return writer.size() <= capacity ? writer.size() : 0;
}

template <class M>
void write(const M& message, const Envelope& envelope, std::vector<uint8_t>& out) {
  out.resize(size_of(message));
  Writer writer(out.data(), out.size());
  write_message(writer, message, envelope);
}

template <class M>
Status read(const uint8_t* data, std::size_t size, M& out, Envelope& envelope, std::shared_ptr<Retina>* spare) {
  Reader reader(data, size);
  if (read_message(reader, out, envelope, spare)) return {};
  return Status::error(std::string("not a ") + std::string(M::kTypeName) + ": " + reader.why());
}

const std::string& idl() {
  static const std::string text = Idl().all(MessageTypes{});
  return text;
}

std::string idl_type_name(std::string_view type) { return "saccade_idl::" + std::string(type); }

namespace {

template <class M>
std::string idl_of_type() {
  if constexpr (CarriesRetina<M>)
    return Idl().all(TypeList<Retina, M>{});
  else
    return Idl().all(TypeList<M>{});
}

template <class... T>
std::string idl_of_as(std::string_view type, TypeList<T...>) {
  std::string out;
  (void)((type == T::kTypeName ? (out = idl_of_type<T>(), true) : false) || ...);
  return out;
}

}  // namespace

std::string idl_of(std::string_view type) { return idl_of_as(type, MessageTypes{}); }

uint64_t schema_fingerprint(std::string_view type) {
  const std::string text = idl_of(type);
  if (text.empty()) return 0;
  // The declarations alone: a comment's wording is not the layout. (The
  // enum values' names live in comments: their numbers are octets, and a
  // renamed value reads the same.)
  uint64_t hash = 14695981039346656037ull;
  bool comment = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (!comment && text.compare(i, 2, "//") == 0) comment = true;
    if (text[i] == '\n') comment = false;
    if (comment) continue;
    hash = (hash ^ static_cast<uint8_t>(text[i])) * 1099511628211ull;
  }
  return hash;
}

// One instantiation per described message type.
#define SACCADE_CDR_FOR(M)                                                         \
  template std::size_t size_of<M>(const M&);                                       \
  template std::size_t write<M>(const M&, const Envelope&, uint8_t*, std::size_t); \
  template void write<M>(const M&, const Envelope&, std::vector<uint8_t>&);        \
  template Status read<M>(const uint8_t*, std::size_t, M&, Envelope&, std::shared_ptr<Retina>*);
SACCADE_CDR_FOR(Image)
SACCADE_CDR_FOR(Retina)
SACCADE_CDR_FOR(FeatureMaps)
SACCADE_CDR_FOR(Motion)
SACCADE_CDR_FOR(Region)
SACCADE_CDR_FOR(StereoFixation)
SACCADE_CDR_FOR(GazeRequest)
SACCADE_CDR_FOR(JointState)
SACCADE_CDR_FOR(JointTargets)
SACCADE_CDR_FOR(HeadPose)
SACCADE_CDR_FOR(FoveaState)
SACCADE_CDR_FOR(Classification)
SACCADE_CDR_FOR(CanFrames)
#undef SACCADE_CDR_FOR

}  // namespace saccade::cdr
