// A UDP socket and the addresses it talks to: the only file of net/ that
// makes system calls. IPv4 and IPv6; non-blocking; batches with sendmmsg and
// recvmmsg so that a sender pays one system call for many datagrams.
//
// Contract: every function returns a Status (or a count) and never throws;
// Receive* never writes past the buffers it is given, and reports a datagram
// longer than its buffer as truncated (MSG_TRUNC) so the caller can drop it
// as too long instead of parsing a prefix. Sending to an address that is not
// of the socket's family is InvalidArgument.
// Thread safety: SendTo/SendBatch may be called from several threads at once
// (the kernel serialises them); one thread receives.
#ifndef MESHSTREAM_NET_UDP_SOCKET_H_
#define MESHSTREAM_NET_UDP_SOCKET_H_

#include <sys/socket.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream {

class SocketAddress {
 public:
  SocketAddress() = default;
  // "HOST:PORT", "[V6]:PORT"; HOST is a numeric address or a name
  // (resolved once, the first answer of the wanted family, AF_UNSPEC: any).
  static StatusOr<SocketAddress> Parse(const std::string& host_port, int family = AF_UNSPEC);
  static StatusOr<SocketAddress> Resolve(const std::string& host, uint16_t port, int family = AF_UNSPEC);
  static SocketAddress FromRaw(const sockaddr* addr, socklen_t length);

  int family() const { return storage_.ss_family; }
  uint16_t port() const;
  std::string host() const;       // numeric, without brackets
  std::string ToString() const;   // "1.2.3.4:5", "[::1]:5"
  bool IsUnspecified() const;     // 0.0.0.0 or ::
  const sockaddr* raw() const { return reinterpret_cast<const sockaddr*>(&storage_); }
  socklen_t length() const { return length_; }
  bool empty() const { return length_ == 0; }
  bool operator==(const SocketAddress& other) const;
  bool operator!=(const SocketAddress& other) const { return !(*this == other); }
  size_t Hash() const;

 private:
  sockaddr_storage storage_{};
  socklen_t length_ = 0;
};

struct SocketAddressHash {
  size_t operator()(const SocketAddress& a) const { return a.Hash(); }
};

// Splits "HOST:PORT" / "[V6]:PORT"; InvalidArgument naming the text when it is neither.
Status SplitHostPort(const std::string& host_port, std::string* host, uint16_t* port);

struct OutgoingDatagram {
  const SocketAddress* to = nullptr;
  const uint8_t* data = nullptr;
  size_t size = 0;
};

struct IncomingDatagram {
  SocketAddress from;
  std::vector<uint8_t> data;  // resized to what arrived (at most the buffer size)
  bool truncated = false;     // the datagram was longer than the buffer
};

class UdpSocket {
 public:
  // Binds to `address` (port 0: any free one); SO_RCVBUF/SO_SNDBUF raised
  // towards `buffer_bytes` (the kernel may cap it).
  static StatusOr<UdpSocket> Bind(const SocketAddress& address, int buffer_bytes = 4 << 20);
  UdpSocket() = default;
  ~UdpSocket();
  UdpSocket(UdpSocket&& other) noexcept;
  UdpSocket& operator=(UdpSocket&& other) noexcept;
  UdpSocket(const UdpSocket&) = delete;
  UdpSocket& operator=(const UdpSocket&) = delete;

  bool valid() const { return fd_ >= 0; }
  int fd() const { return fd_; }
  const SocketAddress& local() const { return local_; }

  // One datagram; Unavailable when the kernel's buffer is full (EAGAIN), IoError otherwise.
  Status SendTo(const SocketAddress& to, const uint8_t* data, size_t size);
  // As many of `batch` as the kernel takes (sendmmsg), in order; returns how
  // many were sent (fewer when the buffer filled: retry the rest later).
  StatusOr<size_t> SendBatch(const OutgoingDatagram* batch, size_t count);
  // Waits at most timeout_ms (0: do not wait, -1: forever) for the socket to
  // be readable, then reads up to out->size() datagrams (recvmmsg), each at
  // most max_bytes; returns how many (0 on timeout). `out` keeps its buffers.
  StatusOr<size_t> ReceiveBatch(std::vector<IncomingDatagram>* out, size_t max_bytes, int timeout_ms);

 private:
  int fd_ = -1;
  SocketAddress local_;
};

}  // namespace meshstream

#endif  // MESHSTREAM_NET_UDP_SOCKET_H_
