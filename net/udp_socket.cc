#include "net/udp_socket.h"

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
#include <netdb.h>
#include <netinet/in.h>
#include <poll.h>
#include <unistd.h>

#include <cstring>
#include <functional>

namespace meshstream {

namespace {

std::string ErrnoText() { return std::strerror(errno); }

}  // namespace

Status SplitHostPort(const std::string& host_port, std::string* host, uint16_t* port) {
  const Status bad = InvalidArgument("\"" + host_port + "\": not HOST:PORT (or [IPV6]:PORT)");
  std::string h, p;
  if (!host_port.empty() && host_port[0] == '[') {
    const size_t close = host_port.find(']');
    if (close == std::string::npos || close + 1 >= host_port.size() || host_port[close + 1] != ':') return bad;
    h = host_port.substr(1, close - 1);
    p = host_port.substr(close + 2);
  } else {
    const size_t colon = host_port.rfind(':');
    if (colon == std::string::npos || host_port.find(':') != colon) return bad;
    h = host_port.substr(0, colon);
    p = host_port.substr(colon + 1);
  }
  if (h.empty() || p.empty() || p.size() > 5 || p.find_first_not_of("0123456789") != std::string::npos) return bad;
  const unsigned long value = std::stoul(p);
  if (value > 65535) return InvalidArgument("\"" + host_port + "\": the port is above 65535");
  *host = h;
  *port = static_cast<uint16_t>(value);
  return Status::Ok();
}

StatusOr<SocketAddress> SocketAddress::Resolve(const std::string& host, uint16_t port, int family) {
  addrinfo hints{};
  hints.ai_family = family;
  hints.ai_socktype = SOCK_DGRAM;
  hints.ai_flags = AI_NUMERICSERV;
  addrinfo* found = nullptr;
  const std::string service = std::to_string(port);
  const int rc = getaddrinfo(host.c_str(), service.c_str(), &hints, &found);
  if (rc != 0 || found == nullptr) {
    return Unavailable("\"" + host + "\": cannot resolve (" + gai_strerror(rc) + ")");
  }
  SocketAddress a = FromRaw(found->ai_addr, found->ai_addrlen);
  freeaddrinfo(found);
  return a;
}

StatusOr<SocketAddress> SocketAddress::Parse(const std::string& host_port, int family) {
  std::string host;
  uint16_t port = 0;
  Status s = SplitHostPort(host_port, &host, &port);
  if (!s.ok()) return s;
  return Resolve(host, port, family);
}

SocketAddress SocketAddress::FromRaw(const sockaddr* addr, socklen_t length) {
  SocketAddress a;
  if (addr == nullptr || length == 0 || length > sizeof(a.storage_)) return a;
  std::memcpy(&a.storage_, addr, length);
  a.length_ = length;
  return a;
}

uint16_t SocketAddress::port() const {
  if (family() == AF_INET) return ntohs(reinterpret_cast<const sockaddr_in*>(&storage_)->sin_port);
  if (family() == AF_INET6) return ntohs(reinterpret_cast<const sockaddr_in6*>(&storage_)->sin6_port);
  return 0;
}

std::string SocketAddress::host() const {
  char text[INET6_ADDRSTRLEN] = {0};
  if (family() == AF_INET) {
    inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(&storage_)->sin_addr, text, sizeof text);
  } else if (family() == AF_INET6) {
    inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(&storage_)->sin6_addr, text, sizeof text);
  }
  return text;
}

std::string SocketAddress::ToString() const {
  if (family() == AF_INET6) return "[" + host() + "]:" + std::to_string(port());
  return host() + ":" + std::to_string(port());
}

bool SocketAddress::IsUnspecified() const {
  if (family() == AF_INET) return reinterpret_cast<const sockaddr_in*>(&storage_)->sin_addr.s_addr == htonl(INADDR_ANY);
  if (family() == AF_INET6) {
    return IN6_IS_ADDR_UNSPECIFIED(&reinterpret_cast<const sockaddr_in6*>(&storage_)->sin6_addr);
  }
  return true;
}

bool SocketAddress::operator==(const SocketAddress& other) const {
  if (family() != other.family() || port() != other.port()) return false;
  if (family() == AF_INET) {
    return reinterpret_cast<const sockaddr_in*>(&storage_)->sin_addr.s_addr ==
           reinterpret_cast<const sockaddr_in*>(&other.storage_)->sin_addr.s_addr;
  }
  if (family() == AF_INET6) {
    return std::memcmp(&reinterpret_cast<const sockaddr_in6*>(&storage_)->sin6_addr,
                       &reinterpret_cast<const sockaddr_in6*>(&other.storage_)->sin6_addr, 16) == 0;
  }
  return length_ == other.length_;
}

size_t SocketAddress::Hash() const {
  size_t h = std::hash<uint32_t>()(static_cast<uint32_t>(family()) << 16 | port());
  if (family() == AF_INET) {
    h ^= std::hash<uint32_t>()(reinterpret_cast<const sockaddr_in*>(&storage_)->sin_addr.s_addr) * 31;
  } else if (family() == AF_INET6) {
    const uint8_t* b = reinterpret_cast<const sockaddr_in6*>(&storage_)->sin6_addr.s6_addr;
    for (int i = 0; i < 16; ++i) h = h * 131 + b[i];
  }
  return h;
}

StatusOr<UdpSocket> UdpSocket::Bind(const SocketAddress& address, int buffer_bytes) {
  if (address.empty()) return InvalidArgument("bind: no address");
  UdpSocket s;
  s.fd_ = socket(address.family(), SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, IPPROTO_UDP);
  if (s.fd_ < 0) return IoError("socket: " + ErrnoText());
  if (buffer_bytes > 0) {
    setsockopt(s.fd_, SOL_SOCKET, SO_RCVBUF, &buffer_bytes, sizeof buffer_bytes);
    setsockopt(s.fd_, SOL_SOCKET, SO_SNDBUF, &buffer_bytes, sizeof buffer_bytes);
  }
  if (bind(s.fd_, address.raw(), address.length()) != 0) {
    return Unavailable("bind " + address.ToString() + ": " + ErrnoText());
  }
  sockaddr_storage local{};
  socklen_t length = sizeof local;
  if (getsockname(s.fd_, reinterpret_cast<sockaddr*>(&local), &length) != 0) {
    return IoError("getsockname: " + ErrnoText());
  }
  s.local_ = SocketAddress::FromRaw(reinterpret_cast<sockaddr*>(&local), length);
  return s;
}

UdpSocket::~UdpSocket() {
  if (fd_ >= 0) close(fd_);
}

UdpSocket::UdpSocket(UdpSocket&& other) noexcept : fd_(other.fd_), local_(other.local_) { other.fd_ = -1; }

UdpSocket& UdpSocket::operator=(UdpSocket&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) close(fd_);
    fd_ = other.fd_;
    local_ = other.local_;
    other.fd_ = -1;
  }
  return *this;
}

Status UdpSocket::SendTo(const SocketAddress& to, const uint8_t* data, size_t size) {
  OutgoingDatagram d{&to, data, size};
  auto sent = SendBatch(&d, 1);
  if (!sent.ok()) return sent.status();
  if (sent.value() == 0) return Unavailable("send to " + to.ToString() + ": the socket's buffer is full");
  return Status::Ok();
}

StatusOr<size_t> UdpSocket::SendBatch(const OutgoingDatagram* batch, size_t count) {
  if (fd_ < 0) return FailedPrecondition("send: the socket is closed");
  constexpr size_t kChunk = 64;
  size_t done = 0;
  while (done < count) {
    const size_t n = std::min(kChunk, count - done);
    mmsghdr messages[kChunk];
    iovec vectors[kChunk];
    for (size_t i = 0; i < n; ++i) {
      const OutgoingDatagram& d = batch[done + i];
      if (d.to == nullptr || d.to->family() != local_.family()) {
        return InvalidArgument("send: the address is not of the socket's family");
      }
      vectors[i].iov_base = const_cast<uint8_t*>(d.data);
      vectors[i].iov_len = d.size;
      std::memset(&messages[i], 0, sizeof messages[i]);
      messages[i].msg_hdr.msg_name = const_cast<sockaddr*>(d.to->raw());
      messages[i].msg_hdr.msg_namelen = d.to->length();
      messages[i].msg_hdr.msg_iov = &vectors[i];
      messages[i].msg_hdr.msg_iovlen = 1;
    }
    const int rc = sendmmsg(fd_, messages, static_cast<unsigned>(n), 0);
    if (rc < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ENOBUFS) return done;
      if (errno == EINTR) continue;
      // An ICMP error of an earlier datagram (ECONNREFUSED) reports here on
      // some kernels; it says nothing about this batch: skip one and go on.
      if (errno == ECONNREFUSED) {
        ++done;
        continue;
      }
      return IoError("sendmmsg: " + ErrnoText());
    }
    done += static_cast<size_t>(rc);
    if (static_cast<size_t>(rc) < n) return done;
  }
  return done;
}

StatusOr<size_t> UdpSocket::ReceiveBatch(std::vector<IncomingDatagram>* out, size_t max_bytes, int timeout_ms) {
  if (fd_ < 0) return FailedPrecondition("receive: the socket is closed");
  if (out->empty()) return size_t{0};
  if (timeout_ms != 0) {
    pollfd p{fd_, POLLIN, 0};
    const int rc = poll(&p, 1, timeout_ms);
    if (rc < 0 && errno != EINTR) return IoError("poll: " + ErrnoText());
    if (rc <= 0) return size_t{0};
  }
  constexpr size_t kChunk = 64;
  const size_t n = std::min(kChunk, out->size());
  mmsghdr messages[kChunk];
  iovec vectors[kChunk];
  sockaddr_storage from[kChunk];
  for (size_t i = 0; i < n; ++i) {
    IncomingDatagram& d = (*out)[i];
    d.data.resize(max_bytes);
    vectors[i].iov_base = d.data.data();
    vectors[i].iov_len = d.data.size();
    std::memset(&messages[i], 0, sizeof messages[i]);
    messages[i].msg_hdr.msg_name = &from[i];
    messages[i].msg_hdr.msg_namelen = sizeof from[i];
    messages[i].msg_hdr.msg_iov = &vectors[i];
    messages[i].msg_hdr.msg_iovlen = 1;
  }
  int rc;
  do {
    rc = recvmmsg(fd_, messages, static_cast<unsigned>(n), MSG_DONTWAIT, nullptr);
  } while (rc < 0 && errno == EINTR);
  if (rc < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK || errno == ECONNREFUSED) return size_t{0};
    return IoError("recvmmsg: " + ErrnoText());
  }
  for (int i = 0; i < rc; ++i) {
    IncomingDatagram& d = (*out)[static_cast<size_t>(i)];
    d.truncated = (messages[i].msg_hdr.msg_flags & MSG_TRUNC) != 0;
    d.data.resize(std::min<size_t>(messages[i].msg_len, max_bytes));
    d.from = SocketAddress::FromRaw(reinterpret_cast<sockaddr*>(&from[i]), messages[i].msg_hdr.msg_namelen);
  }
  return static_cast<size_t>(rc);
}

}  // namespace meshstream
