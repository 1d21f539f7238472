// mcap.record and mcap.replay: a graph's messages to an MCAP file and back.
#include <map>
#include <mutex>

#include "recording.hpp"
#include "saccade/log.hpp"
#include "saccade/plugin.hpp"

namespace {

using namespace saccade;

// The files record nodes write, by path: the nodes of one path share one
// file (one channel each); the last node to close it writes its summary. An
// error when the file cannot be written, or another node writes it with
// other options.
Result<std::shared_ptr<mcap::MessageFile>> shared_file(const std::string& path, const mcap::WriterOptions& options) {
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<mcap::MessageFile>> files;
  std::lock_guard lock(mutex);
  if (auto existing = files[path].lock()) {
    if (existing->options().compression != options.compression || existing->options().chunk_size != options.chunk_size)
      return Status::error("another mcap.record node writes '" + path + "' with compression " +
                           mcap::to_string(existing->options().compression) + " and chunk size " +
                           std::to_string(existing->options().chunk_size) + ": give every node of one file the same");
    return existing;
  }
  auto file = std::make_shared<mcap::MessageFile>();
  if (Status opened = file->open(path, options); !opened.ok()) return opened;
  files[path] = file;
  return file;
}

struct RecordConfig {
  std::string path;
  std::string topic;
  std::string compression = "zstd";
  int64_t chunk_kib = 1024;
};

class Record final : public Node {
 public:
  static constexpr const char* kName = "record";
  static constexpr In<Message> kIn{"in", "any message: its channel's type is the first message's"};

  static Contract contract() {
    return Contract(
               "Writes every message it receives to an MCAP file (Foxglove, rosbag2, PlotJuggler read it): one "
               "channel, the topic named by 'topic', log time = the message's timestamp. Record nodes with the same "
               "path share one file, one channel each. Images and joint states as ROS 2 sensor_msgs, other types as "
               "saccade's IDL type (docs/recording.md). Give its edge queue=\"block:N\" to record every message.")
        .ports(kIn)
        .required_string("path", "MCAP file to write (created or truncated; its folder is made)")
        .param_string(
            "topic", "",
            "the channel's topic (default: /<node name>); name it after the recorded port, e.g. /retina/retina")
        .param_enum("compression", "zstd", {"none", "zstd", "lz4"}, "chunk compression")
        .param_int("chunk_kib", 1024, 0, 1 << 20, "chunk size in KiB before compression (0: no chunks, no index)");
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    mcap::WriterOptions options;
    mcap::parse_compression(p.get_string("compression"), options.compression);
    options.chunk_size = static_cast<std::size_t>(p.get_int("chunk_kib")) * 1024;
    Result<std::shared_ptr<mcap::MessageFile>> file = shared_file(p.get_string("path"), options);
    if (!file.ok()) return file.status();
    file_ = std::move(file).value();
    const std::string topic = p.get_string("topic").empty() ? "/" + ctx.node_name() : p.get_string("topic");
    topic_ = file_->topic(topic, {{"node", ctx.node_name()}});
    write_errors_ = &ctx.counter("write_errors");
    return {};
  }
  Status process(ProcessContext& ctx) override {
    if (Status written = file_->write(topic_, *ctx.get(kIn)); !written.ok()) {
      if (write_errors_->fetch_add(1, std::memory_order_relaxed) == 0)
        log().warn("{}: {}", ctx.node_name(), written.message());
    }
    return {};
  }
  void close() override {
    if (file_.use_count() == 1) {
      if (Status closed = file_->close(); !closed.ok()) log().error("mcap.record: {}", closed.message());
    }
    file_.reset();
  }

 private:
  std::shared_ptr<mcap::MessageFile> file_;
  mcap::MessageFile::Topic* topic_ = nullptr;
  std::atomic<uint64_t>* write_errors_ = nullptr;
};

// The steady time a file's replay started, shared by the replay nodes of one
// path while any of them is open, so that their topics keep their recorded
// spacing to each other.
struct Anchors {
  std::mutex mutex;
  std::map<std::string, std::pair<int, int64_t>> by_path;  // users, start (0: not started)
  static Anchors& instance() {
    static Anchors anchors;
    return anchors;
  }
  void join(const std::string& path) {
    std::lock_guard lock(mutex);
    ++by_path[path].first;
  }
  void leave(const std::string& path) {
    std::lock_guard lock(mutex);
    auto it = by_path.find(path);
    if (it != by_path.end() && --it->second.first <= 0) by_path.erase(it);
  }
  int64_t start(const std::string& path) {
    std::lock_guard lock(mutex);
    auto& entry = by_path[path];
    if (entry.second == 0) entry.second = steady_now_ns();
    return entry.second;
  }
};

// The replay's typed outputs: a graph's typed inputs take only their own type,
// so the topic's messages also leave on the output named after their type.
template <class... M>
struct TypedOutputs {
  static void declare(Contract& c) {
    (c.output<M>(port_name(M::kTypeName), "the topic's messages when it carries " + std::string(M::kTypeName)), ...);
  }
  // The output index for each of `types` (-1 for a type without one); an
  // error for a connected output that no type played takes (the first such).
  static Result<std::vector<int>> open(OpenContext& ctx, const std::vector<std::string_view>& types) {
    std::vector<int> index(types.size(), -1);
    // Every type's output is looked up, also after an error: the first error is kept.
    Status first;
    const auto keep_first = [&first](Status s) {
      if (first.ok()) first = std::move(s);
    };
    (keep_first(check<M>(ctx, types, index)), ...);
    if (!first.ok()) return first;
    return index;
  }
  template <class T>
  static Status check(OpenContext& ctx, const std::vector<std::string_view>& types, std::vector<int>& index) {
    const std::string name = port_name(T::kTypeName);
    auto h = ctx.output<T>(name);
    bool played = false;
    for (std::size_t i = 0; i < types.size(); ++i) {
      if (T::kTypeName != types[i]) continue;
      index[i] = h.index;
      played = true;
    }
    if (played || !ctx.connected(h)) return {};
    std::string carried;
    for (std::string_view t : types) carried += (carried.empty() ? "" : ", ") + std::string(t);
    return Status::error("output '" + name + "' is connected, but the played topics carry " + carried + " (output '" +
                         port_name(types.front()) + "'" + (types.size() > 1 ? ", ..." : "") + ")");
  }
  // "FeatureMaps" -> "feature_maps"
  static std::string port_name(std::string_view type) {
    std::string out;
    for (char ch : type) {
      if (ch >= 'A' && ch <= 'Z') {
        if (!out.empty()) out += '_';
        out += static_cast<char>(ch - 'A' + 'a');
      } else {
        out += ch;
      }
    }
    return out;
  }
};
using ReplayOutputs = TypedOutputs<Image, Retina, FeatureMaps, Motion, Region, StereoFixation, GazeRequest, JointState,
                                   JointTargets, HeadPose, FoveaState, Classification, CanFrames>;

class Replay final : public Node {
 public:
  static constexpr const char* kName = "replay";
  static constexpr Out<Message> kOut{"out", "the recorded topics' messages, with their recorded timestamps (any type)"};

  static Contract contract() {
    Contract c(
        "Plays recorded topics of an MCAP file into the graph in file order, each message with its recorded "
        "timestamp and frame id (origin = when it is played): at the recorded pace (realtime, the replay "
        "nodes of one file keeping their topics' spacing) or as fast as consumers take (fast: give its edges "
        "queue=\"block:N\" to drop nothing; the same file gives the same messages in the same order). "
        "Several topics (comma-separated) play interleaved as they were recorded, on one thread: a node's "
        "trigger and side inputs replayed by one node see each other as they did when recorded "
        "(docs/recording.md). Messages leave on 'out' and on the output named after their type (retina, "
        "feature_maps, ...), which typed inputs take; topics played by one node carry different types. A "
        "truncated or corrupted file is an error naming the offset, unless salvage.");
    c.ports(kOut)
        .required_string("path", "MCAP file to read")
        .param_string("topic", "",
                      "the topic to play, or several comma-separated (default: the file's only topic); an unknown one "
                      "lists the file's")
        .param_enum("rate", "fast", {"fast", "realtime"}, "as fast as consumers take, or at the recorded pace")
        .param_double("speed", 1.0, 0.01, 1000.0, "realtime: this many times the recorded pace")
        .param_bool("salvage", false,
                    "play the readable part of a truncated or corrupted file (skipped parts counted in 'skipped')");
    ReplayOutputs::declare(c);
    return c;
  }
  Status open(OpenContext& ctx) override {
    const Params& p = ctx.params();
    path_ = p.get_string("path");
    realtime_ = p.get_string("rate") == "realtime";
    speed_ = p.get_double("speed");
    if (Status opened = reader_.open(path_, comma_list(p.get_string("topic")), p.get_bool("salvage")); !opened.ok())
      return opened;
    std::vector<std::string_view> types;
    for (std::size_t i = 0; i < reader_.topic_count(); ++i) {
      for (std::size_t k = 0; k < i; ++k)
        if (reader_.type(k) == reader_.type(i))
          return Status::error(reader_.topic(k) + " and " + reader_.topic(i) + " both carry " +
                               std::string(reader_.type(i)) + ": play them with a replay node each");
      types.push_back(reader_.type(i));
    }
    Result<std::vector<int>> typed = ReplayOutputs::open(ctx, types);
    if (!typed.ok()) return Status::error(reader_.topic() + ": " + typed.error());
    typed_ = std::move(typed).value();
    for (const std::string& w : reader_.reader().warnings()) log().warn("{}: {}", ctx.node_name(), w);
    skipped_ = &ctx.counter("skipped");
    Anchors::instance().join(path_);
    joined_ = true;
    return {};
  }
  Status process(ProcessContext& ctx) override {
    std::size_t topic = 0;
    Result<MessagePtr> next = reader_.next(&topic);
    const uint64_t skipped = reader_.reader().skipped();
    if (skipped > skipped_seen_) {
      skipped_->fetch_add(skipped - skipped_seen_, std::memory_order_relaxed);
      skipped_seen_ = skipped;
      log().warn("{}: skipped a damaged part: {}", ctx.node_name(), reader_.reader().warnings().back());
    }
    if (!next.ok()) return next.status();
    MessagePtr m = std::move(next).value();
    if (m == nullptr) return Status::end_of_stream();
    if (realtime_) {
      if (anchor_ == 0) anchor_ = Anchors::instance().start(path_);
      const double since = static_cast<double>(m->timestamp_ns - static_cast<int64_t>(reader_.start_time())) / speed_;
      if (!ctx.sleep_until(anchor_ + static_cast<int64_t>(since))) return Status::end_of_stream();
    }
    const_cast<Message&>(*m).origin_ns = steady_now_ns();
    if (typed_[topic] >= 0) ctx.emit(OutputHandle<Message>{typed_[topic]}, m);
    ctx.emit(kOut, std::move(m));
    return {};
  }
  void close() override {
    if (joined_) Anchors::instance().leave(path_);
    joined_ = false;
  }

 private:
  mcap::TopicReader reader_;
  bool joined_ = false;
  std::string path_;
  bool realtime_ = false;
  double speed_ = 1.0;
  int64_t anchor_ = 0;
  std::vector<int> typed_;
  std::atomic<uint64_t>* skipped_ = nullptr;
  uint64_t skipped_seen_ = 0;
};

}  // namespace

SACCADE_PLUGIN("mcap", Record, Replay)
