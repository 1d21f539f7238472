#include "recording.hpp"

#include <cctype>
#include <cstdio>
#include <set>

#include "channel.hpp"
#include "saccade/executor.hpp"

namespace saccade::mcap {

struct MessageFile::Topic {
  std::string name;
  std::map<std::string, std::string> metadata;
  struct Typed {
    std::string_view type;     // Message::type_name()
    bool ros2 = false;         // the "<topic>/ros2" channel of a type saccade writes in its IDL form
    bool ros2_beside = false;  // its messages also go on such a channel
    uint16_t channel = 0;
    std::unique_ptr<dds::MessageEncoder> encoder;
  };
  std::vector<Typed> channels;  // one per message type seen (usually one)
  std::vector<uint8_t> bytes;   // the encoder's output, kept between messages
};

MessageFile::MessageFile() = default;
MessageFile::~MessageFile() { close(); }

Status MessageFile::open(const std::string& path, const WriterOptions& options) {
  std::lock_guard lock(mutex_);
  path_ = path;
  options_ = options;
  return writer_.open(path, options);
}

MessageFile::Topic* MessageFile::topic(const std::string& name, const std::map<std::string, std::string>& metadata) {
  std::lock_guard lock(mutex_);
  topics_.push_back(std::make_unique<Topic>());
  topics_.back()->name = name;
  topics_.back()->metadata = metadata;
  return topics_.back().get();
}

// A type written in saccade's IDL form that ROS 2 also has a message for
// (JointState) gets a second channel, "<topic>/ros2", in ROS 2's form, so
// rosbag2, PlotJuggler and Foxglove's joint handling read it; the first
// channel keeps every field for replay.
constexpr std::string_view kRos2Suffix = "/ros2";
constexpr const char* kRos2FormOf = "ros2_form_of";  // that channel's metadata: the topic it is the form of

Result<std::size_t> MessageFile::channel_for(Topic* topic, std::string_view type, bool ros2) {
  for (std::size_t k = 0; k < topic->channels.size(); ++k)
    if (topic->channels[k].type == type && topic->channels[k].ros2 == ros2) return k;
  const dds::ChannelEncoding* e = ros2 ? dds::channel_encoding(type, true) : dds::written_encoding(type);
  if (e == nullptr)
    return Status::error("topic " + topic->name + ": " + std::string(type) + " has no channel encoding");
  uint16_t schema = 0;
  for (const auto& [name, id] : schemas_)
    if (name == e->schema_name) schema = id;
  if (schema == 0) {
    schema = writer_.add_schema(e->schema_name, e->schema_encoding, e->schema.data(), e->schema.size());
    schemas_.emplace_back(e->schema_name, schema);
  }
  auto metadata = topic->metadata;
  metadata["saccade_type"] = std::string(type);
  if (ros2) metadata[kRos2FormOf] = topic->name;
  Topic::Typed t;
  t.type = e->type;
  t.ros2 = ros2;
  t.ros2_beside = !ros2 && dds::channel_encoding(type, true) != e;
  t.channel = writer_.add_channel(schema, ros2 ? topic->name + std::string(kRos2Suffix) : topic->name,
                                  e->message_encoding, metadata);
  t.encoder = dds::make_encoder(*e);
  topic->channels.push_back(std::move(t));
  return topic->channels.size() - 1;
}

Status MessageFile::write(Topic* topic, const Message& message) {
  std::lock_guard lock(mutex_);
  if (!writer_.is_open()) return Status::error("'" + path_ + "' is closed");
  // On its own channel, then on its ROS 2 form's when one goes beside it.
  for (bool ros2 = false;; ros2 = true) {
    const Result<std::size_t> index = channel_for(topic, message.type_name(), ros2);
    if (!index.ok()) return index.status();
    const Topic::Typed& typed = topic->channels[*index];
    if (Status encoded = typed.encoder->encode(message, topic->bytes); !encoded.ok())
      return Status::error("topic " + topic->name + ": " + encoded.message());
    const Status written = writer_.write(
        typed.channel, static_cast<uint32_t>(message.frame_id), static_cast<uint64_t>(message.timestamp_ns),
        static_cast<uint64_t>(message.timestamp_ns), topic->bytes.data(), topic->bytes.size());
    if (!written.ok() || !typed.ros2_beside) return written;
  }
}

Status MessageFile::close() {
  std::lock_guard lock(mutex_);
  if (!writer_.is_open()) return {};
  return writer_.close();
}

uint64_t MessageFile::messages() const {
  std::lock_guard lock(mutex_);
  return writer_.messages();
}

uint64_t MessageFile::bytes() const {
  std::lock_guard lock(mutex_);
  return writer_.bytes_written();
}

// ---------------------------------------------------------------- GraphRecorder

Result<std::unique_ptr<GraphRecorder>> attach_recorder(Executor& executor, const std::string& path,
                                                       const RecorderOptions& options) {
  std::unique_ptr<GraphRecorder> r(new GraphRecorder());
  r->options_ = options;
  if (r->options_.queue == 0) r->options_.queue = 1;
  const ResolvedGraph& graph = executor.graph();
  // The outputs to record: named ones, or every connected one (in graph order).
  std::vector<std::pair<int, int>> ports;
  if (options.ports.empty()) {
    std::set<std::pair<int, int>> seen;
    for (const ResolvedEdge& e : graph.edges)
      if (seen.insert({e.from_node, e.from_port}).second) ports.emplace_back(e.from_node, e.from_port);
  } else {
    for (const std::string& name : options.ports) {
      const auto dot = name.rfind('.');
      bool found = false;
      for (std::size_t n = 0; n < graph.nodes.size() && !found && dot != std::string::npos; ++n) {
        if (graph.nodes[n].decl.name != name.substr(0, dot)) continue;
        const int port = graph.nodes[n].contract.output_index(name.substr(dot + 1));
        if (port >= 0) {
          ports.emplace_back(static_cast<int>(n), port);
          found = true;
        }
      }
      if (!found) return Status::error("--record: no output '" + name + "' in the graph (node.port)");
    }
  }
  if (Status opened = r->file_.open(path, options.writer); !opened.ok()) return opened;
  r->ring_.resize(r->options_.queue);
  GraphRecorder* self = r.get();
  for (const auto& [n, p] : ports) {
    const ResolvedNode& node = graph.nodes[static_cast<std::size_t>(n)];
    const PortSpec& port = node.contract.outputs()[static_cast<std::size_t>(p)];
    MessageFile::Topic* topic =
        r->file_.topic("/" + node.decl.name + "/" + port.name, {{"node", node.decl.name}, {"port", port.name}});
    r->topics_.push_back(topic);
    if (Status tapped =
            executor.add_tap(node.decl.name, port.name, [self, topic](const MessagePtr& m) { self->push(topic, m); });
        !tapped.ok())
      return Status::error("--record: " + tapped.message());
  }
  r->writer_ = std::thread([self] { self->run_writer(); });
  return r;
}

void GraphRecorder::push(MessageFile::Topic* topic, const MessagePtr& message) {
  std::unique_lock lock(mutex_);
  if (count_ == ring_.size()) {
    if (!options_.lossless || stopping_) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
    has_room_.wait(lock, [&] { return count_ < ring_.size() || stopping_; });
    if (stopping_) {
      dropped_.fetch_add(1, std::memory_order_relaxed);
      return;
    }
  }
  Item& slot = ring_[(head_ + count_) % ring_.size()];
  slot.topic = topic;
  slot.message = message;
  ++count_;
  lock.unlock();
  has_items_.notify_one();
}

void GraphRecorder::run_writer() {
  std::unique_lock lock(mutex_);
  for (;;) {
    has_items_.wait(lock, [&] { return count_ > 0 || stopping_; });
    if (count_ == 0 && stopping_) return;
    Item& slot = ring_[head_];
    MessageFile::Topic* topic = slot.topic;
    MessagePtr message = std::move(slot.message);
    head_ = (head_ + 1) % ring_.size();
    --count_;
    lock.unlock();
    has_room_.notify_one();
    const Status written = file_.write(topic, *message);
    message.reset();  // back to its pool, off the lock
    lock.lock();
    if (written.ok()) {
      recorded_.fetch_add(1, std::memory_order_relaxed);
    } else {
      failed_.fetch_add(1, std::memory_order_relaxed);
      if (first_error_.empty()) first_error_ = written.message();
    }
  }
}

Status GraphRecorder::finish() {
  {
    std::lock_guard lock(mutex_);
    if (finished_) return first_error_.empty() ? Status() : Status::error(first_error_);
    finished_ = true;
    stopping_ = true;
  }
  has_items_.notify_all();
  has_room_.notify_all();
  if (writer_.joinable()) writer_.join();
  const Status closed = file_.close();
  if (first_error_.empty()) first_error_ = closed.message();
  return first_error_.empty() ? Status() : Status::error(first_error_);
}

GraphRecorder::~GraphRecorder() { finish(); }

uint64_t GraphRecorder::bytes() const { return file_.bytes(); }

std::string GraphRecorder::report() const {
  char size[32];
  const double b = static_cast<double>(bytes());
  if (b >= 1e6) {
    std::snprintf(size, sizeof size, "%.1f MB", b / 1e6);
  } else {
    std::snprintf(size, sizeof size, "%.1f kB", b / 1e3);
  }
  std::string line = "recorded " + std::to_string(recorded()) + " messages on " + std::to_string(topics_.size()) +
                     " channels to " + file_.path() + " (" + size + ", " + to_string(file_.options().compression) +
                     "): " + std::to_string(dropped()) + " dropped";
  if (failed() > 0) line += ", " + std::to_string(failed()) + " not written (" + first_error_ + ")";
  return line;
}

// ---------------------------------------------------------------- reading

namespace {

// The members of `struct <name> { ... };` in an IDL text, one per entry
// ("double depth"), comments dropped and white space collapsed; empty where
// the text has no such struct.
std::vector<std::string> struct_members(std::string_view idl, std::string_view name) {
  // The text with each run of white space and // comments as one space.
  std::string text;
  for (std::size_t i = 0; i < idl.size(); ++i) {
    const bool comment = idl.compare(i, 2, "//") == 0;
    if (comment) i = std::min(idl.find('\n', i), idl.size());
    if (comment || std::isspace(static_cast<unsigned char>(idl[i]))) {
      if (!text.empty() && text.back() != ' ') text += ' ';
      continue;
    }
    text += idl[i];
  }
  const std::string head = "struct " + std::string(name) + " {";
  const std::size_t at = text.find(head);
  if (at == std::string::npos) return {};
  const std::size_t end = text.find('}', at);
  std::vector<std::string> members;
  std::string member;
  for (std::size_t i = at + head.size(); i < end; ++i) {
    if (text[i] != ';') {
      if (text[i] != ' ' || !member.empty()) member += text[i];
      continue;
    }
    if (!member.empty() && member.back() == ' ') member.pop_back();
    members.push_back(member);
    member.clear();
  }
  return members;
}

// A saccade IDL type recorded by another version of saccade whose fields
// differ from this build's cannot be decoded: an error that says where they part.
Status same_fields(const Channel& channel, const Schema& recorded, const dds::ChannelEncoding& ours) {
  const std::string_view full = ours.schema_name;
  const std::string_view name = full.substr(full.rfind(':') + 1);
  const std::vector<std::string> theirs =
      struct_members(std::string_view(reinterpret_cast<const char*>(recorded.data.data()), recorded.data.size()), name);
  const std::vector<std::string> mine = struct_members(ours.schema, name);
  if (theirs == mine) return {};
  std::size_t i = 0;
  while (i < theirs.size() && i < mine.size() && theirs[i] == mine[i]) ++i;
  const auto member = [&](const std::vector<std::string>& m) { return i < m.size() ? "'" + m[i] + "'" : "nothing"; };
  return Status::error("topic " + channel.topic + ": recorded with another version of " + ours.schema_name +
                       ", whose fields differ from this build's (member " + std::to_string(i + 1) + ": the file has " +
                       member(theirs) + ", this build " + member(mine) + "); it cannot be decoded");
}

}  // namespace

Result<const dds::ChannelEncoding*> encoding_of(const Channel& channel, const Schema* schema) {
  if (schema == nullptr)
    return Status::error("topic " + channel.topic + ": its channel names schema " + std::to_string(channel.schema_id) +
                         ", which the file does not have");
  if (channel.message_encoding != "cdr")
    return Status::error("topic " + channel.topic + ": message encoding '" + channel.message_encoding +
                         "' (saccade reads cdr)");
  const bool ros2 = schema->encoding == "ros2msg";
  const auto checked = [&](const dds::ChannelEncoding* e) -> Result<const dds::ChannelEncoding*> {
    if (e->schema_encoding != "omgidl") return e;
    if (Status same = same_fields(channel, *schema, *e); !same.ok()) return same;
    return e;
  };
  if (auto it = channel.metadata.find("saccade_type"); it != channel.metadata.end()) {
    const dds::ChannelEncoding* e = dds::channel_encoding(it->second, ros2);
    if (e != nullptr && e->schema_name == schema->name) return checked(e);
  }
  for (std::string_view type : dds::channel_types()) {
    for (bool r : {true, false}) {
      const dds::ChannelEncoding* e = dds::channel_encoding(type, r);
      if (e != nullptr && e->schema_name == schema->name && e->schema_encoding == schema->encoding) return checked(e);
    }
  }
  std::string known;
  for (std::string_view type : dds::channel_types()) {
    for (bool r : {true, false}) {
      const dds::ChannelEncoding* e = dds::channel_encoding(type, r);
      if (e == nullptr || known.find(e->schema_name) != std::string::npos) continue;
      known += (known.empty() ? "" : ", ") + e->schema_name;
    }
  }
  return Status::error("topic " + channel.topic + ": schema '" + schema->name + "' (" + schema->encoding +
                       ") is not one saccade reads (it reads " + known + ")");
}

TopicReader::TopicReader() = default;
TopicReader::~TopicReader() = default;

std::string_view TopicReader::type(std::size_t index) const {
  return index < topics_.size() ? topics_[index].encoding->type : std::string_view();
}

namespace {

std::string list_topics(const Reader& reader) {
  std::string topics;
  for (const auto& [id, c] : reader.channels()) {
    const Schema* s = reader.schema_of(c);
    topics += (topics.empty() ? "" : ", ") + c.topic + " (" + (s != nullptr ? s->name : std::string("no schema")) + ")";
  }
  return topics.empty() ? "none" : topics;
}

}  // namespace

Status TopicReader::add_topic(const std::string& path, const Channel& channel) {
  for (const Played& t : topics_)
    if (t.channel == channel.id) return Status::error(path + ": topic '" + channel.topic + "' named twice");
  const Result<const dds::ChannelEncoding*> encoding = encoding_of(channel, reader_.schema_of(channel));
  if (!encoding.ok()) return Status::error(path + ": " + encoding.error());
  Played played;
  played.encoding = *encoding;
  played.decoder = dds::make_decoder(*played.encoding);
  played.ros2 = played.encoding->schema_encoding == "ros2msg";
  played.name = channel.topic;
  played.channel = channel.id;
  topics_.push_back(std::move(played));
  return {};
}

Status TopicReader::open(const std::string& path, const std::vector<std::string>& topics, bool salvage) {
  salvage_ = salvage;
  topics_.clear();
  if (Status opened = reader_.open(path, salvage); !opened.ok()) return opened;
  if (topics.empty()) {
    // The file's only topic; a joint state topic's ROS 2 form beside it is not another.
    std::vector<const Channel*> own;
    for (const auto& [id, channel] : reader_.channels())
      if (!channel.metadata.contains(kRos2FormOf)) own.push_back(&channel);
    if (own.size() != 1)
      return Status::error(path + ": which topic? the file has " + (own.empty() ? "none" : "several") +
                           "; its topics: " + list_topics(reader_));
    if (Status added = add_topic(path, *own.front()); !added.ok()) return added;
  }
  for (const std::string& name : topics) {
    const Channel* channel = reader_.find_channel(name);
    if (channel == nullptr)
      return Status::error(path + ": no topic '" + name + "'; its topics: " + list_topics(reader_));
    if (Status added = add_topic(path, *channel); !added.ok()) return added;
  }
  start_time_ = reader_.statistics() != nullptr ? reader_.statistics()->message_start_time : 0;
  rewind();
  if (reader_.statistics() == nullptr) {
    // No summary (salvaged): the first message of the file gives the start.
    Reader probe;
    if (probe.open(path, true).ok()) {
      probe.rewind({});
      MessageView v;
      if (const Result<bool> read = probe.next(v); read.ok() && *read) start_time_ = v.log_time;
    }
  }
  return {};
}

void TopicReader::rewind() {
  ReadOptions options;
  options.salvage = salvage_;
  for (const Played& t : topics_) options.channels.push_back(t.channel);
  reader_.rewind(options);
}

Result<MessagePtr> TopicReader::next(std::size_t* topic_index) {
  MessageView view;
  for (;;) {
    const Result<bool> read = reader_.next(view);
    if (!read.ok()) return read.status();
    if (!*read) return MessagePtr();  // the end
    std::size_t index = 0;
    while (index < topics_.size() && topics_[index].channel != view.channel_id) ++index;
    if (index == topics_.size()) continue;  // a channel not asked for (the reader filters them already)
    Played& played = topics_[index];
    Result<MessagePtr> decoded = played.decoder->decode(view.data, view.size);
    if (!decoded.ok()) {
      if (salvage_) continue;
      if (reader_.file_size() == 0) return decoded.status();
      return Status::error("topic " + played.name + ": the message at offset " + std::to_string(view.offset) +
                           " does not decode: " + decoded.error());
    }
    MessagePtr m = std::move(decoded).value();
    auto& mutable_message = const_cast<Message&>(*m);  // new, not shared yet
    mutable_message.timestamp_ns = static_cast<int64_t>(view.log_time);
    if (played.ros2) mutable_message.frame_id = view.sequence;
    if (topic_index != nullptr) *topic_index = index;
    return m;
  }
}

}  // namespace saccade::mcap
