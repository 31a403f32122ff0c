#include "bench/tcp_delay_proxy.h"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <time.h>

#include "net/steady_clock.h"

namespace meshstream::bench {
namespace {

StatusOr<sockaddr_in> ParseIpv4(const std::string& host_port) {
  const size_t colon = host_port.rfind(':');
  if (colon == std::string::npos) return InvalidArgument(host_port + ": not HOST:PORT");
  sockaddr_in a{};
  a.sin_family = AF_INET;
  const std::string host = host_port.substr(0, colon), port = host_port.substr(colon + 1);
  if (inet_pton(AF_INET, host.c_str(), &a.sin_addr) != 1) return InvalidArgument(host_port + ": not a numeric IPv4 host");
  char* end = nullptr;
  const long p = std::strtol(port.c_str(), &end, 10);
  if (port.empty() || *end != '\0' || p < 0 || p > 65535) return InvalidArgument(host_port + ": bad port");
  a.sin_port = htons(static_cast<uint16_t>(p));
  return a;
}

std::string ErrnoText(const std::string& what) { return what + ": " + std::strerror(errno); }

void NoDelayNonBlocking(int fd) {
  const int one = 1;
  setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) | O_NONBLOCK);
}

struct Chunk {
  uint64_t due_us;
  std::vector<uint8_t> bytes;
  size_t sent = 0;
};

// One direction of a connection: read from `from`, write to `to`.
struct Direction {
  int from = -1, to = -1;
  std::deque<Chunk> queue;
  size_t buffered = 0;
  bool eof = false;       // `from` said EOF
  bool shut = false;      // EOF passed on to `to`
  bool blocked = false;   // `to` said EAGAIN: wait for POLLOUT
  uint64_t bytes = 0;     // forwarded
};

struct Connection {
  int client = -1, server = -1;
  Direction up, down;  // up: client -> server; down: server -> client
  bool dead = false;
};

// Writes what is due; false on an error of `to`.
bool Flush(Direction& d, uint64_t now) {
  d.blocked = false;
  while (!d.queue.empty() && d.queue.front().due_us <= now) {
    Chunk& c = d.queue.front();
    const ssize_t n = send(d.to, c.bytes.data() + c.sent, c.bytes.size() - c.sent, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) {
        d.blocked = true;
        return true;
      }
      if (errno == EINTR) continue;
      return false;
    }
    c.sent += static_cast<size_t>(n);
    d.buffered -= static_cast<size_t>(n);
    d.bytes += static_cast<uint64_t>(n);
    if (c.sent == c.bytes.size()) d.queue.pop_front();
  }
  if (d.eof && d.queue.empty() && !d.shut) {
    shutdown(d.to, SHUT_WR);
    d.shut = true;
  }
  return true;
}

// Reads what `from` has (at most up to the bound); false on an error.
bool Fill(Direction& d, uint64_t now, uint64_t delay_us, size_t max_buffered) {
  uint8_t buffer[65536];
  while (!d.eof && d.buffered < max_buffered) {
    const size_t want = std::min(sizeof buffer, max_buffered - d.buffered);
    const ssize_t n = recv(d.from, buffer, want, MSG_DONTWAIT);
    if (n < 0) {
      if (errno == EAGAIN || errno == EWOULDBLOCK) return true;
      if (errno == EINTR) continue;
      return false;
    }
    if (n == 0) {
      d.eof = true;
      return true;
    }
    d.queue.push_back(Chunk{now + delay_us, std::vector<uint8_t>(buffer, buffer + n), 0});
    d.buffered += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

StatusOr<std::unique_ptr<TcpDelayProxy>> TcpDelayProxy::Start(const TcpDelayProxyOptions& options) {
  auto listen_at = ParseIpv4(options.listen);
  if (!listen_at.ok()) return listen_at.status();
  auto upstream = ParseIpv4(options.upstream);
  if (!upstream.ok()) return upstream.status();
  if (options.max_buffered == 0) return InvalidArgument("max_buffered: at least 1");
  std::unique_ptr<TcpDelayProxy> p(new TcpDelayProxy());
  p->options_ = options;
  p->listen_fd_ = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (p->listen_fd_ < 0) return Internal(ErrnoText("socket"));
  const int one = 1;
  setsockopt(p->listen_fd_, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  sockaddr_in a = *listen_at;
  if (bind(p->listen_fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    return Unavailable(ErrnoText("bind " + options.listen));
  }
  if (listen(p->listen_fd_, 64) != 0) return Internal(ErrnoText("listen"));
  socklen_t length = sizeof a;
  getsockname(p->listen_fd_, reinterpret_cast<sockaddr*>(&a), &length);
  char host[INET_ADDRSTRLEN] = {0};
  inet_ntop(AF_INET, &a.sin_addr, host, sizeof host);
  p->address_ = std::string(host) + ":" + std::to_string(ntohs(a.sin_port));
  fcntl(p->listen_fd_, F_SETFL, fcntl(p->listen_fd_, F_GETFL) | O_NONBLOCK);
  TcpDelayProxy* raw = p.get();
  p->thread_ = std::thread([raw] { raw->Run(); });
  return p;
}

TcpDelayProxy::~TcpDelayProxy() { Stop(); }

void TcpDelayProxy::Stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (listen_fd_ >= 0) {
    close(listen_fd_);
    listen_fd_ = -1;
  }
}

std::vector<TcpConnectionInfo> TcpDelayProxy::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

void TcpDelayProxy::Run() {
  const sockaddr_in upstream = *ParseIpv4(options_.upstream);
  std::vector<std::unique_ptr<Connection>> connections;
  auto finish = [&](Connection& c) {
    TcpConnectionInfo info;
    info.bytes_to_client = c.down.bytes;
    info.bytes_to_server = c.up.bytes;
    tcp_info t{};
    socklen_t length = sizeof t;
    if (getsockopt(c.client, IPPROTO_TCP, TCP_INFO, &t, &length) == 0) {
      info.rtt_ms = t.tcpi_rtt / 1000.0;
      info.rttvar_ms = t.tcpi_rttvar / 1000.0;
      info.total_retrans = t.tcpi_total_retrans;
      info.lost = t.tcpi_lost;
    }
    close(c.client);
    close(c.server);
    std::lock_guard<std::mutex> lock(mutex_);
    closed_.push_back(info);
  };
  std::vector<pollfd> fds;
  while (!stop_) {
    uint64_t now = SteadyNowUs();
    // Out with what is due; connections whose both directions are over go.
    uint64_t next_due = UINT64_MAX;
    for (auto& c : connections) {
      if (!c->dead && (!Flush(c->up, now) || !Flush(c->down, now))) c->dead = true;
      for (const Direction* d : {&c->up, &c->down}) {
        if (!d->queue.empty() && !d->blocked) next_due = std::min(next_due, d->queue.front().due_us);
      }
    }
    for (size_t i = 0; i < connections.size();) {
      Connection& c = *connections[i];
      if (c.dead || (c.up.shut && c.down.shut)) {
        finish(c);
        connections.erase(connections.begin() + static_cast<long>(i));
      } else {
        ++i;
      }
    }
    fds.clear();
    fds.push_back({listen_fd_, POLLIN, 0});
    for (auto& c : connections) {
      short client_events = 0, server_events = 0;
      if (!c->up.eof && c->up.buffered < options_.max_buffered) client_events |= POLLIN;
      if (!c->down.eof && c->down.buffered < options_.max_buffered) server_events |= POLLIN;
      if (c->down.blocked) client_events |= POLLOUT;
      if (c->up.blocked) server_events |= POLLOUT;
      // A socket with nothing wanted from it is left out (fd -1): a closed
      // peer would report POLLHUP on every call. Its errors show when the
      // next bytes for it are written.
      fds.push_back({client_events ? c->client : -1, client_events, 0});
      fds.push_back({server_events ? c->server : -1, server_events, 0});
    }
    uint64_t wait_us = 20000;  // wake now and then to see stop_
    if (next_due != UINT64_MAX) wait_us = next_due > now ? std::min<uint64_t>(wait_us, next_due - now) : 0;
    timespec timeout{static_cast<time_t>(wait_us / 1000000), static_cast<long>(wait_us % 1000000) * 1000};
    const int ready = ppoll(fds.data(), fds.size(), &timeout, nullptr);
    if (ready <= 0) continue;
    now = SteadyNowUs();
    for (size_t i = 0; i < connections.size(); ++i) {
      Connection& c = *connections[i];
      const pollfd& cf = fds[1 + 2 * i];
      const pollfd& sf = fds[2 + 2 * i];
      if (cf.revents & (POLLIN | POLLHUP | POLLERR)) {
        if (!Fill(c.up, now, options_.delay_us, options_.max_buffered)) c.dead = true;
      }
      if (sf.revents & (POLLIN | POLLHUP | POLLERR)) {
        if (!Fill(c.down, now, options_.delay_us, options_.max_buffered)) c.dead = true;
      }
      // POLLHUP without data to read (both directions closed by the peer)
      // is seen by recv as EOF above; POLLERR as an error.
      if ((cf.revents & POLLERR) || (sf.revents & POLLERR)) c.dead = true;
    }
    if (fds[0].revents & POLLIN) {
      for (;;) {
        const int fd = accept4(listen_fd_, nullptr, nullptr, SOCK_CLOEXEC);
        if (fd < 0) break;
        if (connections.size() >= options_.max_connections) {
          close(fd);
          continue;
        }
        const int up = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
        // The upstream is the server on this host: a blocking connect is
        // immediate (or refused).
        if (up < 0 || connect(up, reinterpret_cast<const sockaddr*>(&upstream), sizeof upstream) != 0) {
          if (up >= 0) close(up);
          close(fd);
          continue;
        }
        NoDelayNonBlocking(fd);
        NoDelayNonBlocking(up);
        auto c = std::make_unique<Connection>();
        c->client = fd;
        c->server = up;
        c->up.from = fd;
        c->up.to = up;
        c->down.from = up;
        c->down.to = fd;
        connections.push_back(std::move(c));
        ++accepted_;
      }
    }
  }
  for (auto& c : connections) finish(*c);
}

}  // namespace meshstream::bench
