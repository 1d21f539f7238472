// saccade_mcap: looks into MCAP files and records graphs into them.
//   saccade_mcap info FILE [--salvage]
//       the file's topics, types, schemas, message counts and time span; with
//       --salvage, what a damaged file still holds and where the damage is
//   saccade_mcap record GRAPH FILE [--compression none|zstd|lz4] [--chunk-kib N]
//                [--ports node.port,...] [--queue N] [--lossless] [--frames N] [--set node.param=value]...
//       runs GRAPH with every connected output (or the named ones) recorded
//       to FILE, as `saccade run GRAPH --record FILE` does, and prints the
//       recorder's report and the graph's rate
//   saccade_mcap compare A B [--topic T]... [--ignore field,...]
//       the messages of each topic (default: the topics both files have) of
//       A and B, in file order, field by field (origin_ns, the time a message
//       was made or replayed, is never compared); exit 1 at the first
//       difference, which it names (message index, frame, field, both values)
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <map>
#include <set>
#include <sstream>

#include <nlohmann/json.hpp>

#include "channel.hpp"
#include "recording.hpp"
#include "saccade/executor.hpp"
#include "saccade/graph.hpp"
#include "saccade/registry.hpp"
#include "saccade/schema.hpp"

namespace {

using namespace saccade;

int usage() {
  std::cerr << "usage: saccade_mcap info FILE [--salvage]\n"
               "       saccade_mcap record GRAPH FILE [--compression none|zstd|lz4] [--chunk-kib N]\n"
               "                    [--ports node.port,...] [--queue N] [--lossless] [--frames N] [--set "
               "node.param=value]...\n"
               "       saccade_mcap compare A B [--topic T]... [--ignore field,...]\n";
  return 2;
}

int info(const std::string& path, bool salvage) {
  mcap::Reader reader;
  if (Status opened = reader.open(path, salvage); !opened.ok()) {
    std::cerr << "error: " << opened.message() << "\n";
    return 1;
  }
  for (const std::string& w : reader.warnings()) std::cerr << "warning: " << w << "\n";
  // Counts from a full read (the statistics may be missing in a damaged file).
  std::map<uint16_t, uint64_t> counts;
  uint64_t first = 0, last = 0, total = 0;
  mcap::MessageView v;
  reader.rewind({salvage, {}});
  Result<bool> read = false;
  while ((read = reader.next(v)).ok() && *read) {
    ++counts[v.channel_id];
    if (total == 0 || v.log_time < first) first = v.log_time;
    if (total == 0 || v.log_time > last) last = v.log_time;
    ++total;
  }
  std::printf("file:     %s (%llu bytes, library '%s', %s)\n", path.c_str(),
              static_cast<unsigned long long>(reader.file_size()), reader.header_library().c_str(),
              reader.has_summary() ? "with its summary" : "no summary: scanned");
  if (const auto* s = reader.statistics()) std::printf("chunks:   %u\n", s->chunk_count);
  std::printf("messages: %llu over %.3f s\n", static_cast<unsigned long long>(total),
              total > 0 ? static_cast<double>(last - first) / 1e9 : 0.0);
  for (const auto& [id, c] : reader.channels()) {
    const mcap::Schema* s = reader.schema_of(c);
    const Result<const dds::ChannelEncoding*> e = mcap::encoding_of(c, s);
    std::printf("  %-28s %8llu  %-14s %s (%s)\n", c.topic.c_str(), static_cast<unsigned long long>(counts[id]),
                e.ok() ? std::string((*e)->type).c_str() : "(not saccade's)", s != nullptr ? s->name.c_str() : "-",
                s != nullptr ? s->encoding.c_str() : "-");
  }
  if (!read.ok()) {
    std::cerr << "error: " << read.error() << "\n";
    return 1;
  }
  if (reader.skipped() > 0)
    std::printf("skipped:  %llu damaged parts\n", static_cast<unsigned long long>(reader.skipped()));
  return 0;
}

int record(const std::vector<std::string>& args) {
  if (args.size() < 2) return usage();
  const std::string graph_file = args[0], path = args[1];
  mcap::RecorderOptions options;
  ExecutorOptions exec;
  std::vector<std::string> overrides;
  for (std::size_t i = 2; i < args.size(); ++i) {
    const std::string& a = args[i];
    auto value = [&]() -> std::string { return i + 1 < args.size() ? args[++i] : std::string(); };
    if (a == "--compression") {
      if (!mcap::parse_compression(value(), options.writer.compression)) return usage();
    } else if (a == "--chunk-kib") {
      options.writer.chunk_size = static_cast<std::size_t>(std::atoll(value().c_str())) * 1024;
    } else if (a == "--queue") {
      options.queue = static_cast<std::size_t>(std::atoll(value().c_str()));
    } else if (a == "--lossless") {
      options.lossless = true;
    } else if (a == "--frames") {
      exec.max_frames = std::atoll(value().c_str());
    } else if (a == "--set") {
      overrides.push_back(value());
    } else if (a == "--ports") {
      std::stringstream list(value());
      for (std::string p; std::getline(list, p, ',');) options.ports.push_back(p);
    } else {
      return usage();
    }
  }
  Registry registry;
  registry.load_folders(Registry::default_search_path());
  Diagnostics diag;
  GraphDecl decl = load_graph_file(graph_file, diag);
  apply_overrides(decl, overrides, diag);
  auto graph = diag.has_errors() ? std::nullopt : resolve_graph(decl, registry, diag);
  if (!graph) {
    std::cerr << diag.format();
    return 2;
  }
  Executor executor(*graph, registry, exec);
  if (Status s = executor.open(); !s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 1;
  }
  Result<std::unique_ptr<mcap::GraphRecorder>> attached = mcap::attach_recorder(executor, path, options);
  if (!attached.ok()) {
    std::cerr << "error: " << attached.error() << "\n";
    return 1;
  }
  const std::unique_ptr<mcap::GraphRecorder> recorder = std::move(attached).value();
  const Status s = executor.run();
  const Status finished = recorder->finish();
  const double seconds = executor.elapsed_s();
  uint64_t frames = 0;
  for (const NodeStats* n : executor.stats()) frames = std::max<uint64_t>(frames, n->emitted.load());
  std::printf("%s\n", recorder->report().c_str());
  std::printf("graph: %.2f s, %.0f messages/s recorded, %.1f MB/s written\n", seconds,
              static_cast<double>(recorder->recorded()) / seconds,
              static_cast<double>(recorder->bytes()) / 1e6 / seconds);
  if (!s.ok()) {
    std::cerr << "error: " << s.message() << "\n";
    return 1;
  }
  if (!finished.ok()) {
    std::cerr << "error: " << finished.message() << "\n";
    return 1;
  }
  return 0;
}

std::string shorten(const std::string& value) { return value.size() > 160 ? value.substr(0, 157) + "..." : value; }

// Ok when the topic's messages are equal in both files, else an error naming
// the first difference (or why a file cannot be read). `compared`: the
// messages compared equal.
Status compare_topic(const std::string& a, const std::string& b, const std::string& topic,
                     const std::set<std::string>& ignored, uint64_t& compared) {
  mcap::TopicReader readers[2];
  const std::string* paths[2] = {&a, &b};
  for (int k = 0; k < 2; ++k)
    if (Status opened = readers[k].open(*paths[k], topic, false); !opened.ok()) return opened;
  std::string json[2];
  for (compared = 0;; ++compared) {
    MessagePtr m[2];
    for (int k = 0; k < 2; ++k) {
      Result<MessagePtr> next = readers[k].next();
      if (!next.ok()) return next.status();
      m[k] = std::move(next).value();
    }
    if (m[0] == nullptr && m[1] == nullptr) return {};
    const std::string where = topic + ": message " + std::to_string(compared);
    if (m[0] == nullptr || m[1] == nullptr)
      return Status::error(where + ": " + (m[0] == nullptr ? a : b) + " ends here, the other goes on");
    for (int k = 0; k < 2; ++k) {
      json[k].clear();
      append_json(json[k], *m[k]);
    }
    // In the order the type names its fields, so the first difference is the first field that differs.
    const auto fa = nlohmann::ordered_json::parse(json[0]), fb = nlohmann::ordered_json::parse(json[1]);
    if (fa.size() != fb.size()) return Status::error(where + ": the messages have different fields");
    for (auto field = fa.begin(); field != fa.end(); ++field) {
      const auto other = fb.find(field.key());
      if (other == fb.end()) return Status::error(where + ": the messages have different fields");
      if (ignored.count(field.key()) != 0 || *field == *other) continue;
      return Status::error(where + " (frame " + std::to_string(m[0]->frame_id) + "): " + field.key() + " is " +
                           shorten(field->dump()) + " in " + a + ", " + shorten(other->dump()) + " in " + b);
    }
  }
}

int compare(const std::vector<std::string>& args) {
  if (args.size() < 2) return usage();
  const std::string a = args[0], b = args[1];
  std::vector<std::string> topics;
  std::set<std::string> ignored = {"origin_ns"};
  for (std::size_t i = 2; i < args.size(); ++i) {
    if (i + 1 >= args.size()) return usage();
    if (args[i] == "--topic") {
      topics.push_back(args[++i]);
    } else if (args[i] == "--ignore") {
      for (const std::string& field : comma_list(args[++i])) ignored.insert(field);
    } else {
      return usage();
    }
  }
  if (topics.empty()) {
    mcap::Reader ra, rb;
    for (auto [reader, path] : {std::pair{&ra, &a}, std::pair{&rb, &b}}) {
      if (Status opened = reader->open(*path); !opened.ok()) {
        std::cerr << "error: " << opened.message() << "\n";
        return 1;
      }
    }
    for (const auto& [id, channel] : ra.channels())
      if (rb.find_channel(channel.topic) != nullptr) topics.push_back(channel.topic);
    if (topics.empty()) {
      std::cerr << "error: " << a << " and " << b << " have no topic in common\n";
      return 1;
    }
  }
  int status = 0;
  for (const std::string& topic : topics) {
    uint64_t compared = 0;
    const Status same = compare_topic(a, b, topic, ignored, compared);
    if (same.ok()) {
      std::printf("%-28s %8llu messages, all equal\n", topic.c_str(), static_cast<unsigned long long>(compared));
    } else {
      std::printf("%-28s differs: %s\n", topic.c_str(), same.message().c_str());
      status = 1;
    }
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> args(argv + 1, argv + argc);
  if (args.size() >= 2 && args[0] == "info") return info(args[1], args.size() > 2 && args[2] == "--salvage");
  if (!args.empty() && args[0] == "record") return record({args.begin() + 1, args.end()});
  if (!args.empty() && args[0] == "compare") return compare({args.begin() + 1, args.end()});
  return usage();
}
