// What DDS processes of this host leave in /dev/shm, and the participant id a
// new process takes (plugins/dds/shared_memory.hpp): a killed reader's
// shared-memory port is removed once no writer maps it, and never given to a
// new process while one does.
#include <fcntl.h>
#include <sys/file.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "shared_memory.hpp"

namespace fs = std::filesystem;
using saccade::dds::free_participant_id;
using saccade::dds::remove_stale_shared_memory;
using saccade::dds::unicast_ports;

namespace {

void touch(const fs::path& path, std::size_t bytes = 0) {
  std::ofstream out(path, std::ios::binary);
  out << std::string(bytes, '\0');
}

bool removed(const saccade::dds::StaleSharedMemory& stale, const std::string& name) {
  return std::find(stale.removed.begin(), stale.removed.end(), name) != stale.removed.end();
}

// A port number below every domain's (7400 + 250 d): no Fast DDS process here uses it.
std::string test_port(int k) { return "fastrtps_port" + std::to_string(7000 + 4 * (getpid() % 100) + k); }

}  // namespace

TEST(FreeParticipantId, TakesTheLowestIdWhosePortsHaveNoFile) {
  const fs::path dir = fs::temp_directory_path() / ("saccade_shm_ids_" + std::to_string(getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const int domain = 7;
  EXPECT_EQ(unicast_ports(domain, 0), std::make_pair(9160, 9161)) << "RTPS' well-known ports";
  EXPECT_EQ(free_participant_id(domain, dir.string()), 0);
  touch(dir / ("fastrtps_port" + std::to_string(unicast_ports(domain, 0).first)));
  EXPECT_EQ(free_participant_id(domain, dir.string()), 1) << "id 0's metatraffic port has a file";
  touch(dir / ("fastrtps_port" + std::to_string(unicast_ports(domain, 1).second) + "_el"));
  EXPECT_EQ(free_participant_id(domain, dir.string()), 2) << "id 1's user port has a lock file";
  EXPECT_EQ(free_participant_id(domain + 1, dir.string()), 0) << "another domain's ports";
  // The last domain has room for 63 ids under port 65536; all held, Fast DDS chooses.
  for (int id = 0; id < 63; ++id) touch(dir / ("fastrtps_port" + std::to_string(unicast_ports(232, id).first)));
  EXPECT_EQ(unicast_ports(232, 62).second, 65535);
  EXPECT_EQ(free_participant_id(232, dir.string()), -1);
  fs::remove_all(dir);
}

TEST(StaleSharedMemory, ADeadListenersPortIsRemovedOnceNoWriterMapsIt) {
  const fs::path shm = "/dev/shm";
  const std::string dead = test_port(0), listening = test_port(1), written = test_port(2), shared = test_port(3);
  for (const auto& port : {dead, listening, written}) {
    touch(shm / port, 4096);
    touch(shm / (port + "_el"));
  }
  touch(shm / shared, 4096);
  // A port that outlived its users (one of them was killed, and its count of
  // users stayed up): a shared one (discovery's), whose listeners hold "_sl".
  touch(shm / (shared + "_sl"));
  // A live listener holds its port's exclusive lock.
  const int lock = ::open((shm / (listening + "_el")).c_str(), O_RDONLY | O_CLOEXEC);
  ASSERT_GE(lock, 0);
  ASSERT_EQ(::flock(lock, LOCK_EX | LOCK_NB), 0);
  // A live writer still maps the port of a listener that died.
  const int fd = ::open((shm / written).c_str(), O_RDWR | O_CLOEXEC);
  ASSERT_GE(fd, 0);
  void* map = ::mmap(nullptr, 4096, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
  ASSERT_NE(map, MAP_FAILED);

  std::this_thread::sleep_for(std::chrono::milliseconds(2100));  // ports under a second old are never stale
  const auto stale = remove_stale_shared_memory(0);
  EXPECT_TRUE(removed(stale, dead));
  EXPECT_FALSE(fs::exists(shm / dead));
  EXPECT_FALSE(fs::exists(shm / (dead + "_el")));
  EXPECT_FALSE(removed(stale, listening)) << "its listener lives";
  EXPECT_TRUE(fs::exists(shm / listening));
  EXPECT_FALSE(removed(stale, written)) << "a writer maps it";
  EXPECT_TRUE(fs::exists(shm / written));
  EXPECT_TRUE(removed(stale, shared)) << "no lock held, none maps it: its last user was killed";

  // The writer gone too, the port goes.
  ::munmap(map, 4096);
  ::close(fd);
  EXPECT_TRUE(removed(remove_stale_shared_memory(0), written));
  EXPECT_FALSE(fs::exists(shm / written));

  ::close(lock);
  fs::remove(shm / listening);
  for (const auto& file : {listening + "_el", shared + "_sl"}) fs::remove(shm / file);
}
