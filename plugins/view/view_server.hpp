#pragma once
// The live view: an HTTP and WebSocket server on one port, inside the process
// that runs a graph. It speaks the Foxglove WebSocket protocol
// (foxglove.websocket.v1), so Foxglove connects to it live, and serves its own
// page (the graph with per-node stats, any image port, the fovea's box, the
// head's joints; a box dragged on a frame goes to the fovea's `target`).
//
// Every output of a known message type is a channel, "/<node>/<port>":
//  - the message as CDR (ROS 2's sensor_msgs for images and joint states,
//    saccade's IDL type for the rest: plugins/dds/channel.hpp);
//  - images, retinas and feature maps also as "/<node>/<port>/jpeg"
//    (sensor_msgs/msg/CompressedImage: the frame, the retina's levels or the
//    maps side by side);
//  - every other described type also as "/<node>/<port>/json" (JSON with its
//    JSON Schema), and "/saccade/stats" carries the graph's stats once a second.
// A client may publish JSON Regions (clientPublish) on "/<node>/<input>" for
// any side input that takes a Region: the message reaches that input through
// Executor::inject.
//
// Frames go at the viewer's pace and never slow the graph: a tap only swaps
// the newest message of its output under a small lock (nothing at all while
// nobody subscribes); one thread encodes the newest message of each
// subscribed channel (at most `max_rate_hz` a channel) and a network thread
// sends it; a client still busy with an older frame gets only the newest one
// when it is ready.
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "saccade/status.hpp"

namespace saccade {
class Executor;
}

namespace saccade::view {

struct ViewOptions {
  std::string address = "127.0.0.1";  // loopback unless told
  int port = 8765;                    // 0: a free port the kernel picks
  double max_rate_hz = 30.0;          // messages per second per channel, at most
  // The share of one core the view's own threads (encoding, sending) may
  // use; past it, pictures wait (every channel's rate falls) instead of the
  // graph slowing down. <= 0: no limit.
  double cpu_share = 0.04;
  int jpeg_quality = 80;
  // A WebSocket message from a client larger than this closes that client
  // (counted as oversize); an HTTP request larger than this is refused.
  std::size_t max_client_message = 64 * 1024;
  double stats_interval_s = 1.0;  // of /saccade/stats
};

// "[ADDR:]PORT" (e.g. "8765", "0.0.0.0:8765", "[::1]:8765") into `options`
// (its other fields kept); an error saying what is wrong leaves it unchanged.
Status parse_view_address(const std::string& text, ViewOptions& options);

// What the server has seen, for the page, the stats and tests.
struct ViewCounters {
  uint64_t clients = 0;      // connected WebSocket clients now
  uint64_t connections = 0;  // WebSocket clients since the start
  uint64_t http_requests = 0;
  uint64_t messages_sent = 0;   // messageData frames
  uint64_t malformed = 0;       // client messages dropped: not JSON, unknown op, bad fields, bad binary
  uint64_t oversize = 0;        // client messages or requests over max_client_message (connection closed)
  uint64_t injected = 0;        // client-published Regions given to a side input
  uint64_t inject_refused = 0;  // client-published messages the executor refused
  uint64_t budget_waits = 0;    // rounds pictures waited for the view's CPU allowance (cpu_share)
};

class ViewServer {
 public:
  virtual ~ViewServer();
  // The port it listens on (the kernel's choice when asked for 0).
  virtual int port() const = 0;
  // http://address:port/
  virtual std::string url() const = 0;
  virtual ViewCounters counters() const = 0;
  // Closes every connection and joins the threads; the destructor does it too.
  virtual void stop() = 0;
};

// Taps every output of `executor` (opened, not yet running) and listens on
// options.address:options.port: the running server, or an error when it
// cannot (the port is in use, a bad address). Keep the server until run()
// returned, then stop it (or destroy it) before the executor.
Result<std::unique_ptr<ViewServer>> start_view(Executor& executor, const ViewOptions& options);

}  // namespace saccade::view
