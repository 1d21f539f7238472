#include "socketcan.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <vector>

namespace saccade::can {

static_assert(kEffFlag == CAN_EFF_FLAG && kRtrFlag == CAN_RTR_FLAG && kErrFlag == CAN_ERR_FLAG);
static_assert(kInvFilter == CAN_INV_FILTER && error_class::kBusOff == CAN_ERR_BUSOFF);
static_assert(controller_status::kRxPassive == CAN_ERR_CRTL_RX_PASSIVE);

Result<std::unique_ptr<SocketCan>> SocketCan::open(const std::string& interface) {
  const std::string where = "socketcan '" + interface + "'";
  if (interface.empty() || interface.size() >= IFNAMSIZ)
    return Status::error(where + ": expected an interface name such as can0 (at most " + std::to_string(IFNAMSIZ - 1) +
                         " characters)");
  const int fd = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0)
    return Status::error(where + ": this kernel has no CAN sockets (socket(PF_CAN): " + std::strerror(errno) + ")");
  const auto fail = [&](const std::string& what) {
    const int failure = errno;  // before close() can change it
    ::close(fd);
    return Status::error(where + ": " + what + ": " + std::strerror(failure));
  };
  const int on = 1;
  // FD frames are accepted where the interface speaks FD; a kernel without FD
  // support refuses the option, which only matters for FD traffic.
  (void)::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on);
  if (::setsockopt(fd, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof on) != 0) return fail("SO_TIMESTAMPNS");
  // Bus-off, controller state and restarts always arrive: state() follows them.
  const can_err_mask_t errors = CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_RESTARTED;
  if (::setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors) != 0) return fail("CAN_RAW_ERR_FILTER");
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, interface.c_str(), IFNAMSIZ - 1);
  if (::ioctl(fd, SIOCGIFINDEX, &ifr) != 0) return fail("no such interface");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifr.ifr_ifindex;
  if (::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return fail("bind");
  return std::unique_ptr<SocketCan>(new SocketCan(fd, interface));
}

SocketCan::~SocketCan() { ::close(fd_); }

bool SocketCan::send(const Frame& f) {
  canfd_frame k{};
  k.can_id = f.raw_id();
  k.len = f.length;
  k.flags = f.fd_flags;
  std::memcpy(k.data, f.data.data(), f.length);
  const std::size_t size = f.fd ? CANFD_MTU : CAN_MTU;
  for (;;) {
    const ssize_t n = ::write(fd_, &k, size);
    if (n == static_cast<ssize_t>(size)) {
      ++counters_.sent;
      return true;
    }
    if (n < 0 && errno == EINTR) continue;
    // ENOBUFS: the interface's transmit queue is full (a silent bus, nobody
    // acknowledging); EAGAIN: the socket buffer is. Either way this frame is
    // not sent; the next control cycle sends fresh set-points.
    last_error_ = n < 0 ? std::strerror(errno) : "short write";
    ++counters_.send_failed;
    return false;
  }
}

bool SocketCan::receive(Frame& out, int64_t timeout_ns) {
  for (;;) {
    canfd_frame k{};
    iovec io{&k, sizeof k};
    alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
    msghdr msg{};
    msg.msg_iov = &io;
    msg.msg_iovlen = 1;
    msg.msg_control = control;
    msg.msg_controllen = sizeof control;
    const ssize_t n = ::recvmsg(fd_, &msg, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        last_error_ = std::strerror(errno);
        return false;
      }
      if (timeout_ns <= 0) return false;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, static_cast<int>((timeout_ns + 999'999) / 1'000'000)) <= 0) return false;
      timeout_ns = 0;
      continue;
    }
    if (n != CAN_MTU && n != CANFD_MTU) continue;
    out = Frame::from_raw_id(k.can_id);
    out.fd = n == CANFD_MTU;
    out.fd_flags = out.fd ? k.flags : 0;
    out.length = std::min<uint8_t>(k.len, out.fd ? 64 : 8);
    std::memcpy(out.data.data(), k.data, out.length);
    out.timestamp_ns = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c))
      if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
        timespec ts;
        std::memcpy(&ts, CMSG_DATA(c), sizeof ts);
        out.timestamp_ns = static_cast<int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
      }
    if (out.error) {
      track_state(out);
      if ((out.id & error_mask_) == 0) continue;  // asked for by state() only
      ++counters_.error_frames;
    }
    ++counters_.received;
    return true;
  }
}

void SocketCan::track_state(const Frame& e) {
  if (e.id & CAN_ERR_BUSOFF) {
    state_ = BusState::kBusOff;
  } else if (e.id & CAN_ERR_RESTARTED) {
    state_ = BusState::kErrorActive;
  } else if (e.id & CAN_ERR_CRTL) {
    const uint8_t s = e.data[1];
    if (s & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE))
      state_ = BusState::kErrorPassive;
    else if (s & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING))
      state_ = BusState::kErrorWarning;
    else if (s & CAN_ERR_CRTL_ACTIVE)
      state_ = BusState::kErrorActive;
  }
}

void SocketCan::set_filters(FilterSet filters) {
  std::vector<can_filter> k(filters.filters.size());
  for (std::size_t i = 0; i < k.size(); ++i) k[i] = {filters.filters[i].id, filters.filters[i].mask};
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, k.data(), static_cast<socklen_t>(k.size() * sizeof(can_filter)));
  error_mask_ = filters.error_mask;
  const int join = filters.join ? 1 : 0;
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_JOIN_FILTERS, &join, sizeof join);
  const can_err_mask_t errors = filters.error_mask | CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_RESTARTED;
  ::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &errors, sizeof errors);
}

}  // namespace saccade::can
