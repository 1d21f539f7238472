#include "shared_memory.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include "frame_ring.hpp"
#include "mailbox.hpp"

namespace saccade::dds {

namespace fs = std::filesystem;

namespace {

constexpr const char* kShm = "/dev/shm";
// Fast DDS' shared-memory port files: "fastrtps_port<number>" (its default domain name, "fastrtps").
constexpr const char* kPortFile = "fastrtps_port";

// Every file of /dev/shm some process has mapped now (the processes this user may inspect).
std::set<std::string> mapped_shm_files() {
  std::set<std::string> out;
  const std::string prefix = std::string(kShm) + "/";
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator("/proc", ec)) {
    const std::string pid = entry.path().filename().string();
    if (pid.empty() || pid.find_first_not_of("0123456789") != std::string::npos) continue;
    std::ifstream maps(entry.path() / "maps");
    std::string line;
    while (std::getline(maps, line)) {
      auto at = line.find(prefix);
      if (at == std::string::npos) continue;
      std::string name = line.substr(at + prefix.size());
      if (auto deleted = name.find(" (deleted)"); deleted != std::string::npos) name.resize(deleted);
      out.insert(name);
    }
  }
  return out;
}

// Fast DDS' participant segments are held by an flock on "<segment>_el" for
// their owner's lifetime: a lock we can take has no owner left.
bool owner_is_gone(const std::string& lock_file) {
  int fd = ::open(lock_file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return false;
  const bool free = ::flock(fd, LOCK_EX | LOCK_NB) == 0;
  ::close(fd);  // releases the lock
  return free;
}

}  // namespace

StaleSharedMemory remove_stale_shared_memory(double min_age_s) {
  StaleSharedMemory result;
  static const std::regex participant_segment("fastrtps_[0-9a-f]{16}");
  static const std::regex data_sharing_pool("fast_datasharing_[0-9a-f_.]+");
  static const std::regex frame_ring("saccade_ring_[0-9]+_[0-9a-f]{16}");
  static const std::regex mailbox("saccade_mail_[0-9a-f]{16}");
  static const std::regex port(std::string(kPortFile) + "[0-9]+");
  std::error_code ec;
  std::set<std::string> mapped;
  bool mapped_known = false;
  const std::time_t now = std::time(nullptr);
  for (const auto& entry : fs::directory_iterator(kShm, ec)) {
    const std::string name = entry.path().filename().string();
    const bool segment = std::regex_match(name, participant_segment);
    const bool pool = !segment && (std::regex_match(name, data_sharing_pool) || std::regex_match(name, frame_ring) ||
                                   std::regex_match(name, mailbox));
    const bool shm_port = !segment && !pool && std::regex_match(name, port);
    if (!segment && !pool && !shm_port) continue;
    struct stat st {};
    // Only this user's files, and none so young that its owner may still be setting it up.
    // (Never a port under a second old: a process's port is unmapped for a
    // moment after it is made, and no test needs one removed at once.)
    const double min_age = shm_port ? std::max(min_age_s, 1.0) : min_age_s;
    if (::stat(entry.path().c_str(), &st) != 0 || st.st_uid != ::geteuid() ||
        static_cast<double>(now - st.st_ctime) < min_age)
      continue;
    bool stale = false;
    const auto unmapped = [&] {
      if (!mapped_known) {
        mapped = mapped_shm_files();
        mapped_known = true;
      }
      return mapped.count(name) == 0;
    };
    if (segment) {
      stale = owner_is_gone(entry.path().string() + "_el");
    } else if (shm_port) {
      // Its listeners and writers map a port, a live writer perhaps still
      // after its listener died. (A port outlives its last user when a
      // process that used it was killed: its count of users stays up.) A
      // unicast port's listener also holds "<port>_el" while it lives.
      const std::string lock = entry.path().string() + "_el";
      stale = unmapped() && (!fs::exists(lock, ec) || owner_is_gone(lock));
    } else if (std::regex_match(name, frame_ring)) {
      stale = !frame_ring_has_writer(entry.path().string());
    } else if (std::regex_match(name, mailbox)) {
      stale = !mailbox_has_writer(entry.path().string());
    } else {
      // A data-sharing pool is mapped by its writer for the writer's lifetime
      // (and by its readers): seen in /proc only for processes of this pid
      // namespace, so processes that share /dev/shm must share that too.
      stale = unmapped();
    }
    if (!stale) continue;
    const auto bytes = static_cast<uint64_t>(st.st_size);
    if (!fs::remove(entry.path(), ec)) continue;
    if (segment || shm_port) fs::remove(entry.path().string() + "_el", ec);
    result.removed.push_back(name);
    result.bytes += bytes;
  }
  return result;
}

std::pair<int, int> unicast_ports(int domain_id, int participant_id) {
  // Fast DDS' defaults (RTPS' well-known ports): PB 7400, DG 250, PG 2, d1 10, d3 11.
  const int base = 7400 + 250 * domain_id + 2 * participant_id;
  return {base + 10, base + 11};
}

int free_participant_id(int domain_id, const std::string& shm_dir) {
  // Ids whose ports stay within the domain's 250 and under 65536.
  for (int id = 0; id < 120; ++id) {
    const auto [meta, user] = unicast_ports(domain_id, id);
    if (user > 65535) break;
    std::error_code ec;
    const auto held = [&](int number) {
      const std::string file = shm_dir + "/" + kPortFile + std::to_string(number);
      return fs::exists(file, ec) || fs::exists(file + "_el", ec);
    };
    if (!held(meta) && !held(user)) return id;
  }
  return -1;  // every id's ports held: Fast DDS chooses
}

}  // namespace saccade::dds
