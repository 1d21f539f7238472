#pragma once
// The shared memory DDS processes of this host left behind.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace saccade::dds {

// Shared memory that DDS processes which died without cleaning up (kill -9, a
// crash) left in /dev/shm: Fast DDS participant segments whose owner's lock is
// free; Fast DDS shared-memory ports no process maps (a live writer may still
// hold a dead reader's port) whose listener's lock, if any, is free; and
// data-sharing pools, saccade frame rings and mailboxes no process maps. Files
// younger than `min_age_s` are left (their owner may be starting; ports under
// a second old always), and other users' files. A clean exit (and
// SIGINT/SIGTERM, which saccade run turns into one) leaves none.
struct StaleSharedMemory {
  std::vector<std::string> removed;  // file names
  uint64_t bytes = 0;
};
StaleSharedMemory remove_stale_shared_memory(double min_age_s = 5.0);

// Fast DDS' shared-memory unicast ports of participant `participant_id` in
// domain `domain_id` (its default port numbers: metatraffic, then user data).
std::pair<int, int> unicast_ports(int domain_id, int participant_id);

// The participant id a new participant of `domain_id` takes: the lowest whose
// two shared-memory unicast ports have no file in `shm_dir`. Left to itself,
// Fast DDS gives a process the first id whose ports no live process holds,
// and so a restarted process the id of the one killed before it: it removes
// the dead process's port (its lock free) and makes it anew under the same
// name, while a live peer that wrote to the dead process may keep the old one
// open, and then writes into it for ever (when the killed listener was not
// waiting at its death, nothing marks the old port broken). The restarted
// process, on the new port, never hears that peer. A port of its own that no
// one has held is new to every peer. (Ports a killed process left, which no
// process maps any more, remove_stale_shared_memory removes.)
int free_participant_id(int domain_id, const std::string& shm_dir = "/dev/shm");

}  // namespace saccade::dds
