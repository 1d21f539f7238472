#include "domain.hpp"

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <utility>

#include <fastdds/dds/domain/DomainParticipantFactory.hpp>
#include <fastdds/dds/domain/qos/DomainParticipantQos.hpp>
#include <fastdds/dds/log/Log.hpp>
#include <fastdds/rtps/transport/UDPv4TransportDescriptor.h>
#include <fastdds/rtps/transport/shared_mem/SharedMemTransportDescriptor.h>

#include "saccade/cdr.hpp"
#include "saccade/log.hpp"
#include "shared_memory.hpp"

namespace saccade::dds {

namespace fdds = eprosima::fastdds::dds;

namespace {

std::string guid_text(const eprosima::fastrtps::rtps::GUID_t& guid) {
  std::ostringstream text;
  text << guid;
  return text.str();
}

// Fast DDS' own errors go to saccade's log (stderr, timed, with the other
// messages) rather than to stdout; its warnings too at --log-level debug, for
// whoever looks into discovery or shared memory ("Port 7412 ... NOT Healthy").
class FastDdsLog : public fdds::LogConsumer {
 public:
  void Consume(const fdds::Log::Entry& entry) override {
    const char* category = entry.context.category != nullptr ? entry.context.category : "";
    if (entry.kind == fdds::Log::Kind::Error)
      log().error("Fast DDS {}: {}", category, entry.message);
    else
      log().debug("Fast DDS {}: {}", category, entry.message);
  }
};

void route_fast_dds_log() {
  fdds::Log::ClearConsumers();
  fdds::Log::RegisterConsumer(std::make_unique<FastDdsLog>());
  fdds::Log::SetVerbosity(log().should_log(spdlog::level::debug) ? fdds::Log::Kind::Warning : fdds::Log::Kind::Error);
}

template <class Qos>
void apply_edge_settings(Qos& qos, const EdgeSettings& s) {
  qos.reliability().kind = s.reliable ? fdds::RELIABLE_RELIABILITY_QOS : fdds::BEST_EFFORT_RELIABILITY_QOS;
  qos.durability().kind = fdds::VOLATILE_DURABILITY_QOS;
  if (s.depth == 0) {
    qos.history().kind = fdds::KEEP_ALL_HISTORY_QOS;
    qos.resource_limits().max_samples = 64;
    qos.resource_limits().max_instances = 1;
    qos.resource_limits().max_samples_per_instance = 64;
  } else {
    qos.history().kind = fdds::KEEP_LAST_HISTORY_QOS;
    qos.history().depth = s.depth;
  }
  if (s.deadline_ms > 0) qos.deadline().period = eprosima::fastrtps::Duration_t(s.deadline_ms / 1000.0);
}

// DDS Security from a folder made by scripts/make-security.sh: the builtin
// PKI-DH authentication, access control and AES-GCM-GMAC plugins. An error
// naming the first file the folder lacks.
Status add_security(fdds::DomainParticipantQos& qos, const std::string& folder) {
  namespace fs = std::filesystem;
  const std::pair<const char*, const char*> files[] = {
      {"dds.sec.auth.builtin.PKI-DH.identity_ca", "ca.pem"},
      {"dds.sec.auth.builtin.PKI-DH.identity_certificate", "cert.pem"},
      {"dds.sec.auth.builtin.PKI-DH.private_key", "key.pem"},
      {"dds.sec.access.builtin.Access-Permissions.permissions_ca", "ca.pem"},
      {"dds.sec.access.builtin.Access-Permissions.governance", "governance.p7s"},
      {"dds.sec.access.builtin.Access-Permissions.permissions", "permissions.p7s"},
  };
  auto& props = qos.properties().properties();
  props.emplace_back("dds.sec.auth.plugin", "builtin.PKI-DH");
  props.emplace_back("dds.sec.access.plugin", "builtin.Access-Permissions");
  props.emplace_back("dds.sec.crypto.plugin", "builtin.AES-GCM-GMAC");
  for (const auto& [property, file] : files) {
    const fs::path path = fs::absolute(fs::path(folder) / file);
    if (!fs::is_regular_file(path))
      return Status::error("DDS security: " + path.string() +
                           " is missing (make the folder with scripts/make-security.sh DIR NAME)");
    props.emplace_back(property, "file://" + path.string());
  }
  return {};
}

}  // namespace

fdds::DataWriterQos writer_qos(const fdds::Publisher& publisher, const EdgeSettings& s) {
  fdds::DataWriterQos qos = publisher.get_default_datawriter_qos();
  apply_edge_settings(qos, s);
  // A keep-all writer waits for a slow reader rather than drop; a keep-last one never waits long.
  qos.reliability().max_blocking_time = eprosima::fastrtps::Duration_t(s.depth == 0 ? 10.0 : 0.1);
  // A plain type's samples live in a ring of the writer's shared memory; a
  // few spare ones keep a sample a reader is still copying from being reused
  // (for the frame ring's, the small sample saying where the frame is).
  if (s.zero_copy) qos.resource_limits().extra_samples = 3;
  return qos;
}

fdds::DataReaderQos reader_qos(const fdds::Subscriber& subscriber, const EdgeSettings& s) {
  fdds::DataReaderQos qos = subscriber.get_default_datareader_qos();
  apply_edge_settings(qos, s);
  return qos;
}

Result<std::shared_ptr<Domain>> Domain::get(int domain_id) {
  static std::mutex mu;
  static std::map<int, std::weak_ptr<Domain>> domains;
  std::lock_guard lock(mu);
  if (auto existing = domains[domain_id].lock()) return existing;

  // Once per process: Fast DDS' log, and what crashed processes left, which
  // would otherwise fill /dev/shm (16 MB a participant).
  static bool first = true;
  if (std::exchange(first, false)) {
    route_fast_dds_log();
    StaleSharedMemory stale = remove_stale_shared_memory();
    if (!stale.removed.empty())
      log().info("removed {} shared-memory files ({:.1f} MB) that DDS processes which died left in /dev/shm",
                 stale.removed.size(), static_cast<double>(stale.bytes) / 1e6);
  }

  auto* factory = fdds::DomainParticipantFactory::get_instance();
  fdds::DomainParticipantQos qos;
  if (std::getenv("FASTRTPS_DEFAULT_PROFILES_FILE") != nullptr) {
    factory->load_profiles();
    qos = factory->get_default_participant_qos();
  } else {
    TransportSettings settings;
    qos.transport().use_builtin_transports = false;
    auto shm = std::make_shared<eprosima::fastdds::rtps::SharedMemTransportDescriptor>();
    shm->segment_size(settings.shm_segment_bytes);
    shm->max_message_size(settings.shm_segment_bytes / 2);
    shm->healthy_check_timeout_ms(settings.shm_health_check_ms);
    qos.transport().user_transports.push_back(shm);
    auto udp = std::make_shared<eprosima::fastdds::rtps::UDPv4TransportDescriptor>();
    udp->sendBufferSize = settings.udp_buffer_bytes;
    udp->receiveBufferSize = settings.udp_buffer_bytes;
    qos.transport().user_transports.push_back(udp);
    qos.transport().send_socket_buffer_size = settings.udp_buffer_bytes;
    qos.transport().listen_socket_buffer_size = settings.udp_buffer_bytes;
    // A peer that dies without saying so (kill -9, power, cable) is dropped
    // and reported after 3 s rather than Fast DDS' default 20 s.
    auto& discovery = qos.wire_protocol().builtin.discovery_config;
    discovery.leaseDuration = eprosima::fastrtps::Duration_t(3, 0);
    discovery.leaseDuration_announcementperiod = eprosima::fastrtps::Duration_t(1, 0);
    // Never a killed process's shared-memory ports (see free_participant_id).
    qos.wire_protocol().participant_id = free_participant_id(domain_id);
  }
  qos.name("saccade");
  const char* env_security = std::getenv("SACCADE_DDS_SECURITY");
  const std::string security = env_security != nullptr ? env_security : "";
  if (!security.empty())
    if (Status s = add_security(qos, security); !s.ok()) return s;
  std::shared_ptr<Domain> domain(new Domain());
  domain->listener_.domain = domain.get();
  for (const auto& property : qos.properties().properties())  // from saccade's folder or an XML profile
    if (property.name().rfind("dds.sec.", 0) == 0) domain->secure_ = true;
  // The listener hears discovery alone (no status: the readers and writers have their own listeners).
  domain->participant_ = factory->create_participant(static_cast<fdds::DomainId_t>(domain_id), qos, &domain->listener_,
                                                     fdds::StatusMask::none());
  if (domain->participant_ == nullptr)
    return Status::error("cannot create a DDS participant in domain " + std::to_string(domain_id) +
                         (security.empty() ? std::string()
                                           : " with the DDS security of " + security +
                                                 " (a certificate, key or signed document that does not check out: "
                                                 "Fast DDS' log says which)"));
  domain->publisher_ = domain->participant_->create_publisher(fdds::PUBLISHER_QOS_DEFAULT);
  domain->subscriber_ = domain->participant_->create_subscriber(fdds::SUBSCRIBER_QOS_DEFAULT);
  if (domain->publisher_ == nullptr || domain->subscriber_ == nullptr)
    return Status::error("cannot create a DDS publisher or subscriber in domain " + std::to_string(domain_id));
  domains[domain_id] = domain;
  return domain;
}

Domain::~Domain() {
  if (participant_ == nullptr) return;
  // A participant Fast DDS refuses to delete (an entity still busy) lives on:
  // its discovery threads must not call into this Domain then.
  participant_->set_listener(nullptr);
  participant_->delete_contained_entities();
  if (fdds::DomainParticipantFactory::get_instance()->delete_participant(participant_) != ReturnCode_t::RETCODE_OK)
    log().warn(
        "the DDS participant could not be deleted (an entity of it still in use): it is left to the process's end");
}

Result<fdds::Topic*> Domain::topic(const std::string& name, const Codec& codec) {
  std::lock_guard lock(mu_);
  fdds::TypeSupport type(codec.make_type().release());
  if (auto it = topics_.find(name); it != topics_.end()) {
    if (it->second->get_type_name() != type.get_type_name())
      return Status::error("topic " + name + " already carries " + it->second->get_type_name());
    return it->second;
  }
  if (participant_->find_type(type.get_type_name()).empty()) type.register_type(participant_);
  fdds::Topic* topic = participant_->create_topic(name, type.get_type_name(), fdds::TOPIC_QOS_DEFAULT);
  if (topic == nullptr) return Status::error("cannot create DDS topic " + name + " of type " + type.get_type_name());
  topics_[name] = topic;
  if (codec.form == Codec::Form::kSerialized) {
    // Peers discovered before this process made the topic are compared now.
    std::lock_guard schema_lock(schema_mu_);
    schemas_[name] = {type.get_type_name(), cdr::schema_fingerprint(codec.type), 0};
    for (auto& [guid, peer] : peers_)
      if (peer.topic == name) report_if_other(peer);
  }
  return topic;
}

namespace {

constexpr std::string_view kSchemaKey = "saccade-schema=";

std::string hex(uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

}  // namespace

std::vector<uint8_t> schema_user_data(const Codec& codec) {
  if (codec.form != Codec::Form::kSerialized) return {};
  const std::string text = std::string(kSchemaKey) + hex(cdr::schema_fingerprint(codec.type));
  return {text.begin(), text.end()};
}

uint64_t schema_in_user_data(const std::vector<uint8_t>& user_data) {
  const std::string text(user_data.begin(), user_data.end());
  const std::size_t at = text.find(kSchemaKey);
  if (at == std::string::npos) return 0;
  const std::string digits = text.substr(at + kSchemaKey.size(), 16);
  if (digits.size() != 16 || digits.find_first_not_of("0123456789abcdef") != std::string::npos) return 0;
  return std::stoull(digits, nullptr, 16);
}

uint64_t Domain::peers_of_another_schema(const std::string& name) {
  std::lock_guard lock(schema_mu_);
  auto it = schemas_.find(name);
  return it == schemas_.end() ? 0 : it->second.others;
}

template <class Proxy>
void Domain::discovered(const Proxy& proxy, const char* role) {
  const uint64_t fingerprint = schema_in_user_data(proxy.m_qos.m_userData.data_vec());
  if (fingerprint == 0) return;  // a peer that does not say: nothing to compare
  std::lock_guard lock(schema_mu_);
  auto [it, fresh] =
      peers_.try_emplace(guid_text(proxy.guid()),
                         PeerEndpoint{proxy.topicName().to_string(), proxy.typeName().to_string(), fingerprint, role});
  if (fresh) report_if_other(it->second);  // (an endpoint back after a lease ran out is not named again)
}

void Domain::report_if_other(PeerEndpoint& peer) {
  auto it = schemas_.find(peer.topic);
  if (peer.reported || it == schemas_.end() || it->second.type != peer.type || it->second.fingerprint == 0 ||
      it->second.fingerprint == peer.fingerprint)
    return;
  peer.reported = true;
  ++it->second.others;
  log().error(
      "DDS topic {}: a peer {} {} of another schema (its fingerprint {}, this build's {}): the two sides may "
      "misread, or be unable to read, each other's samples (a reader counts those it cannot read as unreadable). "
      "Run one saccade version on both; `saccade idl` prints this build's types",
      peer.topic, peer.role, peer.type, hex(peer.fingerprint), hex(it->second.fingerprint));
}

void Domain::SchemaListener::on_publisher_discovery(fdds::DomainParticipant*,
                                                    eprosima::fastrtps::rtps::WriterDiscoveryInfo&& info) {
  if (info.status == eprosima::fastrtps::rtps::WriterDiscoveryInfo::DISCOVERED_WRITER)
    domain->discovered(info.info, "writes");
}

void Domain::SchemaListener::on_subscriber_discovery(fdds::DomainParticipant*,
                                                     eprosima::fastrtps::rtps::ReaderDiscoveryInfo&& info) {
  if (info.status == eprosima::fastrtps::rtps::ReaderDiscoveryInfo::DISCOVERED_READER)
    domain->discovered(info.info, "reads");
}

void Domain::SchemaListener::on_participant_discovery(fdds::DomainParticipant*,
                                                      eprosima::fastrtps::rtps::ParticipantDiscoveryInfo&& info) {
  using Info = eprosima::fastrtps::rtps::ParticipantDiscoveryInfo;
  const char* what = info.status == Info::DISCOVERED_PARTICIPANT    ? "discovered"
                     : info.status == Info::CHANGED_QOS_PARTICIPANT ? "changed its QoS"
                     : info.status == Info::REMOVED_PARTICIPANT     ? "left"
                     : info.status == Info::DROPPED_PARTICIPANT     ? "dropped (its lease expired)"
                                                                    : "ignored";
  log().debug("DDS participant {} ({}) {}", guid_text(info.info.m_guid), info.info.m_participantName.to_string(), what);
}

#if HAVE_SECURITY
void Domain::SchemaListener::onParticipantAuthentication(
    fdds::DomainParticipant*, eprosima::fastrtps::rtps::ParticipantAuthenticationInfo&& info) {
  if (info.status == eprosima::fastrtps::rtps::ParticipantAuthenticationInfo::AUTHORIZED_PARTICIPANT)
    log().debug("DDS participant {} authenticated", guid_text(info.guid));
  else
    log().warn(
        "DDS participant {} failed authentication (not of this certificate authority, or its permissions "
        "refuse it): nothing is exchanged with it",
        guid_text(info.guid));
}
#endif

}  // namespace saccade::dds
