#pragma once
// saccade's messages in MCAP files: a file of channels that any thread may
// write messages to (the mcap.record nodes of a graph share one per path), a
// recorder that taps every connected output of a running graph
// (`saccade run --record`), and the reading of one recorded topic back into
// messages (mcap.replay). Each channel carries one message type in the
// encoding saccade writes it in (plugins/dds/channel.hpp): images as ROS 2's
// sensor_msgs/Image, every other type as its IDL type; joint states also on
// "<topic>/ros2" as sensor_msgs/JointState, for ROS 2's tools.
// No plugin registry here: the saccade command links this library.
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "mcap.hpp"
#include "saccade/message.hpp"
#include "saccade/status.hpp"

namespace saccade {
class Executor;
namespace dds {
class MessageEncoder;
class MessageDecoder;
struct ChannelEncoding;
}  // namespace dds
}  // namespace saccade

namespace saccade::mcap {

// One MCAP file of saccade messages. Thread-safe.
class MessageFile {
 public:
  struct Topic;  // a topic's channels (one per message type seen on it)

  MessageFile();
  ~MessageFile();  // closes the file
  MessageFile(const MessageFile&) = delete;
  MessageFile& operator=(const MessageFile&) = delete;

  // An error saying why the file cannot be written.
  Status open(const std::string& path, const WriterOptions& options);
  // A topic to write on, kept until the file closes; `metadata` goes to each
  // of its channels (beside saccade_type, the message type).
  Topic* topic(const std::string& name, const std::map<std::string, std::string>& metadata = {});
  // Writes `message` on `topic`: log time and publish time are its timestamp,
  // the sequence its frame id. Its channel (schema described once per type)
  // is made at the first message of its type. An error saying what failed (a
  // type with no encoding, a message that does not encode, a write error).
  Status write(Topic* topic, const Message& message);
  Status close();  // the file's first write error, if any

  uint64_t messages() const;
  uint64_t bytes() const;  // written to the file so far
  const std::string& path() const { return path_; }
  const WriterOptions& options() const { return options_; }

 private:
  mutable std::mutex mutex_;
  Writer writer_;
  std::string path_;
  WriterOptions options_;
  std::vector<std::unique_ptr<Topic>> topics_;
  std::vector<std::pair<std::string, uint16_t>> schemas_;  // schema name -> id

  // The index in `topic`'s channels of the one for `type` (its ROS 2 form's
  // when `ros2`), made at its first message; `mutex_` is held.
  Result<std::size_t> channel_for(Topic* topic, std::string_view type, bool ros2);
};

// What attach_recorder records and how.
struct RecorderOptions {
  WriterOptions writer;     // compression (zstd by default), chunk size
  std::size_t queue = 256;  // messages waiting for the writer thread
  // A full queue makes the emitting node wait for the writer (nothing is
  // dropped, the graph slows down) instead of dropping the message (counted).
  bool lossless = false;
  // "node.port" outputs to record; empty: every connected output.
  std::vector<std::string> ports;
};

// Records a running graph: one channel per output port ("/node/port"), fed
// by executor taps on whatever threads emit, through a bounded queue to one
// writer thread.
class GraphRecorder {
 public:
  ~GraphRecorder();  // finish()
  GraphRecorder(const GraphRecorder&) = delete;
  GraphRecorder& operator=(const GraphRecorder&) = delete;

  // After Executor::run(): writes what is queued, closes the file (summary,
  // footer). The first error of the recording, if any (also in report()).
  Status finish();
  uint64_t recorded() const { return recorded_.load(); }  // messages written
  uint64_t dropped() const { return dropped_.load(); }    // messages dropped on a full queue
  uint64_t failed() const { return failed_.load(); }      // messages that could not be encoded or written
  uint64_t bytes() const;
  std::size_t channels() const { return topics_.size(); }
  // One line for the run's report: "recorded 1200 messages on 2 channels to
  // run.mcap (3.1 MB, zstd): 0 dropped".
  std::string report() const;

 private:
  friend Result<std::unique_ptr<GraphRecorder>> attach_recorder(Executor&, const std::string&, const RecorderOptions&);
  GraphRecorder() = default;
  void push(MessageFile::Topic* topic, const MessagePtr& message);
  void run_writer();

  MessageFile file_;
  RecorderOptions options_;
  std::vector<MessageFile::Topic*> topics_;
  struct Item {
    MessageFile::Topic* topic = nullptr;
    MessagePtr message;
  };
  std::vector<Item> ring_;  // the bounded queue
  std::size_t head_ = 0, count_ = 0;
  std::mutex mutex_;
  std::condition_variable has_items_, has_room_;
  bool stopping_ = false, finished_ = false;
  std::thread writer_;
  std::atomic<uint64_t> recorded_{0}, dropped_{0}, failed_{0};
  std::string first_error_;
};

// Taps every connected output port of `executor`'s graph (or options.ports)
// and records what they emit to `path`. Call after Executor::open() and
// before run(); call finish() (or destroy the recorder) after run().
// The running recorder, or an error when the file cannot be written or a
// port is unknown.
Result<std::unique_ptr<GraphRecorder>> attach_recorder(Executor& executor, const std::string& path,
                                                       const RecorderOptions& options);

// The saccade type a recorded channel carries: its saccade_type metadata, or
// the type whose schema it names (never nullptr). An error for a schema
// saccade does not read (it names the schema and what saccade reads).
Result<const dds::ChannelEncoding*> encoding_of(const Channel& channel, const Schema* schema);

// Reads recorded topics back as messages, in file order: one topic, or
// several interleaved as they were written (a recorder writes in the order
// the graph's consumers took them).
class TopicReader {
 public:
  TopicReader();
  ~TopicReader();
  // An error saying what is wrong: the file (with the offset of the damage),
  // no such topic (the error lists the file's topics), a schema saccade does
  // not read, a topic named twice. No topics: the file's only topic.
  Status open(const std::string& path, const std::vector<std::string>& topics, bool salvage);
  Status open(const std::string& path, const std::string& topic, bool salvage) {
    return open(path, topic.empty() ? std::vector<std::string>{} : std::vector<std::string>{topic}, salvage);
  }
  // The next message (timestamp = the log time), or nullptr at the end; an
  // error naming the offset of a damaged part or of a message that does not
  // decode (with salvage, both are skipped instead). `topic_index`, when
  // given, is set to the index of the message's topic.
  Result<MessagePtr> next(std::size_t* topic_index = nullptr);
  void rewind();
  std::size_t topic_count() const { return topics_.size(); }
  const std::string& topic(std::size_t index = 0) const { return topics_[index].name; }
  std::string_view type(std::size_t index = 0) const;
  uint64_t start_time() const { return start_time_; }  // the file's first log time (of any topic)
  const Reader& reader() const { return reader_; }

 private:
  struct Played {
    std::string name;
    uint16_t channel = 0;
    bool ros2 = false;
    const dds::ChannelEncoding* encoding = nullptr;
    std::unique_ptr<dds::MessageDecoder> decoder;
  };
  // Plays `channel` too; an error naming `path` when it cannot be played.
  Status add_topic(const std::string& path, const Channel& channel);
  Reader reader_;
  std::vector<Played> topics_;
  bool salvage_ = false;
  uint64_t start_time_ = 0;
};

}  // namespace saccade::mcap
