#pragma once
// One DomainParticipant per process and DDS domain, shared by every bridge
// node of that process, with the transports saccade's payloads need.
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <fastdds/dds/domain/DomainParticipant.hpp>
#include <fastdds/dds/domain/DomainParticipantListener.hpp>
#include <fastdds/dds/publisher/Publisher.hpp>
#include <fastdds/dds/publisher/qos/DataWriterQos.hpp>
#include <fastdds/dds/subscriber/qos/DataReaderQos.hpp>
#include <fastdds/dds/subscriber/Subscriber.hpp>
#include <fastdds/dds/topic/Topic.hpp>

#include "codec.hpp"
#include "saccade/status.hpp"

namespace saccade::dds {

struct TransportSettings {
  // Shared memory between processes of one host. Fast DDS' default (512 KB)
  // is smaller than one VGA colour frame: an image would fall back to
  // fragments and reliable repair (measured: 9 ms for 786 KB instead of 0.4 ms).
  uint32_t shm_segment_bytes = 16u << 20;
  // UDP socket buffers; the kernel caps them at net.core.rmem_max / wmem_max.
  uint32_t udp_buffer_bytes = 4u << 20;
  // How long a process opening a shared-memory port waits for the port's
  // listeners to show they are alive before it takes the port for dead,
  // removes its file and makes a new one. A live listener whose thread is
  // starved that long (a loaded host, a VM's stolen time) is then deaf to
  // everyone who opens the port afterwards, for good, so a match or a
  // security handshake that needs the port never completes. 250 ms did that
  // to live ports under 300 ms stalls; Fast DDS' 1000 ms did not. (A killed
  // listener is found at once by its released lock, and a restarted process
  // takes ports no one used, so this wait never slows a restart.)
  uint32_t shm_health_check_ms = 1000;
};

// The QoS of one edge's topic, from the bridges' parameters (or a benchmark).
struct EdgeSettings {
  bool reliable = false;
  int depth = 1;  // keep-last depth; 0 keeps all
  double deadline_ms = 0;
  bool zero_copy = false;  // a plain type: spare samples in the writer's shared-memory ring
};
eprosima::fastdds::dds::DataWriterQos writer_qos(const eprosima::fastdds::dds::Publisher& publisher,
                                                 const EdgeSettings& s);
eprosima::fastdds::dds::DataReaderQos reader_qos(const eprosima::fastdds::dds::Subscriber& subscriber,
                                                 const EdgeSettings& s);

// What a saccade endpoint of a serialised type tells its peers at discovery
// (its user data): "saccade-schema=" and the 16 hex digits of its type's
// cdr::schema_fingerprint. Empty for the other forms (a plain or ring type
// stays on one host; a ROS 2 type is ROS 2's).
std::vector<uint8_t> schema_user_data(const Codec& codec);
// The fingerprint in an endpoint's user data; 0 when it carries none (a DDS
// program of another maker, a saccade of before 2026-11-26).
uint64_t schema_in_user_data(const std::vector<uint8_t>& user_data);

class Domain {
 public:
  // The process's participant for `domain_id`, created at first use, or why
  // it cannot be created. With FASTRTPS_DEFAULT_PROFILES_FILE set, the
  // participant comes from that XML profile unchanged (initial peers,
  // security, ...); otherwise from TransportSettings. With
  // SACCADE_DDS_SECURITY naming a folder made by scripts/make-security.sh
  // (saccade run --security), the participant authenticates, is
  // access-controlled and encrypts (DDS Security).
  static Result<std::shared_ptr<Domain>> get(int domain_id);
  ~Domain();
  Domain(const Domain&) = delete;
  Domain& operator=(const Domain&) = delete;

  // The topic `name` of `codec`'s type, registering the type once; an error
  // when the name is taken by another type or DDS refuses the topic.
  Result<eprosima::fastdds::dds::Topic*> topic(const std::string& name, const Codec& codec);
  eprosima::fastdds::dds::Publisher* publisher() const { return publisher_; }
  eprosima::fastdds::dds::Subscriber* subscriber() const { return subscriber_; }
  eprosima::fastdds::dds::DomainParticipant* participant() const { return participant_; }
  // DDS security is on (SACCADE_DDS_SECURITY).
  bool secure() const { return secure_; }
  // Peers' endpoints (readers and writers) on topic `name` seen since the
  // participant began whose schema fingerprint differs from this build's for
  // the topic's type: each logged once as an error, whether it was
  // discovered before or after this process made the topic.
  uint64_t peers_of_another_schema(const std::string& name);

 private:
  Domain() = default;
  // Compares each discovered endpoint's schema with this build's.
  struct SchemaListener final : eprosima::fastdds::dds::DomainParticipantListener {
    Domain* domain = nullptr;
    void on_publisher_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) override;
    void on_subscriber_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                 eprosima::fastrtps::rtps::ReaderDiscoveryInfo&& info) override;
    // Peers coming and going at debug level; with DDS Security, each peer's
    // authentication (a refused one a warning: an intruder, or a peer of
    // another certificate authority).
    void on_participant_discovery(eprosima::fastdds::dds::DomainParticipant*,
                                  eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) override;
#if HAVE_SECURITY
    void onParticipantAuthentication(eprosima::fastdds::dds::DomainParticipant*,
                                     eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) override;
#endif
  };
  struct PeerEndpoint {
    std::string topic, type;  // the DDS type name
    uint64_t fingerprint = 0;
    const char* role = "";  // "writes" or "reads"
    bool reported = false;
  };
  // A discovered writer's or reader's proxy data (Fast DDS' WriterProxyData or ReaderProxyData).
  template <class Proxy>
  void discovered(const Proxy& proxy, const char* role);
  void report_if_other(PeerEndpoint& peer);  // under schema_mu_
  SchemaListener listener_;
  struct TopicSchema {
    std::string type;  // the DDS type name
    uint64_t fingerprint = 0;
    uint64_t others = 0;  // peers' endpoints of another fingerprint
  };
  std::map<std::string, PeerEndpoint> peers_;  // by GUID: those that said a fingerprint
  // By topic name. A mutex of its own: discovery calls in on Fast DDS'
  // threads, which may hold its locks, while topic() holds mu_ across Fast DDS calls.
  std::mutex schema_mu_;
  std::map<std::string, TopicSchema> schemas_;
  std::mutex mu_;
  eprosima::fastdds::dds::DomainParticipant* participant_ = nullptr;
  eprosima::fastdds::dds::Publisher* publisher_ = nullptr;
  eprosima::fastdds::dds::Subscriber* subscriber_ = nullptr;
  std::map<std::string, eprosima::fastdds::dds::Topic*> topics_;
  bool secure_ = false;
};

}  // namespace saccade::dds
