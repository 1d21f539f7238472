#include "view_server.hpp"

#include "cpu_budget.hpp"

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <thread>
#include <utility>
#include <vector>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "channel.hpp"
#include "client_protocol.hpp"
#include "render.hpp"
#include "saccade/executor.hpp"
#include "saccade/schema.hpp"

namespace saccade::view {

extern const char* const kPageHtml;

ViewServer::~ViewServer() = default;

namespace {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr const char* kSubprotocol = "foxglove.websocket.v1";

// One tapped output: the newest message it emitted while anyone listens.
struct Source {
  std::string node, port, type;
  std::atomic<int> interest{0};  // subscriptions to any of its channels
  std::mutex mu;
  MessagePtr latest;
  uint64_t seq = 0;
};

enum class Kind { kCdr, kJpeg, kJson, kStats };

struct Channel {
  uint32_t id = 0;
  std::string topic, encoding, schema_name, schema_encoding, schema;
  Kind kind = Kind::kCdr;
  Source* source = nullptr;  // none for kStats
  const dds::ChannelEncoding* cdr = nullptr;
  std::atomic<int> subscribers{0};
  // The sender's own.
  std::unique_ptr<dds::MessageEncoder> encoder;
  uint64_t sent_seq = 0;
  Clock::time_point last_sent{};
};

// An encoded message, shared by every subscriber's send.
struct Payload {
  std::vector<uint8_t> bytes;
  uint64_t receive_ns = 0;
};
using PayloadPtr = std::shared_ptr<const Payload>;

// A side input a client may publish to.
struct Target {
  std::string node, input;
};

struct Counters {
  std::atomic<uint64_t> clients{0}, connections{0}, http_requests{0}, messages_sent{0}, malformed{0}, oversize{0},
      injected{0}, inject_refused{0}, budget_waits{0};
};

uint64_t wall_ns() {
  return static_cast<uint64_t>(
      std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::system_clock::now().time_since_epoch())
          .count());
}

class Server;

// One WebSocket client, on the network thread only.
class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server& server) : ws_(std::move(socket)), server_(server) {}
  void start(http::request<http::string_body> request);
  // The newest payload of `channel` for every subscription to it.
  void offer(uint32_t channel, const PayloadPtr& payload);
  void send_text(std::string text) {
    text_.push_back(std::move(text));
    pump();
  }
  void close() {
    beast::error_code ec;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ec);
    beast::get_lowest_layer(ws_).socket().close(ec);
  }

 private:
  void read();
  void on_read(beast::error_code ec);
  void on_text(const std::string& text);
  void on_binary(const uint8_t* data, std::size_t size);
  void pump();
  void ended();
  void malformed(const std::string& why);
  void drop_subscription(uint32_t id);

  websocket::stream<beast::tcp_stream> ws_;
  Server& server_;
  beast::flat_buffer buffer_;
  bool open_ = false, writing_ = false, ended_ = false;
  std::map<uint32_t, uint32_t> subscriptions_;            // subscription id -> channel id
  std::map<uint32_t, std::optional<Target>> advertised_;  // client channel id -> where it goes (none: nowhere)
  std::deque<std::string> text_;
  std::map<uint32_t, PayloadPtr> pending_;  // subscription id -> newest payload not yet sent
  uint32_t next_subscription_ = 0;
  std::string text_in_flight_;
  std::array<uint8_t, 13> header_{};
  PayloadPtr payload_in_flight_;
};

class Server final : public ViewServer {
 public:
  Server(Executor& executor, ViewOptions options) : executor_(executor), options_(std::move(options)) {}
  ~Server() override { stop(); }

  // Ok when listening with every output tapped; else the error naming the address or output.
  Status start();
  int port() const override { return port_; }
  std::string url() const override {
    const bool v6 = options_.address.find(':') != std::string::npos;
    return "http://" + (v6 ? "[" + options_.address + "]" : options_.address) + ":" + std::to_string(port_) + "/";
  }
  ViewCounters counters() const override {
    ViewCounters c;
    c.clients = counters_.clients.load();
    c.connections = counters_.connections.load();
    c.http_requests = counters_.http_requests.load();
    c.messages_sent = counters_.messages_sent.load();
    c.malformed = counters_.malformed.load();
    c.oversize = counters_.oversize.load();
    c.injected = counters_.injected.load();
    c.inject_refused = counters_.inject_refused.load();
    c.budget_waits = counters_.budget_waits.load();
    return c;
  }
  void stop() override {
    if (stopped_.exchange(true)) return;
    {
      std::lock_guard lock(wake_mu_);
      stop_sender_ = true;
    }
    wake_.notify_all();
    if (sender_.joinable()) sender_.join();
    ioc_.stop();
    if (io_thread_.joinable()) io_thread_.join();
    for (auto& s : sources_) {
      std::lock_guard lock(s->mu);
      s->latest.reset();
    }
  }

  // Network thread.
  const ViewOptions& options() const { return options_; }
  Counters& stats() { return counters_; }
  Channel* channel(uint32_t id) { return id < channels_.size() ? channels_[id].get() : nullptr; }
  std::optional<Target> target_of(const std::string& topic) const {
    auto it = targets_.find(topic);
    if (it == targets_.end()) return std::nullopt;
    return it->second;
  }
  Status inject(const Target& target, MessagePtr message) {
    return executor_.inject(target.node, target.input, std::move(message));
  }
  void joined(const std::shared_ptr<WsSession>& s) {
    std::erase_if(sessions_, [](const std::weak_ptr<WsSession>& w) { return w.expired(); });
    sessions_.push_back(s);
    s->send_text(server_info_);
    s->send_text(advertise_);
  }
  void subscribed(Channel& c, int by) {
    c.subscribers.fetch_add(by);
    if (c.source) c.source->interest.fetch_add(by);
    if (by > 0) wake_.notify_all();
  }
  std::string http_reply(const std::string& target, http::status& status, std::string& content_type);
  std::string view_json() const;

 private:
  void accept();
  void build_channels();
  void add_channel(std::unique_ptr<Channel> c, json& advertised);
  json input_ports(const ResolvedNode& n, json& targets);
  json output_channels(const std::string& node, const PortSpec& out, json& advertised);
  void send_loop();
  bool encode(Channel& c, const Message& m, Payload& p, std::vector<uint8_t>& jpeg, cv::Mat& picture);

  Executor& executor_;
  ViewOptions options_;
  net::io_context ioc_{1};
  tcp::acceptor acceptor_{ioc_};
  int port_ = 0;
  std::vector<std::unique_ptr<Source>> sources_;
  std::vector<std::unique_ptr<Channel>> channels_;  // index = channel id
  std::map<std::string, Target> targets_;           // topic -> side input
  std::string server_info_, advertise_, graph_json_;
  std::vector<std::weak_ptr<WsSession>> sessions_;  // network thread
  Counters counters_;
  std::thread io_thread_, sender_;
  std::mutex wake_mu_;
  std::condition_variable wake_;
  bool stop_sender_ = false;
  std::atomic<bool> stopped_{false};
};

// ---------------------------------------------------------------- WebSocket

void WsSession::start(http::request<http::string_body> request) {
  bool foxglove = false;
  const auto header = request[http::field::sec_websocket_protocol];
  const std::string_view offered(header.data(), header.size());
  std::size_t at = 0;
  while (at <= offered.size()) {
    std::size_t end = offered.find(',', at);
    if (end == std::string_view::npos) end = offered.size();
    std::string_view p = offered.substr(at, end - at);
    while (!p.empty() && p.front() == ' ') p.remove_prefix(1);
    while (!p.empty() && p.back() == ' ') p.remove_suffix(1);
    if (p == kSubprotocol) foxglove = true;
    at = end + 1;
  }
  ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
  ws_.set_option(websocket::stream_base::decorator([foxglove](websocket::response_type& res) {
    res.set(http::field::server, "saccade");
    if (foxglove) res.set(http::field::sec_websocket_protocol, kSubprotocol);
  }));
  ws_.read_message_max(server_.options().max_client_message);
  ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) {
    if (ec) return;
    self->open_ = true;
    self->server_.stats().clients.fetch_add(1);
    self->server_.stats().connections.fetch_add(1);
    self->server_.joined(self);
    self->read();
  });
}

void WsSession::read() {
  ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
}

void WsSession::on_read(beast::error_code ec) {
  if (ec) {
    if (ec == websocket::error::message_too_big) {
      server_.stats().oversize.fetch_add(1);
    } else if (ec != websocket::error::closed && ec != net::error::eof && ec != net::error::operation_aborted &&
               ec != net::error::connection_reset && ec != beast::error::timeout) {
      server_.stats().malformed.fetch_add(1);  // a frame that breaks the protocol
    }
    ended();
    return;
  }
  const auto data = buffer_.cdata();
  if (ws_.got_text()) {
    on_text(std::string(static_cast<const char*>(data.data()), data.size()));
  } else {
    on_binary(static_cast<const uint8_t*>(data.data()), data.size());
  }
  buffer_.consume(buffer_.size());
  read();
}

void WsSession::ended() {
  if (ended_) return;
  ended_ = true;
  for (auto it = subscriptions_.begin(); it != subscriptions_.end(); it = subscriptions_.begin())
    drop_subscription(it->first);
  pending_.clear();
  if (open_) server_.stats().clients.fetch_sub(1);
  close();
}

void WsSession::malformed(const std::string& why) {
  server_.stats().malformed.fetch_add(1);
  json status = {{"op", "status"}, {"level", 1}, {"message", "dropped: " + why}};
  send_text(status.dump());
}

void WsSession::drop_subscription(uint32_t id) {
  auto it = subscriptions_.find(id);
  if (it == subscriptions_.end()) return;
  if (Channel* c = server_.channel(it->second)) server_.subscribed(*c, -1);
  subscriptions_.erase(it);
  pending_.erase(id);
}

void WsSession::on_text(const std::string& text) {
  const ClientRequest r = parse_client_text(text);
  switch (r.op) {
    case ClientRequest::Op::kMalformed: return malformed(r.malformed);
    case ClientRequest::Op::kSubscribe:
      for (const ClientRequest::Subscription& s : r.subscriptions) {
        Channel* c = server_.channel(s.channel_id);
        if (!c) return malformed("subscribe: no channel " + std::to_string(s.channel_id));
        if (subscriptions_.count(s.id)) return malformed("subscribe: subscription " + std::to_string(s.id) + " exists");
        subscriptions_[s.id] = s.channel_id;
        server_.subscribed(*c, 1);
      }
      break;
    case ClientRequest::Op::kUnsubscribe:
      for (uint32_t id : r.ids) drop_subscription(id);
      break;
    case ClientRequest::Op::kAdvertise:
      for (const ClientRequest::AdvertisedChannel& c : r.channels) {
        std::optional<Target> target = server_.target_of(c.topic);
        if (target && c.encoding != "json") {
          send_text(json{{"op", "status"}, {"level", 1}, {"message", "only json is taken on " + c.topic}}.dump());
          target.reset();
        }
        advertised_[c.id] = target;
      }
      break;
    case ClientRequest::Op::kUnadvertise:
      for (uint32_t id : r.ids) advertised_.erase(id);
      break;
  }
  // An entry that is not whole ends the request; those before it were taken.
  if (!r.malformed.empty()) malformed(r.malformed);
}

void WsSession::on_binary(const uint8_t* data, std::size_t size) {
  uint32_t channel_id = 0;
  if (!parse_message_data(data, size, channel_id))
    return malformed("binary message is not messageData (opcode 1, channel id)");
  auto it = advertised_.find(channel_id);
  if (it == advertised_.end()) return malformed("message on a channel the client did not advertise");
  if (!it->second) {
    server_.stats().inject_refused.fetch_add(1);
    return;
  }
  auto region = std::make_shared<Region>();
  if (Status s = parse_region_json(data + 5, size - 5, *region); !s.ok()) return malformed(s.message());
  if (Status s = server_.inject(*it->second, region); s.ok()) {
    server_.stats().injected.fetch_add(1);
  } else {
    server_.stats().inject_refused.fetch_add(1);
    send_text(json{{"op", "status"}, {"level", 2}, {"message", s.message()}}.dump());
  }
}

void WsSession::offer(uint32_t channel, const PayloadPtr& payload) {
  if (ended_) return;
  bool any = false;
  for (const auto& [sub, ch] : subscriptions_) {
    if (ch != channel) continue;
    pending_[sub] = payload;  // the newest only
    any = true;
  }
  if (any) pump();
}

void WsSession::pump() {
  if (!open_ || writing_ || ended_) return;
  auto done = [self = shared_from_this()](beast::error_code ec, std::size_t) {
    self->writing_ = false;
    self->payload_in_flight_.reset();
    if (ec) return self->ended();
    self->pump();
  };
  if (!text_.empty()) {
    text_in_flight_ = std::move(text_.front());
    text_.pop_front();
    writing_ = true;
    ws_.text(true);
    ws_.async_write(net::buffer(text_in_flight_), std::move(done));
    return;
  }
  if (pending_.empty()) return;
  auto it = pending_.lower_bound(next_subscription_);
  if (it == pending_.end()) it = pending_.begin();
  const uint32_t sub = it->first;
  next_subscription_ = sub + 1;
  payload_in_flight_ = std::move(it->second);
  pending_.erase(it);
  header_[0] = 0x01;  // messageData
  std::memcpy(header_.data() + 1, &sub, 4);
  std::memcpy(header_.data() + 5, &payload_in_flight_->receive_ns, 8);
  writing_ = true;
  ws_.binary(true);
  const std::array<net::const_buffer, 2> buffers{net::buffer(header_), net::buffer(payload_in_flight_->bytes)};
  server_.stats().messages_sent.fetch_add(1);
  ws_.async_write(buffers, std::move(done));
}

// ---------------------------------------------------------------- HTTP

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server& server) : stream_(std::move(socket)), server_(server) {}
  void read() {
    parser_.emplace();
    parser_->body_limit(server_.options().max_client_message);
    parser_->header_limit(
        static_cast<std::uint32_t>(std::min<std::size_t>(server_.options().max_client_message, 65536)));
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
  }

 private:
  void on_read(beast::error_code ec) {
    if (ec == http::error::end_of_stream || ec == beast::error::timeout || ec == net::error::operation_aborted ||
        ec == net::error::connection_reset || ec == net::error::eof)
      return close();
    if (ec == http::error::body_limit || ec == http::error::header_limit || ec == http::error::buffer_overflow) {
      server_.stats().oversize.fetch_add(1);
      return reply_and_close(http::status::payload_too_large, "request too large\n");
    }
    if (ec) {
      server_.stats().malformed.fetch_add(1);
      return reply_and_close(http::status::bad_request, "bad request\n");
    }
    server_.stats().http_requests.fetch_add(1);
    http::request<http::string_body> req = parser_->release();
    if (websocket::is_upgrade(req)) {
      stream_.expires_never();
      std::make_shared<WsSession>(stream_.release_socket(), server_)->start(std::move(req));
      return;
    }
    auto res = std::make_shared<http::response<http::string_body>>();
    res->version(req.version());
    res->keep_alive(req.keep_alive());
    res->set(http::field::server, "saccade");
    res->set(http::field::cache_control, "no-store");
    if (req.method() != http::verb::get && req.method() != http::verb::head) {
      res->result(http::status::method_not_allowed);
      res->set(http::field::content_type, "text/plain");
      res->body() = "only GET\n";
    } else {
      http::status status = http::status::ok;
      std::string type;
      res->body() = server_.http_reply(std::string(req.target()), status, type);
      res->result(status);
      res->set(http::field::content_type, type);
      if (req.method() == http::verb::head) res->body().clear();
    }
    res->prepare_payload();
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code wec, std::size_t) {
      if (wec || !res->keep_alive()) return self->close();
      self->read();
    });
  }

  void reply_and_close(http::status status, const char* text) {
    auto res = std::make_shared<http::response<http::string_body>>(status, 11);
    res->set(http::field::content_type, "text/plain");
    res->keep_alive(false);
    res->body() = text;
    res->prepare_payload();
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res](beast::error_code, std::size_t) { self->close(); });
  }

  void close() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
    stream_.socket().close(ec);
  }

  beast::tcp_stream stream_;
  Server& server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

// ---------------------------------------------------------------- Server

Status Server::start() {
  build_channels();
  beast::error_code ec;
  const net::ip::address address = net::ip::make_address(options_.address, ec);
  if (ec) return Status::error("view: bad address '" + options_.address + "'");
  const tcp::endpoint endpoint(address, static_cast<unsigned short>(options_.port));
  const std::string where = options_.address + ":" + std::to_string(options_.port);
  acceptor_.open(endpoint.protocol(), ec);
  if (!ec) acceptor_.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor_.bind(endpoint, ec);
  if (!ec) acceptor_.listen(net::socket_base::max_listen_connections, ec);
  if (ec == net::error::address_in_use)
    return Status::error("view: cannot listen on " + where + ": the port is in use");
  if (ec) return Status::error("view: cannot listen on " + where + ": " + ec.message());
  port_ = acceptor_.local_endpoint().port();

  for (auto& s : sources_) {
    Source* source = s.get();
    const Status tapped = executor_.add_tap(source->node, source->port, [source](const MessagePtr& m) {
      if (source->interest.load(std::memory_order_relaxed) == 0) return;
      MessagePtr old;
      {
        std::lock_guard lock(source->mu);
        old = std::exchange(source->latest, m);
        ++source->seq;
      }
    });
    if (!tapped.ok()) return Status::error("view: " + tapped.message());
  }
  accept();
  io_thread_ = std::thread([this] { ioc_.run(); });
  sender_ = std::thread([this] { send_loop(); });
  return {};
}

void Server::accept() {
  acceptor_.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (ec == net::error::operation_aborted || !acceptor_.is_open()) return;
    if (!ec) std::make_shared<HttpSession>(std::move(socket), *this)->read();
    accept();
  });
}

namespace {

std::unique_ptr<Channel> make_channel(std::string topic, Kind kind, std::string encoding, std::string schema_name,
                                      std::string schema_encoding, std::string schema, Source* source) {
  auto c = std::make_unique<Channel>();
  c->topic = std::move(topic);
  c->kind = kind;
  c->encoding = std::move(encoding);
  c->schema_name = std::move(schema_name);
  c->schema_encoding = std::move(schema_encoding);
  c->schema = std::move(schema);
  c->source = source;
  return c;
}

// The graph's edges as /api/graph gives them.
json edges_json(const ResolvedGraph& graph) {
  json edges = json::array();
  for (const ResolvedEdge& e : graph.edges) {
    const ResolvedNode& from = graph.nodes[static_cast<std::size_t>(e.from_node)];
    const ResolvedNode& to = graph.nodes[static_cast<std::size_t>(e.to_node)];
    edges.push_back({{"from", from.decl.name},
                     {"from_port", from.contract.outputs()[static_cast<std::size_t>(e.from_port)].name},
                     {"to", to.decl.name},
                     {"to_port", to.contract.inputs()[static_cast<std::size_t>(e.to_port)].name},
                     {"delay", e.delay}});
  }
  return edges;
}

}  // namespace

void Server::add_channel(std::unique_ptr<Channel> c, json& advertised) {
  c->id = static_cast<uint32_t>(channels_.size());
  advertised.push_back({{"id", c->id},
                        {"topic", c->topic},
                        {"encoding", c->encoding},
                        {"schemaName", c->schema_name},
                        {"schema", c->schema},
                        {"schemaEncoding", c->schema_encoding}});
  channels_.push_back(std::move(c));
}

// A node's inputs for /api/graph; a side input that takes a Region becomes a
// topic clients may publish to (a box dragged on the page, for the fovea).
json Server::input_ports(const ResolvedNode& n, json& targets) {
  json inputs = json::array();
  for (const PortSpec& in : n.contract.inputs()) {
    const char* kind = in.kind == InputKind::kSide ? "side" : in.kind == InputKind::kOptional ? "optional" : "trigger";
    json j = {{"name", in.name}, {"type", in.type}, {"kind", kind}};
    if (in.kind == InputKind::kSide && (in.type == Region::kTypeName)) {
      const std::string topic = "/" + n.decl.name + "/" + in.name;
      targets_[topic] = Target{n.decl.name, in.name};
      j["topic"] = topic;
      targets.push_back({{"node", n.decl.name}, {"input", in.name}, {"topic", topic}});
    }
    inputs.push_back(std::move(j));
  }
  return inputs;
}

// An output's channels: its CDR form where it has one, and a picture of it
// (JPEG) or its JSON; their topics.
json Server::output_channels(const std::string& node, const PortSpec& out, json& advertised) {
  json topics = json::array();
  const dds::ChannelEncoding* cdr = dds::channel_encoding(out.type, true);
  const bool described = !json_schema(out.type).empty();
  if (!cdr && !described) return topics;
  auto source = std::make_unique<Source>();
  source->node = node;
  source->port = out.name;
  source->type = out.type;
  const std::string base = "/" + node + "/" + out.name;
  if (cdr) {
    auto c = make_channel(base, Kind::kCdr, cdr->message_encoding, cdr->schema_name, cdr->schema_encoding, cdr->schema,
                          source.get());
    c->cdr = cdr;
    topics.push_back(c->topic);
    add_channel(std::move(c), advertised);
  }
  if (has_picture(out.type)) {
    auto c = make_channel(base + "/jpeg", Kind::kJpeg, "cdr", "sensor_msgs/msg/CompressedImage", "ros2msg",
                          compressed_image_schema(), source.get());
    topics.push_back(c->topic);
    add_channel(std::move(c), advertised);
  } else if (described) {
    auto c =
        make_channel(base + "/json", Kind::kJson, "json", out.type, "jsonschema", json_schema(out.type), source.get());
    topics.push_back(c->topic);
    add_channel(std::move(c), advertised);
  }
  sources_.push_back(std::move(source));
  return topics;
}

void Server::build_channels() {
  const ResolvedGraph& graph = executor_.graph();
  json channels = json::array();
  json nodes = json::array();
  json targets = json::array();
  for (const ResolvedNode& n : graph.nodes) {
    json outputs = json::array();
    for (const PortSpec& out : n.contract.outputs())
      outputs.push_back(
          {{"name", out.name}, {"type", out.type}, {"topics", output_channels(n.decl.name, out, channels)}});
    nodes.push_back({{"name", n.decl.name},
                     {"plugin", n.decl.plugin},
                     {"inputs", input_ports(n, targets)},
                     {"outputs", std::move(outputs)}});
  }
  add_channel(
      make_channel("/saccade/stats", Kind::kStats, "json", "saccade.Stats", "jsonschema",
                   R"({"type":"object","properties":{"view":{"type":"object"},"stats":{"type":"object"}}})", nullptr),
      channels);
  server_info_ = json{{"op", "serverInfo"},
                      {"name", "saccade " + graph.name},
                      {"capabilities", json::array({"clientPublish"})},
                      {"supportedEncodings", json::array({"json"})},
                      {"metadata", json::object({{"graph", graph.name}})},
                      {"sessionId", std::to_string(wall_ns())}}
                     .dump();
  advertise_ = json{{"op", "advertise"}, {"channels", std::move(channels)}}.dump();
  graph_json_ = json{{"name", graph.name},
                     {"nodes", std::move(nodes)},
                     {"edges", edges_json(graph)},
                     {"targets", std::move(targets)}}
                    .dump();
}

std::string Server::view_json() const {
  const ViewCounters c = counters();
  return json{{"clients", c.clients},
              {"connections", c.connections},
              {"http_requests", c.http_requests},
              {"messages_sent", c.messages_sent},
              {"malformed", c.malformed},
              {"oversize", c.oversize},
              {"injected", c.injected},
              {"inject_refused", c.inject_refused},
              {"budget_waits", c.budget_waits}}
      .dump();
}

std::string Server::http_reply(const std::string& target, http::status& status, std::string& content_type) {
  const std::string path = target.substr(0, target.find('?'));
  content_type = "application/json";
  if (path == "/" || path == "/index.html") {
    content_type = "text/html; charset=utf-8";
    return kPageHtml;
  }
  if (path == "/api/graph") return graph_json_;
  if (path == "/api/view") return view_json();
  if (path == "/api/stats") return executor_.stats_json();
  status = http::status::not_found;
  content_type = "text/plain";
  return "not found\n";
}

bool Server::encode(Channel& c, const Message& m, Payload& p, std::vector<uint8_t>& jpeg, cv::Mat& picture) {
  switch (c.kind) {
    case Kind::kCdr:
      if (!c.encoder) c.encoder = dds::make_encoder(*c.cdr);
      return c.encoder && c.encoder->encode(m, p.bytes).ok();
    case Kind::kJpeg: {
      render_picture(m, picture);
      if (picture.empty()) return false;
      if (!cv::imencode(".jpg", picture, jpeg, {cv::IMWRITE_JPEG_QUALITY, options_.jpeg_quality})) return false;
      encode_compressed_image(m.timestamp_ns, c.source->node, jpeg, p.bytes);
      return true;
    }
    case Kind::kJson: {
      std::string text;
      append_json(text, m);
      p.bytes.assign(text.begin(), text.end());
      return true;
    }
    case Kind::kStats: return false;
  }
  return false;
}

void Server::send_loop() {
  const auto min_gap = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(options_.max_rate_hz > 0 ? 1.0 / options_.max_rate_hz : 0.0));
  const auto stats_gap = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(std::max(0.05, options_.stats_interval_s)));
  std::vector<uint8_t> jpeg;
  cv::Mat picture;
  CpuBudget budget(options_.cpu_share);
  const pthread_t io_thread = io_thread_.native_handle(), sender = pthread_self();
  for (;;) {
    bool any = false;
    const Clock::time_point now = Clock::now();
    const int64_t now_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(now.time_since_epoch()).count();
    // Checked once a round: the pictures of a round go out together or wait together.
    const bool room = budget.has_room(thread_cpu_ns(sender) + thread_cpu_ns(io_thread), now_ns);
    bool waited = false;
    for (auto& cp : channels_) {
      Channel& c = *cp;
      if (c.subscribers.load() <= 0) continue;
      any = true;
      auto payload = std::make_shared<Payload>();
      if (c.kind == Kind::kStats) {
        if (now - c.last_sent < stats_gap) continue;
        const std::string text = "{\"view\":" + view_json() + ",\"stats\":" + executor_.stats_json() + "}";
        payload->bytes.assign(text.begin(), text.end());
      } else {
        if (now - c.last_sent < min_gap) continue;
        if (!room) {
          waited = true;
          continue;
        }
        MessagePtr m;
        uint64_t seq = 0;
        {
          std::lock_guard lock(c.source->mu);
          m = c.source->latest;
          seq = c.source->seq;
        }
        if (!m || seq == c.sent_seq) continue;
        c.sent_seq = seq;
        if (!encode(c, *m, *payload, jpeg, picture)) continue;
      }
      c.last_sent = now;
      payload->receive_ns = wall_ns();
      net::post(ioc_, [this, id = c.id, p = PayloadPtr(std::move(payload))] {
        for (auto& w : sessions_)
          if (auto s = w.lock()) s->offer(id, p);
      });
    }
    if (waited) counters_.budget_waits.fetch_add(1, std::memory_order_relaxed);
    // Sources nobody listens to any more let their message go.
    for (auto& s : sources_) {
      if (s->interest.load() > 0) continue;
      MessagePtr old;
      std::lock_guard lock(s->mu);
      old = std::move(s->latest);
    }
    std::unique_lock lock(wake_mu_);
    if (stop_sender_) return;
    wake_.wait_for(lock, any ? std::chrono::milliseconds(2) : std::chrono::milliseconds(50),
                   [this] { return stop_sender_; });
    if (stop_sender_) return;
  }
}

}  // namespace

Status parse_view_address(const std::string& text, ViewOptions& options) {
  std::string address = options.address, port = text;
  if (!text.empty() && text.front() == '[') {
    const std::size_t close = text.find(']');
    if (close == std::string::npos || close + 1 >= text.size() || text[close + 1] != ':')
      return Status::error("--view: expected [ADDR]:PORT, got '" + text + "'");
    address = text.substr(1, close - 1);
    port = text.substr(close + 2);
  } else if (const std::size_t colon = text.rfind(':'); colon != std::string::npos) {
    if (text.find(':') != colon)
      return Status::error("--view: an IPv6 address goes in brackets ([::1]:8765), got '" + text + "'");
    address = text.substr(0, colon);
    port = text.substr(colon + 1);
  }
  // At most five digits, so std::stoi cannot throw.
  if (port.empty() || port.size() > 5 || port.find_first_not_of("0123456789") != std::string::npos ||
      std::stoi(port) > 65535)
    return Status::error("--view: expected a port number 0-65535, got '" + port + "'");
  boost::system::error_code ec;
  boost::asio::ip::make_address(address, ec);
  if (ec) return Status::error("--view: '" + address + "' is not an IP address");
  options.address = address;
  options.port = std::stoi(port);
  return {};
}

Result<std::unique_ptr<ViewServer>> start_view(Executor& executor, const ViewOptions& options) {
  auto server = std::make_unique<Server>(executor, options);
  if (Status s = server->start(); !s.ok()) return s;
  return std::unique_ptr<ViewServer>(std::move(server));
}

}  // namespace saccade::view
