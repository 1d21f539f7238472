#include "mcap.hpp"

#include <fcntl.h>
#include <lz4frame.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cstring>
#include <filesystem>

namespace saccade::mcap {

static_assert(std::endian::native == std::endian::little, "MCAP is little endian; this code reads it in place");

namespace {

constexpr uint8_t kMagic[8] = {0x89, 'M', 'C', 'A', 'P', '0', '\r', '\n'};
enum Op : uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};
constexpr uint64_t kRecordHeader = 9;  // opcode + u64 length
constexpr uint64_t kFooterRecord = kRecordHeader + 20;
// A chunk claiming more than this uncompressed is taken as corrupted rather
// than allocated (the writer's chunks are a few MiB).
constexpr uint64_t kMaxChunk = uint64_t{1} << 32;

// What a compressed chunk is first decompressed into: its claimed size, or
// less when that is far more than its compressed bytes could make (grown as
// they really make more), so that a few bytes claiming gigabytes cost a few bytes.
std::size_t first_output_size(uint64_t claimed, std::size_t compressed) {
  return static_cast<std::size_t>(
      std::min<uint64_t>(claimed, std::max<uint64_t>(uint64_t{1} << 20, uint64_t{16} * compressed)));
}

// Decompresses zstd frames into `out` (the reader's reused chunk buffer), at
// most `claimed` bytes; an error saying what is wrong with them.
Status decompress_zstd(const uint8_t* in, std::size_t in_size, uint64_t claimed, std::vector<uint8_t>& out) {
  std::unique_ptr<ZSTD_DCtx, std::size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  if (!dctx) return Status::error("no zstd decompression context");
  out.resize(first_output_size(claimed, in_size));
  ZSTD_inBuffer src{in, in_size, 0};
  std::size_t produced = 0, left = 1;  // left: 0 once a frame is whole
  while (src.pos < src.size || left != 0) {
    if (produced == out.size() && out.size() < claimed)
      out.resize(static_cast<std::size_t>(std::min<uint64_t>(claimed, uint64_t{2} * out.size())));
    ZSTD_outBuffer dst{out.data(), out.size(), produced};
    const std::size_t read_before = src.pos;
    left = ZSTD_decompressStream(dctx.get(), &dst, &src);
    if (ZSTD_isError(left)) return Status::error(std::string("does not decompress: ") + ZSTD_getErrorName(left));
    const bool moved = dst.pos != produced || src.pos != read_before;
    produced = dst.pos;
    if (!moved) {
      return Status::error(produced == out.size() ? "decompresses to more than " + std::to_string(claimed) + " bytes"
                                                  : "does not decompress: its last frame is cut");
    }
  }
  out.resize(produced);
  return {};
}

const char* op_name(uint8_t op) {
  switch (op) {
    case kHeader: return "Header";
    case kFooter: return "Footer";
    case kSchema: return "Schema";
    case kChannel: return "Channel";
    case kMessage: return "Message";
    case kChunk: return "Chunk";
    case kMessageIndex: return "MessageIndex";
    case kChunkIndex: return "ChunkIndex";
    case kAttachment: return "Attachment";
    case kAttachmentIndex: return "AttachmentIndex";
    case kStatistics: return "Statistics";
    case kMetadata: return "Metadata";
    case kMetadataIndex: return "MetadataIndex";
    case kSummaryOffset: return "SummaryOffset";
    case kDataEnd: return "DataEnd";
    default: return "unknown";
  }
}

// CRC-32 tables for slicing by 8.
struct CrcTables {
  std::array<std::array<uint32_t, 256>, 8> t{};
  CrcTables() {
    for (uint32_t i = 0; i < 256; ++i) {
      uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320U ^ (c >> 1) : c >> 1;
      t[0][i] = c;
    }
    for (uint32_t i = 0; i < 256; ++i)
      for (std::size_t s = 1; s < 8; ++s) t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xFF];
  }
};
const CrcTables& crc_tables() {
  static const CrcTables tables;
  return tables;
}

// Appending little-endian fields to a byte buffer.
template <class T>
void put_le(std::vector<uint8_t>& out, T value) {
  const auto n = out.size();
  out.resize(n + sizeof(T));
  std::memcpy(out.data() + n, &value, sizeof(T));
}
void put_bytes(std::vector<uint8_t>& out, const void* data, std::size_t size) {
  if (size == 0) return;
  const auto n = out.size();
  out.resize(n + size);
  std::memcpy(out.data() + n, data, size);
}
void put_string(std::vector<uint8_t>& out, std::string_view s) {
  put_le<uint32_t>(out, static_cast<uint32_t>(s.size()));
  put_bytes(out, s.data(), s.size());
}
// Starts a record; returns where its length goes (patched by end_record).
std::size_t begin_record(std::vector<uint8_t>& out, uint8_t op) {
  out.push_back(op);
  const auto at = out.size();
  put_le<uint64_t>(out, 0);
  return at;
}
void end_record(std::vector<uint8_t>& out, std::size_t at) {
  const uint64_t len = out.size() - at - 8;
  std::memcpy(out.data() + at, &len, 8);
}

// Reading fields in place, bounds-checked.
class Cursor {
 public:
  Cursor(const uint8_t* p, uint64_t n) : p_(p), n_(n) {}
  template <class T>
  bool get(T& v) {
    if (n_ - at_ < sizeof(T) || at_ > n_) return fail();
    std::memcpy(&v, p_ + at_, sizeof(T));
    at_ += sizeof(T);
    return true;
  }
  bool string(std::string& s) {
    uint32_t len = 0;
    if (!get(len) || n_ - at_ < len) return fail();
    s.assign(reinterpret_cast<const char*>(p_ + at_), len);
    at_ += len;
    return true;
  }
  bool bytes32(std::vector<uint8_t>& b) {
    uint32_t len = 0;
    if (!get(len) || n_ - at_ < len) return fail();
    b.assign(p_ + at_, p_ + at_ + len);
    at_ += len;
    return true;
  }
  // A u32 byte-length prefixed block (map, array): a cursor over it.
  bool block(Cursor& inner) {
    uint32_t len = 0;
    if (!get(len) || n_ - at_ < len) return fail();
    inner = Cursor(p_ + at_, len);
    at_ += len;
    return true;
  }
  bool done() const { return at_ >= n_; }
  uint64_t at() const { return at_; }
  uint64_t left() const { return n_ - at_; }
  const uint8_t* here() const { return p_ + at_; }
  bool skip(uint64_t k) {
    if (n_ - at_ < k) return fail();
    at_ += k;
    return true;
  }
  bool ok() const { return ok_; }

 private:
  bool fail() {
    ok_ = false;
    return false;
  }
  const uint8_t* p_;
  uint64_t n_;
  uint64_t at_ = 0;
  bool ok_ = true;
};

// A Message record's fields from its body of `len` bytes (at least
// kMessageFields): channel, sequence, log and publish times, then the data.
constexpr uint64_t kMessageFields = 22;
void read_message(const uint8_t* body, uint64_t len, uint64_t offset, MessageView& out) {
  std::memcpy(&out.channel_id, body, 2);
  std::memcpy(&out.sequence, body + 2, 4);
  std::memcpy(&out.log_time, body + 6, 8);
  std::memcpy(&out.publish_time, body + 14, 8);
  out.data = body + kMessageFields;
  out.size = len - kMessageFields;
  out.offset = offset;
}

}  // namespace

bool parse_compression(std::string_view text, Compression& out) {
  if (text == "none" || text.empty()) {
    out = Compression::kNone;
  } else if (text == "zstd") {
    out = Compression::kZstd;
  } else if (text == "lz4") {
    out = Compression::kLz4;
  } else {
    return false;
  }
  return true;
}

const char* to_string(Compression compression) {
  switch (compression) {
    case Compression::kZstd: return "zstd";
    case Compression::kLz4: return "lz4";
    case Compression::kNone: break;
  }
  return "none";
}

uint32_t crc32(uint32_t crc, const void* data, std::size_t size) {
  const auto& t = crc_tables().t;
  const auto* p = static_cast<const uint8_t*>(data);
  uint32_t c = ~crc;
  while (size >= 8) {
    uint32_t lo, hi;
    std::memcpy(&lo, p, 4);
    std::memcpy(&hi, p + 4, 4);
    lo ^= c;
    c = t[7][lo & 0xFF] ^ t[6][(lo >> 8) & 0xFF] ^ t[5][(lo >> 16) & 0xFF] ^ t[4][lo >> 24] ^ t[3][hi & 0xFF] ^
        t[2][(hi >> 8) & 0xFF] ^ t[1][(hi >> 16) & 0xFF] ^ t[0][hi >> 24];
    p += 8;
    size -= 8;
  }
  while (size-- > 0) c = t[0][(c ^ *p++) & 0xFF] ^ (c >> 8);
  return ~c;
}

// ---------------------------------------------------------------- Writer

Writer::Writer() = default;

Writer::~Writer() {
  if (file_ != nullptr) close();
  if (zstd_ != nullptr) ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_));
}

bool Writer::is_open() const { return file_ != nullptr; }

Status Writer::write_status() const { return error_.empty() ? Status() : Status::error(error_); }

Status Writer::open(const std::string& path, const WriterOptions& options) {
  if (file_ != nullptr) return Status::error("already open");
  options_ = options;
  path_ = path;
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  std::error_code ec;
  if (!folder.empty()) std::filesystem::create_directories(folder, ec);
  if (ec) return Status::error("cannot create the folder of '" + path + "': " + ec.message());
  file_ = std::fopen(path.c_str(), "wb");
  if (file_ == nullptr) return Status::error("cannot write '" + path + "': " + std::strerror(errno));
  std::setvbuf(file_, nullptr, _IOFBF, 1 << 20);
  if (options_.compression == Compression::kZstd && zstd_ == nullptr) zstd_ = ZSTD_createCCtx();
  offset_ = 0;
  data_crc_ = 0;
  in_data_ = true;
  put(kMagic, sizeof(kMagic));
  scratch_.clear();
  const auto at = begin_record(scratch_, kHeader);
  put_string(scratch_, options_.profile);
  put_string(scratch_, options_.library);
  end_record(scratch_, at);
  flush_scratch();
  if (options_.chunk_size > 0) chunk_.reserve(options_.chunk_size + (options_.chunk_size >> 2));
  return write_status();
}

void Writer::put(const void* data, std::size_t size) {
  if (file_ == nullptr || size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size && error_.empty())
    error_ = "cannot write '" + path_ + "': " + std::strerror(errno);
  if (in_data_) data_crc_ = crc32(data_crc_, data, size);
  offset_ += size;
}

void Writer::flush_scratch() {
  put(scratch_.data(), scratch_.size());
  scratch_.clear();
}

std::vector<uint8_t>& Writer::records_out() { return options_.chunk_size > 0 ? chunk_ : scratch_; }

void Writer::append_schema(std::vector<uint8_t>& out, uint16_t id, const SchemaState& schema) const {
  const auto at = begin_record(out, kSchema);
  put_le<uint16_t>(out, id);
  put_string(out, schema.name);
  put_string(out, schema.encoding);
  put_le<uint32_t>(out, static_cast<uint32_t>(schema.data.size()));
  put_bytes(out, schema.data.data(), schema.data.size());
  end_record(out, at);
}

void Writer::append_channel(std::vector<uint8_t>& out, uint16_t id, const ChannelState& channel) const {
  const auto at = begin_record(out, kChannel);
  put_le<uint16_t>(out, id);
  put_le<uint16_t>(out, channel.schema_id);
  put_string(out, channel.topic);
  put_string(out, channel.message_encoding);
  std::vector<uint8_t> map;
  for (const auto& [k, v] : channel.metadata) {
    put_string(map, k);
    put_string(map, v);
  }
  put_le<uint32_t>(out, static_cast<uint32_t>(map.size()));
  put_bytes(out, map.data(), map.size());
  end_record(out, at);
}

uint16_t Writer::add_schema(std::string_view name, std::string_view encoding, const void* data, std::size_t size) {
  SchemaState s{std::string(name), std::string(encoding), {}};
  s.data.assign(static_cast<const uint8_t*>(data), static_cast<const uint8_t*>(data) + size);
  schemas_.push_back(std::move(s));
  const auto id = static_cast<uint16_t>(schemas_.size());
  append_schema(records_out(), id, schemas_.back());
  if (options_.chunk_size == 0) flush_scratch();
  return id;
}

uint16_t Writer::add_channel(uint16_t schema_id, std::string_view topic, std::string_view message_encoding,
                             const std::map<std::string, std::string>& metadata) {
  ChannelState c;
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  channels_.push_back(std::move(c));
  const auto id = static_cast<uint16_t>(channels_.size());
  append_channel(records_out(), id, channels_.back());
  if (options_.chunk_size == 0) flush_scratch();
  return id;
}

Status Writer::write(uint16_t channel_id, uint32_t sequence, uint64_t log_time, uint64_t publish_time, const void* data,
                     std::size_t size) {
  if (file_ == nullptr) return Status::error("not open");
  if (channel_id == 0 || channel_id > channels_.size())
    return Status::error("no channel " + std::to_string(channel_id));
  ChannelState& channel = channels_[channel_id - 1];
  std::vector<uint8_t>& out = records_out();
  if (options_.chunk_size > 0) {
    channel.index.emplace_back(log_time, out.size());
    if (chunk_messages_ == 0 || log_time < chunk_start_) chunk_start_ = log_time;
    if (chunk_messages_ == 0 || log_time > chunk_end_) chunk_end_ = log_time;
    ++chunk_messages_;
  }
  out.push_back(kMessage);
  put_le<uint64_t>(out, 2 + 4 + 8 + 8 + size);
  put_le<uint16_t>(out, channel_id);
  put_le<uint32_t>(out, sequence);
  put_le<uint64_t>(out, log_time);
  put_le<uint64_t>(out, publish_time);
  put_bytes(out, data, size);
  if (message_count_ == 0 || log_time < start_time_) start_time_ = log_time;
  if (message_count_ == 0 || log_time > end_time_) end_time_ = log_time;
  ++message_count_;
  ++channel.count;
  if (options_.chunk_size == 0) {
    flush_scratch();
  } else if (chunk_.size() >= options_.chunk_size) {
    close_chunk();
  }
  return write_status();
}

void Writer::close_chunk() {
  if (chunk_.empty()) return;
  const uint32_t crc = crc32(0, chunk_.data(), chunk_.size());
  const uint8_t* body = chunk_.data();
  std::size_t body_size = chunk_.size();
  std::string_view compression;
  if (options_.compression == Compression::kZstd) {
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compressCCtx(static_cast<ZSTD_CCtx*>(zstd_), compressed_.data(), compressed_.size(),
                                            chunk_.data(), chunk_.size(), options_.zstd_level);
    if (!ZSTD_isError(n)) {
      body = compressed_.data();
      body_size = n;
      compression = "zstd";
    }
  } else if (options_.compression == Compression::kLz4) {
    LZ4F_preferences_t prefs{};
    prefs.frameInfo.contentSize = chunk_.size();
    compressed_.resize(LZ4F_compressFrameBound(chunk_.size(), &prefs));
    const std::size_t n =
        LZ4F_compressFrame(compressed_.data(), compressed_.size(), chunk_.data(), chunk_.size(), &prefs);
    if (!LZ4F_isError(n)) {
      body = compressed_.data();
      body_size = n;
      compression = "lz4";
    }
  }
  ChunkIndex index;
  index.start_time = chunk_messages_ > 0 ? chunk_start_ : 0;
  index.end_time = chunk_messages_ > 0 ? chunk_end_ : 0;
  index.offset = offset_;
  index.compression = compression;
  index.compressed_size = body_size;
  index.uncompressed_size = chunk_.size();
  scratch_.clear();
  scratch_.push_back(kChunk);
  put_le<uint64_t>(scratch_, 8 + 8 + 8 + 4 + 4 + compression.size() + 8 + body_size);
  put_le<uint64_t>(scratch_, index.start_time);
  put_le<uint64_t>(scratch_, index.end_time);
  put_le<uint64_t>(scratch_, chunk_.size());
  put_le<uint32_t>(scratch_, crc);
  put_string(scratch_, compression);
  put_le<uint64_t>(scratch_, body_size);
  flush_scratch();
  put(body, body_size);
  index.length = offset_ - index.offset;
  // One MessageIndex per channel that has messages in the chunk.
  const uint64_t indexes_start = offset_;
  index.first_offset = index_offsets_.size();
  for (std::size_t c = 0; c < channels_.size(); ++c) {
    auto& entries = channels_[c].index;
    if (entries.empty()) continue;
    index_offsets_.emplace_back(static_cast<uint16_t>(c + 1), offset_);
    scratch_.push_back(kMessageIndex);
    put_le<uint64_t>(scratch_, 2 + 4 + 16 * entries.size());
    put_le<uint16_t>(scratch_, static_cast<uint16_t>(c + 1));
    put_le<uint32_t>(scratch_, static_cast<uint32_t>(16 * entries.size()));
    for (const auto& [time, at] : entries) {
      put_le<uint64_t>(scratch_, time);
      put_le<uint64_t>(scratch_, at);
    }
    flush_scratch();
    entries.clear();
  }
  index.offsets = index_offsets_.size() - index.first_offset;
  index.index_length = offset_ - indexes_start;
  chunk_indexes_.push_back(index);
  chunk_.clear();
  chunk_messages_ = 0;
}

void Writer::append_statistics(std::vector<uint8_t>& out) const {
  const auto at = begin_record(out, kStatistics);
  put_le<uint64_t>(out, message_count_);
  put_le<uint16_t>(out, static_cast<uint16_t>(schemas_.size()));
  put_le<uint32_t>(out, static_cast<uint32_t>(channels_.size()));
  put_le<uint32_t>(out, 0);  // attachments
  put_le<uint32_t>(out, 0);  // metadata
  put_le<uint32_t>(out, static_cast<uint32_t>(chunk_indexes_.size()));
  put_le<uint64_t>(out, message_count_ > 0 ? start_time_ : 0);
  put_le<uint64_t>(out, message_count_ > 0 ? end_time_ : 0);
  put_le<uint32_t>(out, static_cast<uint32_t>(channels_.size() * 10));
  for (std::size_t i = 0; i < channels_.size(); ++i) {
    put_le<uint16_t>(out, static_cast<uint16_t>(i + 1));
    put_le<uint64_t>(out, channels_[i].count);
  }
  end_record(out, at);
}

void Writer::append_chunk_indexes(std::vector<uint8_t>& out) const {
  for (const ChunkIndex& c : chunk_indexes_) {
    const auto at = begin_record(out, kChunkIndex);
    put_le<uint64_t>(out, c.start_time);
    put_le<uint64_t>(out, c.end_time);
    put_le<uint64_t>(out, c.offset);
    put_le<uint64_t>(out, c.length);
    put_le<uint32_t>(out, static_cast<uint32_t>(c.offsets * 10));
    for (std::size_t k = c.first_offset; k < c.first_offset + c.offsets; ++k) {
      put_le<uint16_t>(out, index_offsets_[k].first);
      put_le<uint64_t>(out, index_offsets_[k].second);
    }
    put_le<uint64_t>(out, c.index_length);
    put_string(out, c.compression);
    put_le<uint64_t>(out, c.compressed_size);
    put_le<uint64_t>(out, c.uncompressed_size);
    end_record(out, at);
  }
}

Status Writer::close() {
  if (file_ == nullptr) return write_status();
  if (options_.chunk_size > 0) close_chunk();
  scratch_.clear();
  auto at = begin_record(scratch_, kDataEnd);
  put_le<uint32_t>(scratch_, data_crc_);  // of everything before this record, the leading magic included
  end_record(scratch_, at);
  flush_scratch();
  in_data_ = false;

  // The summary: every schema and channel again, the statistics, the chunk indexes.
  const uint64_t summary_start = offset_;
  std::vector<uint8_t> summary;
  struct Group {
    uint8_t op;
    uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](uint8_t op, std::size_t from) {
    if (summary.size() > from) groups.push_back({op, summary_start + from, summary.size() - from});
  };
  std::size_t from = summary.size();
  for (std::size_t i = 0; i < schemas_.size(); ++i) append_schema(summary, static_cast<uint16_t>(i + 1), schemas_[i]);
  group(kSchema, from);
  from = summary.size();
  for (std::size_t i = 0; i < channels_.size(); ++i)
    append_channel(summary, static_cast<uint16_t>(i + 1), channels_[i]);
  group(kChannel, from);
  from = summary.size();
  append_statistics(summary);
  group(kStatistics, from);
  from = summary.size();
  append_chunk_indexes(summary);
  group(kChunkIndex, from);
  const uint64_t summary_offset_start = summary_start + summary.size();
  for (const Group& g : groups) {
    at = begin_record(summary, kSummaryOffset);
    summary.push_back(g.op);
    put_le<uint64_t>(summary, g.start);
    put_le<uint64_t>(summary, g.length);
    end_record(summary, at);
  }
  // The footer; its CRC covers the summary, the summary offsets and the
  // footer's own fields before the CRC.
  summary.push_back(kFooter);
  put_le<uint64_t>(summary, 20);
  put_le<uint64_t>(summary, summary_start);
  put_le<uint64_t>(summary, summary_offset_start);
  put_le<uint32_t>(summary, crc32(0, summary.data(), summary.size()));
  put(summary.data(), summary.size());
  put(kMagic, sizeof(kMagic));
  if (std::fclose(file_) != 0 && error_.empty()) error_ = "cannot write '" + path_ + "': " + std::strerror(errno);
  file_ = nullptr;
  return write_status();
}

// ---------------------------------------------------------------- Reader

Reader::Reader() = default;

Reader::~Reader() {
  if (data_ != nullptr) munmap(const_cast<uint8_t*>(data_), size_);
}

Status Reader::fail(uint64_t offset, const std::string& what) const {
  return Status::error(path_ + ": at offset " + std::to_string(offset) + ": " + what);
}

const Channel* Reader::find_channel(std::string_view topic) const {
  for (const auto& [id, c] : channels_)
    if (c.topic == topic) return &c;
  return nullptr;
}

const Schema* Reader::schema_of(const Channel& channel) const {
  auto it = schemas_.find(channel.schema_id);
  return it == schemas_.end() ? nullptr : &it->second;
}

Status Reader::open(const std::string& path, bool salvage) {
  path_ = path;
  salvage_open_ = salvage;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::error("cannot read '" + path + "': " + std::strerror(errno));
  struct stat st {};
  if (fstat(fd, &st) != 0) {
    ::close(fd);
    return Status::error("cannot read '" + path + "': " + std::strerror(errno));
  }
  size_ = static_cast<uint64_t>(st.st_size);
  if (size_ > 0) {
    void* m = mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    if (m == MAP_FAILED) {
      ::close(fd);
      return Status::error("cannot map '" + path + "': " + std::strerror(errno));
    }
    data_ = static_cast<const uint8_t*>(m);
  }
  ::close(fd);

  if (size_ < sizeof(kMagic) || std::memcmp(data_, kMagic, sizeof(kMagic)) != 0)
    return fail(0, "not an MCAP file (no MCAP magic at its start)");
  // The Header.
  const uint64_t h = sizeof(kMagic);
  uint64_t len = 0;
  if (size_ < h + kRecordHeader) return fail(h, "truncated: the Header record is cut");
  std::memcpy(&len, data_ + h + 1, 8);
  if (data_[h] != kHeader)
    return fail(h, std::string("the first record is a ") + op_name(data_[h]) + ", not the Header");
  if (len > size_ - h - kRecordHeader) return fail(h, "truncated: the Header record runs past the end of the file");
  Cursor header(data_ + h + kRecordHeader, len);
  if (!header.string(profile_) || !header.string(library_)) return fail(h, "the Header record is malformed");
  data_start_ = h + kRecordHeader + len;
  data_end_ = size_;

  // The footer and the summary.
  std::string problem;
  const bool has_footer = size_ >= data_start_ + kFooterRecord + sizeof(kMagic) &&
                          std::memcmp(data_ + size_ - sizeof(kMagic), kMagic, sizeof(kMagic)) == 0 &&
                          data_[size_ - sizeof(kMagic) - kFooterRecord] == kFooter;
  if (!has_footer) {
    problem = "no Footer and closing magic at the end of the file (" + std::to_string(size_) +
              " bytes): truncated, or the recording was not closed";
  } else {
    problem = read_summary().message();
  }
  if (problem.empty()) return {};
  if (has_summary_) {
    // A summary that is there but broken: named with its offset.
    has_summary_ = false;
    schemas_.clear();
    channels_.clear();
    chunks_.clear();
    has_statistics_ = false;
  }
  // Scan the data section for where the damage starts (the offset to report)
  // and, when salvaging, for the schemas and channels before it.
  const std::string scan = scan_definitions().message();
  if (!has_footer) {
    problem = scan.empty() ? fail(size_, problem).message() : scan + "; " + problem;
    data_end_ = size_;  // the reader stops where records stop, and reads a cut uncompressed chunk's whole records
  } else if (!scan.empty()) {
    problem += "; " + scan.substr(path_.size() + 2);
  }
  if (!salvage) return Status::error(problem + " (salvage reads the messages before the damage)");
  warnings_.push_back(problem);
  return {};
}

Status Reader::read_summary() {
  const uint64_t footer = size_ - sizeof(kMagic) - kFooterRecord;
  uint64_t len = 0;
  std::memcpy(&len, data_ + footer + 1, 8);
  if (len != 20) return fail(footer, "the Footer record's length is " + std::to_string(len) + ", not 20");
  uint64_t summary_start = 0, offsets_start = 0;
  uint32_t crc = 0;
  std::memcpy(&summary_start, data_ + footer + 9, 8);
  std::memcpy(&offsets_start, data_ + footer + 17, 8);
  std::memcpy(&crc, data_ + footer + 25, 4);
  if (summary_start == 0) {
    // A valid file without a summary: the data section holds everything.
    data_end_ = footer;
    return scan_definitions();
  }
  if (summary_start < data_start_ || summary_start > footer ||
      (offsets_start != 0 && (offsets_start < summary_start || offsets_start > footer)))
    return fail(footer, "the Footer points outside the file (summary at " + std::to_string(summary_start) + ")");
  if (crc != 0) {
    const uint32_t actual = crc32(0, data_ + summary_start, footer + 9 + 16 - summary_start);
    if (actual != crc) return fail(summary_start, "the summary's CRC does not match (the summary is corrupted)");
  }
  has_summary_ = true;
  const uint64_t end = offsets_start != 0 ? offsets_start : footer;
  uint64_t pos = summary_start;
  while (pos < end) {
    if (end - pos < kRecordHeader) return fail(pos, "a summary record is cut");
    const uint8_t op = data_[pos];
    std::memcpy(&len, data_ + pos + 1, 8);
    if (len > end - pos - kRecordHeader)
      return fail(pos, std::string("the summary's ") + op_name(op) + " record runs past the summary");
    const uint8_t* p = data_ + pos + kRecordHeader;
    Cursor c(p, len);
    if (op == kSchema || op == kChannel) {
      if (Status parsed = parse_definition(op, p, len, pos); !parsed.ok()) return parsed;
    } else if (op == kChunkIndex) {
      uint64_t start_time, end_time, offset, length, index_length;
      Cursor offsets(nullptr, 0);
      ChunkRef ref;
      if (!c.get(start_time) || !c.get(end_time) || !c.get(offset) || !c.get(length) || !c.block(offsets))
        return fail(pos, "a ChunkIndex record is malformed");
      while (!offsets.done()) {
        uint16_t channel;
        uint64_t at;
        if (!offsets.get(channel) || !offsets.get(at))
          return fail(pos, "a ChunkIndex's message index offsets are malformed");
        ref.channels.push_back(channel);
      }
      if (!c.get(index_length)) return fail(pos, "a ChunkIndex record is malformed");
      if (offset < data_start_ || offset > size_ || length > size_ - offset)
        return fail(pos, "a ChunkIndex points outside the file (chunk at " + std::to_string(offset) + ")");
      ref.offset = offset;
      ref.length = length;
      chunks_.push_back(std::move(ref));
    } else if (op == kStatistics) {
      Statistics& s = statistics_;
      Cursor counts(nullptr, 0);
      if (!c.get(s.message_count) || !c.get(s.schema_count) || !c.get(s.channel_count) || !c.get(s.attachment_count) ||
          !c.get(s.metadata_count) || !c.get(s.chunk_count) || !c.get(s.message_start_time) ||
          !c.get(s.message_end_time) || !c.block(counts))
        return fail(pos, "the Statistics record is malformed");
      while (!counts.done()) {
        uint16_t channel;
        uint64_t count;
        if (!counts.get(channel) || !counts.get(count))
          return fail(pos, "the Statistics' channel counts are malformed");
        s.channel_message_counts[channel] = count;
      }
      has_statistics_ = true;
    }
    pos += kRecordHeader + len;
  }
  std::sort(chunks_.begin(), chunks_.end(), [](const ChunkRef& a, const ChunkRef& b) { return a.offset < b.offset; });
  // The data section ends at the DataEnd record before the summary.
  data_end_ = summary_start;
  return {};
}

Status Reader::parse_definition(uint8_t op, const uint8_t* p, uint64_t len, uint64_t offset) {
  Cursor c(p, len);
  if (op == kSchema) {
    Schema s;
    if (!c.get(s.id) || !c.string(s.name) || !c.string(s.encoding) || !c.bytes32(s.data))
      return fail(offset, "a Schema record is malformed");
    if (s.id != 0) schemas_[s.id] = std::move(s);
    return {};
  }
  Channel ch;
  Cursor meta(nullptr, 0);
  if (!c.get(ch.id) || !c.get(ch.schema_id) || !c.string(ch.topic) || !c.string(ch.message_encoding) || !c.block(meta))
    return fail(offset, "a Channel record is malformed");
  while (!meta.done()) {
    std::string k, v;
    if (!meta.string(k) || !meta.string(v)) return fail(offset, "a Channel record's metadata is malformed");
    ch.metadata[k] = v;
  }
  channels_[ch.id] = std::move(ch);
  return {};
}

void Reader::read_chunk_definitions(uint64_t offset) {
  Cursor inner(chunk_data_, chunk_size_);
  while (inner.left() >= kRecordHeader) {
    const uint8_t op = *inner.here();
    uint64_t len = 0;
    std::memcpy(&len, inner.here() + 1, 8);
    if (len > inner.left() - kRecordHeader) break;
    if (op == kSchema || op == kChannel) (void)parse_definition(op, inner.here() + kRecordHeader, len, offset);
    inner.skip(kRecordHeader + len);
  }
}

Status Reader::scan_definitions() {
  uint64_t pos = data_start_;
  const uint64_t end = data_end_;
  while (pos < end) {
    if (end - pos < kRecordHeader) {
      data_end_ = pos;
      return fail(pos, "truncated: a record's header is cut");
    }
    const uint8_t op = data_[pos];
    uint64_t len = 0;
    std::memcpy(&len, data_ + pos + 1, 8);
    if (op == kDataEnd || op == kFooter) {
      data_end_ = pos;
      return {};
    }
    if (len > end - pos - kRecordHeader) {
      data_end_ = pos;
      // A cut chunk may still hold whole records (uncompressed chunks).
      if (op == kChunk && load_chunk(pos, end - pos, true).ok()) read_chunk_definitions(pos);
      return fail(pos, std::string("truncated: a ") + op_name(op) + " record of " + std::to_string(len) +
                           " bytes runs past the end of the file (" + std::to_string(size_) + " bytes)");
    }
    const uint8_t* p = data_ + pos + kRecordHeader;
    if (op == kSchema || op == kChannel) {
      if (Status parsed = parse_definition(op, p, len, pos); !parsed.ok()) {
        data_end_ = pos;
        return parsed;
      }
    } else if (op == kChunk) {
      // A chunk that does not load is reported where its messages are read.
      if (load_chunk(pos, kRecordHeader + len, false).ok()) read_chunk_definitions(pos);
    } else if (op < kHeader || op > kDataEnd) {
      data_end_ = pos;
      return fail(pos, "corrupted: a record with opcode " + std::to_string(op) + ", which MCAP does not have");
    }
    pos += kRecordHeader + len;
  }
  return {};
}

Status Reader::load_chunk(uint64_t offset, uint64_t length, bool allow_cut) {
  if (length < kRecordHeader || data_[offset] != kChunk) return fail(offset, "no Chunk record where its index points");
  Cursor c(data_ + offset + kRecordHeader, length - kRecordHeader);
  uint64_t start_time, end_time, uncompressed_size, records_size;
  uint32_t crc;
  std::string compression;
  if (!c.get(start_time) || !c.get(end_time) || !c.get(uncompressed_size) || !c.get(crc) || !c.string(compression) ||
      !c.get(records_size))
    return fail(offset, "a Chunk record's header is malformed or cut");
  bool cut = false;
  if (records_size > c.left()) {
    if (!allow_cut || !compression.empty()) return fail(offset, "a Chunk's records run past the end of the record");
    records_size = c.left();
    cut = true;
  }
  const uint8_t* records = c.here();
  chunk_offset_ = offset;
  if (compression.empty()) {
    if (!cut && records_size != uncompressed_size)
      return fail(offset,
                  "an uncompressed Chunk's size (" + std::to_string(records_size) + ") differs from its header's");
    chunk_data_ = records;
    chunk_size_ = records_size;
  } else {
    if (uncompressed_size > kMaxChunk)
      return fail(offset, "a Chunk claims " + std::to_string(uncompressed_size) + " bytes uncompressed");
    if (compression == "zstd") {
      if (Status unpacked = decompress_zstd(records, records_size, uncompressed_size, chunk_); !unpacked.ok())
        return fail(offset, "a zstd Chunk " + unpacked.message());
      if (chunk_.size() != uncompressed_size)
        return fail(offset, "a zstd Chunk decompresses to " + std::to_string(chunk_.size()) + " bytes, not " +
                                std::to_string(uncompressed_size));
    } else if (compression == "lz4") {
      // LZ4 makes at most 255 bytes of one (a match's length byte), so the
      // claim is checked before it is allocated.
      if (uncompressed_size / 256 > records_size)
        return fail(offset, "an lz4 Chunk of " + std::to_string(records_size) + " bytes cannot hold " +
                                std::to_string(uncompressed_size) + " bytes uncompressed");
      chunk_.resize(uncompressed_size);
      LZ4F_dctx* dctx = nullptr;
      if (LZ4F_isError(LZ4F_createDecompressionContext(&dctx, LZ4F_VERSION)))
        return fail(offset, "no lz4 decompression context");
      std::size_t out_at = 0, in_at = 0;
      std::size_t hint = 1;
      while (hint != 0 && in_at < records_size) {
        std::size_t out_n = chunk_.size() - out_at, in_n = records_size - in_at;
        hint = LZ4F_decompress(dctx, chunk_.data() + out_at, &out_n, records + in_at, &in_n, nullptr);
        if (LZ4F_isError(hint)) {
          LZ4F_freeDecompressionContext(dctx);
          return fail(offset, std::string("an lz4 Chunk does not decompress: ") + LZ4F_getErrorName(hint));
        }
        out_at += out_n;
        in_at += in_n;
        if (out_n == 0 && in_n == 0) break;
      }
      LZ4F_freeDecompressionContext(dctx);
      if (hint != 0 || out_at != uncompressed_size)
        return fail(offset, "an lz4 Chunk decompresses to " + std::to_string(out_at) + " bytes, not " +
                                std::to_string(uncompressed_size));
    } else {
      return fail(offset,
                  "a Chunk compressed with '" + compression + "', which this reader does not know (none, zstd, lz4)");
    }
    chunk_data_ = chunk_.data();
    chunk_size_ = chunk_.size();
  }
  if (crc != 0 && !cut && crc32(0, chunk_data_, chunk_size_) != crc)
    return fail(offset, "a Chunk's CRC does not match its records (the file is corrupted)");
  return {};
}

void Reader::rewind(const ReadOptions& options) {
  read_ = options;
  read_.salvage = options.salvage || salvage_open_;
  indexed_ = has_summary_ && !chunks_.empty();
  next_chunk_ = 0;
  pos_ = data_start_;
  in_chunk_ = false;
  done_ = false;
  skipped_ = 0;
}

bool Reader::wanted(uint16_t channel) const {
  return read_.channels.empty() ||
         std::find(read_.channels.begin(), read_.channels.end(), channel) != read_.channels.end();
}

Result<bool> Reader::next_in_chunk(MessageView& out) {
  while (chunk_pos_ < chunk_size_) {
    const uint64_t at = chunk_pos_;
    if (chunk_size_ - at < kRecordHeader)
      return fail(chunk_offset_, "a record inside the Chunk is cut at byte " + std::to_string(at) + " of its records");
    const uint8_t op = chunk_data_[at];
    uint64_t len = 0;
    std::memcpy(&len, chunk_data_ + at + 1, 8);
    if (len > chunk_size_ - at - kRecordHeader)
      return fail(chunk_offset_, std::string("a ") + op_name(op) + " record inside the Chunk runs past its end (byte " +
                                     std::to_string(at) + " of its records)");
    chunk_pos_ = at + kRecordHeader + len;
    if (op != kMessage) continue;
    if (len < kMessageFields)
      return fail(chunk_offset_, "a Message record inside the Chunk is shorter than its fields");
    read_message(chunk_data_ + at + kRecordHeader, len, chunk_offset_, out);
    if (!wanted(out.channel_id)) continue;
    return true;
  }
  in_chunk_ = false;
  return false;
}

Result<bool> Reader::next_linear(MessageView& out) {
  while (pos_ < data_end_) {
    const uint64_t at = pos_;
    if (data_end_ - at < kRecordHeader) return fail(at, "truncated: a record's header is cut");
    const uint8_t op = data_[at];
    uint64_t len = 0;
    std::memcpy(&len, data_ + at + 1, 8);
    if (op == kDataEnd) return false;
    if (len > data_end_ - at - kRecordHeader) {
      if (op == kChunk && read_.salvage) {
        // Reads a cut uncompressed chunk up to where it stops.
        pos_ = data_end_;
        if (load_chunk(at, data_end_ - at, true).ok()) {
          chunk_pos_ = 0;
          in_chunk_ = true;
          return false;  // the caller reads the chunk
        }
      }
      return fail(at, std::string("truncated: a ") + op_name(op) + " record runs past the readable end (" +
                          std::to_string(data_end_) + ")");
    }
    pos_ = at + kRecordHeader + len;
    if (op == kMessage) {
      if (len < kMessageFields) return fail(at, "a Message record is shorter than its fields");
      read_message(data_ + at + kRecordHeader, len, at, out);
      if (!wanted(out.channel_id)) continue;
      return true;
    }
    if (op == kChunk) {
      if (Status loaded = load_chunk(at, kRecordHeader + len, false); !loaded.ok()) return loaded;
      chunk_pos_ = 0;
      in_chunk_ = true;
      return false;
    }
    if (op < kHeader || op > kDataEnd) {
      pos_ = data_end_;  // no way to find the next record
      return fail(at, "corrupted: a record with opcode " + std::to_string(op) + ", which MCAP does not have");
    }
  }
  return false;
}

Result<bool> Reader::next(MessageView& out) {
  if (data_ == nullptr) return Status::error("not open");
  while (!done_) {
    if (in_chunk_) {
      const Result<bool> r = next_in_chunk(out);
      if (r.ok() && *r) return true;
      if (!r.ok()) {
        in_chunk_ = false;
        if (!read_.salvage) return r;
        warnings_.push_back(r.error());
        ++skipped_;
      }
      continue;
    }
    if (indexed_) {
      if (next_chunk_ >= chunks_.size()) {
        done_ = true;
        break;
      }
      const ChunkRef& ref = chunks_[next_chunk_++];
      if (!read_.channels.empty()) {
        bool any = false;
        for (uint16_t ch : ref.channels) any = any || wanted(ch);
        if (!any) continue;
      }
      if (Status loaded = load_chunk(ref.offset, ref.length, false); !loaded.ok()) {
        if (!read_.salvage) return loaded;
        warnings_.push_back(loaded.message());
        ++skipped_;
        continue;
      }
      chunk_pos_ = 0;
      in_chunk_ = true;
      continue;
    }
    const uint64_t before = pos_;
    const Result<bool> r = next_linear(out);
    if (r.ok() && *r) return true;
    if (r.ok() && in_chunk_) continue;
    if (r.ok()) {
      done_ = true;
      break;
    }
    if (!read_.salvage) return r;
    warnings_.push_back(r.error());
    ++skipped_;
    if (pos_ <= before) {  // nothing to resume from
      done_ = true;
      break;
    }
  }
  return false;
}

}  // namespace saccade::mcap
