#pragma once
// MCAP, the robotics log format (Foxglove, rosbag2, PlotJuggler read it),
// written from its specification: a writer (magic, Header, Schema, Channel and
// Message records, optionally in Chunks compressed with zstd or lz4, a
// MessageIndex per channel after each chunk, DataEnd, a summary section with
// Schemas, Channels, Statistics and ChunkIndexes, SummaryOffsets, Footer and
// CRCs) and a reader (summary-driven or a linear scan of the data section).
// Nothing of saccade here but its Status: records, bytes and errors that name
// file offsets.
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "saccade/status.hpp"

namespace saccade::mcap {

enum class Compression { kNone, kZstd, kLz4 };
// "none", "zstd", "lz4"; false when `text` is none of them.
bool parse_compression(std::string_view text, Compression& out);
const char* to_string(Compression compression);

// CRC-32 (ISO-HDLC, as zlib's crc32), continued from `crc` (0 to start).
uint32_t crc32(uint32_t crc, const void* data, std::size_t size);

struct WriterOptions {
  Compression compression = Compression::kZstd;
  // A chunk is closed once its records reach this many bytes (uncompressed);
  // 0 writes every record straight into the data section, unchunked.
  std::size_t chunk_size = 1 << 20;
  int zstd_level = 1;   // fast: recording must keep up with the graph
  std::string profile;  // the Header's profile ("" or "ros2")
  std::string library = "saccade";
};

// Writes one MCAP file. Not thread-safe: one writer thread, or a lock.
class Writer {
 public:
  Writer();
  ~Writer();  // closes the file when open() succeeded and close() was not called
  Writer(const Writer&) = delete;
  Writer& operator=(const Writer&) = delete;

  // An error saying why the file cannot be written (its folder is made when
  // missing).
  Status open(const std::string& path, const WriterOptions& options = {});
  // Ids from 1, in the order added (0 is "no schema" in MCAP).
  uint16_t add_schema(std::string_view name, std::string_view encoding, const void* data, std::size_t size);
  uint16_t add_channel(uint16_t schema_id, std::string_view topic, std::string_view message_encoding,
                       const std::map<std::string, std::string>& metadata = {});
  // One message; its bytes are copied (into the open chunk). An error saying
  // what failed (an unknown channel, a write error, also an earlier one: a
  // write error sticks). Steady state allocates nothing.
  Status write(uint16_t channel_id, uint32_t sequence, uint64_t log_time, uint64_t publish_time, const void* data,
               std::size_t size);
  // Closes the open chunk, writes DataEnd, the summary and the footer; the
  // first write error of the file, if any.
  Status close();
  bool is_open() const;

  uint64_t messages() const { return message_count_; }
  uint64_t bytes_written() const { return offset_; }  // the file's size so far
  uint64_t chunks() const { return chunk_indexes_.size(); }

 private:
  struct ChunkIndex {
    uint64_t start_time, end_time, offset, length;
    std::size_t first_offset, offsets;  // its message indexes' entries in index_offsets_
    uint64_t index_length;
    std::string_view compression;  // a literal: "", "zstd" or "lz4"
    uint64_t compressed_size, uncompressed_size;
  };
  struct ChannelState {
    uint16_t schema_id = 0;
    std::string topic, message_encoding;
    std::map<std::string, std::string> metadata;
    uint64_t count = 0;
    std::vector<std::pair<uint64_t, uint64_t>> index;  // (log time, offset in the open chunk)
  };
  // The summary's Statistics record and its Chunk Index records.
  void append_statistics(std::vector<uint8_t>& out) const;
  void append_chunk_indexes(std::vector<uint8_t>& out) const;
  struct SchemaState {
    std::string name, encoding;
    std::vector<uint8_t> data;
  };
  void put(const void* data, std::size_t size);  // to the file, counting the offset and the data CRC
  Status write_status() const;                   // the first write error (error_), as a Status
  void close_chunk();
  std::vector<uint8_t>& records_out();  // the open chunk, or the scratch buffer of an unchunked file
  void flush_scratch();
  void append_schema(std::vector<uint8_t>& out, uint16_t id, const SchemaState& schema) const;
  void append_channel(std::vector<uint8_t>& out, uint16_t id, const ChannelState& channel) const;

  std::FILE* file_ = nullptr;
  std::string path_, error_;
  WriterOptions options_;
  uint64_t offset_ = 0;
  uint32_t data_crc_ = 0;
  bool in_data_ = true;
  std::vector<SchemaState> schemas_;    // id - 1
  std::vector<ChannelState> channels_;  // id - 1
  std::vector<uint8_t> chunk_, compressed_, scratch_;
  uint64_t chunk_start_ = 0, chunk_end_ = 0, chunk_messages_ = 0;
  // The summary's index, growing with the file (by doubling: one vector for
  // every chunk's message indexes, not one each).
  std::vector<ChunkIndex> chunk_indexes_;
  std::vector<std::pair<uint16_t, uint64_t>> index_offsets_;  // (channel, its message index's offset)
  uint64_t message_count_ = 0, start_time_ = 0, end_time_ = 0;
  void* zstd_ = nullptr;  // ZSTD_CCtx, kept between chunks
};

struct Schema {
  uint16_t id = 0;
  std::string name, encoding;
  std::vector<uint8_t> data;
};
struct Channel {
  uint16_t id = 0, schema_id = 0;
  std::string topic, message_encoding;
  std::map<std::string, std::string> metadata;
};
struct Statistics {
  uint64_t message_count = 0;
  uint16_t schema_count = 0;
  uint32_t channel_count = 0, attachment_count = 0, metadata_count = 0, chunk_count = 0;
  uint64_t message_start_time = 0, message_end_time = 0;
  std::map<uint16_t, uint64_t> channel_message_counts;
};

// One message as read: its bytes point into the reader's memory (the mapped
// file, or the chunk it decompressed) and stay valid until the next call.
struct MessageView {
  uint16_t channel_id = 0;
  uint32_t sequence = 0;
  uint64_t log_time = 0, publish_time = 0;
  const uint8_t* data = nullptr;
  std::size_t size = 0;
  uint64_t offset = 0;  // the file offset of its record, or of the chunk that holds it
};

struct ReadOptions {
  // Yields every readable message of a truncated or corrupted file instead
  // of stopping at the first error: damaged chunks are skipped (counted in
  // Reader::skipped()), a truncated file is read up to where it was cut.
  bool salvage = false;
  // Only these channels (empty: all); chunks without them are not decompressed
  // when the file has its chunk indexes.
  std::vector<uint16_t> channels;
};

// Reads one MCAP file (mapped into memory).
class Reader {
 public:
  Reader();
  ~Reader();
  Reader(const Reader&) = delete;
  Reader& operator=(const Reader&) = delete;

  // Maps the file and reads its schemas and channels: from the summary when
  // the file has an intact one, else by scanning the data section. An error
  // saying what is wrong, with the file offset ("run.mcap: at offset 1234:
  // truncated ..."). With `salvage`, a file without a summary, or with a
  // broken one, is read by a scan that stops where the damage starts; the
  // damage is then only reported in warnings().
  Status open(const std::string& path, bool salvage = false);

  const std::map<uint16_t, Schema>& schemas() const { return schemas_; }
  const std::map<uint16_t, Channel>& channels() const { return channels_; }
  const Channel* find_channel(std::string_view topic) const;
  const Schema* schema_of(const Channel& channel) const;
  // From the summary's Statistics record; absent in a file without a summary.
  const Statistics* statistics() const { return has_statistics_ ? &statistics_ : nullptr; }
  bool has_summary() const { return has_summary_; }
  const std::string& header_profile() const { return profile_; }
  const std::string& header_library() const { return library_; }
  uint64_t file_size() const { return size_; }
  // What a salvaging open or read skipped, each with its file offset.
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Starts (again) reading messages in file order.
  void rewind(const ReadOptions& options = {});
  // The next message into `out` (reused: its bytes are the reader's): true,
  // or false at the end; an error naming the offset when the file is damaged
  // and not salvaging (a later call goes on after the damage, where it can).
  Result<bool> next(MessageView& out);
  uint64_t skipped() const { return skipped_; }  // damaged chunks or records passed over

 private:
  struct ChunkRef {
    uint64_t offset, length;
    std::vector<uint16_t> channels;
  };
  // The error "PATH: at offset N: what".
  Status fail(uint64_t offset, const std::string& what) const;
  Status read_summary();
  // Schemas and channels from the data section; the first damage met.
  Status scan_definitions();
  // One Schema or Channel record (op) of `len` bytes at `p`, file offset
  // `offset`, into schemas_ / channels_; an error when it is malformed.
  Status parse_definition(uint8_t op, const uint8_t* p, uint64_t len, uint64_t offset);
  // The schemas and channels inside the loaded chunk (at `offset`), up to its
  // first cut record. A malformed one is passed over: the definitions are
  // read where they can be, the damage is reported where messages are read.
  void read_chunk_definitions(uint64_t offset);
  // Decompresses the chunk record at `offset` into chunk_; an error when it
  // is malformed, does not decompress or fails its CRC.
  Status load_chunk(uint64_t offset, uint64_t length, bool allow_cut);
  bool wanted(uint16_t channel) const;
  // The loaded chunk's next wanted message: true, or false when the chunk is
  // done; an error when a record inside it is damaged.
  Result<bool> next_in_chunk(MessageView& out);
  // The data section's next wanted message: true, or false when there is none
  // here (the end, or a chunk now loaded for next_in_chunk: in_chunk_); an
  // error naming the offset of the damage.
  Result<bool> next_linear(MessageView& out);

  std::string path_;
  const uint8_t* data_ = nullptr;
  uint64_t size_ = 0;
  std::map<uint16_t, Schema> schemas_;
  std::map<uint16_t, Channel> channels_;
  Statistics statistics_;
  bool has_statistics_ = false, has_summary_ = false, salvage_open_ = false;
  std::string profile_, library_;
  uint64_t data_start_ = 0,
           data_end_ = 0;         // records after the Header; where the data section ends (file size when unknown)
  std::vector<ChunkRef> chunks_;  // from the chunk indexes, in file order
  std::vector<std::string> warnings_;

  ReadOptions read_;
  bool indexed_ = false;
  std::size_t next_chunk_ = 0;
  uint64_t pos_ = 0;  // linear: next record's offset
  std::vector<uint8_t> chunk_;
  const uint8_t* chunk_data_ = nullptr;
  uint64_t chunk_size_ = 0, chunk_pos_ = 0, chunk_offset_ = 0;
  bool in_chunk_ = false, done_ = false;
  uint64_t skipped_ = 0;
};

}  // namespace saccade::mcap
