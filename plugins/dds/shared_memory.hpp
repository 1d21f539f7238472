#pragma once
// The shared memory DDS processes of this host left behind.
#include <cstdint>
#include <string>
#include <vector>

namespace saccade::dds {

// Shared memory that DDS processes which died without cleaning up (kill -9, a
// crash) left in /dev/shm: Fast DDS participant segments whose owner's lock is
// free, and data-sharing pools, saccade frame rings and mailboxes no process maps. Files younger than `min_age_s`
// are left (their owner may be starting), and other users' files. A clean exit
// (and SIGINT/SIGTERM, which saccade run turns into one) leaves none.
struct StaleSharedMemory {
  std::vector<std::string> removed;  // file names
  uint64_t bytes = 0;
};
StaleSharedMemory remove_stale_shared_memory(double min_age_s = 5.0);

}  // namespace saccade::dds
