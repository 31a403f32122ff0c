// A seeded UDP relay for the streaming tests, the demo and the benchmarks:
// it sits between the clients and the server's UDP endpoint (the client
// sends its HELLO to the relay's front, `fetch --udp-via` or the server's
// --udp-advertise) and forwards both ways with impairments drawn from the
// one link model (codec/loss/link_model.h: loss, Bernoulli or in
// Gilbert-Elliott bursts, delay with jitter, extra reordering, duplicates),
// the same the session cores' simulated network draws from, so a relay
// run's fates can be replayed in process. Every client address on the front gets its own
// upstream socket, so the server sees one source per client and its replies
// find their way back. The front listens on loopback unless
// RelayOptions::bind says where (the host side of a network namespace's
// veth, for clients inside it). One thread; all randomness from one
// SimulatedLink per direction (to the server seeded with its model's seed,
// to the clients with the seed ^ 0x9E3779B97F4A7C15), so a run is
// reproducible for the same order of arrivals.
//
// For the hostile-traffic tests it records what passed (a bounded copy) and
// can inject any bytes towards a client or the server.
//
// Thread safety: Start/Stop and the accessors from any thread.
#ifndef MESHSTREAM_TESTING_UDP_RELAY_H_
#define MESHSTREAM_TESTING_UDP_RELAY_H_

#include <poll.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <queue>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include "codec/core/status.h"
#include "codec/loss/link_model.h"
#include "net/steady_clock.h"
#include "net/udp_socket.h"

namespace meshstream::test_util {

struct RelayOptions {
  SocketAddress upstream;              // the server's UDP endpoint
  LinkModel to_server, to_client;
  size_t max_clients = 256;
  size_t max_queued = 1 << 16;         // delayed datagrams in flight, both ways
  size_t record = 0;                   // keep a copy of the first N datagrams passed to clients
  // Where the front listens and the upstream sockets are bound, "HOST:PORT"
  // (port 0: any free one; the upstream sockets always take any free port on
  // HOST). Empty: the loopback of the upstream's family, "127.0.0.1:0" or
  // "[::1]:0". A namespace's clients need the host side of its veth. Last,
  // so that positional initialisers of the fields above keep their meaning.
  std::string bind;
};

struct RelayCounters {
  uint64_t in = 0, dropped = 0, duplicated = 0, forwarded = 0, bytes = 0;
};

class UdpRelay {
 public:
  static StatusOr<std::unique_ptr<UdpRelay>> Start(const RelayOptions& options) {
    const std::string bind =
        !options.bind.empty() ? options.bind : options.upstream.family() == AF_INET6 ? "[::1]:0" : "127.0.0.1:0";
    auto front_address = SocketAddress::Parse(bind);
    if (!front_address.ok()) return front_address.status();
    auto front = UdpSocket::Bind(*front_address);
    if (!front.ok()) return front.status();
    std::unique_ptr<UdpRelay> r(new UdpRelay(options));
    r->front_ = std::move(front).value();
    // The upstream sockets: the front's host, any port.
    r->upstream_bind_ = front_address->family() == AF_INET6 ? "[" + front_address->host() + "]:0"
                                                            : front_address->host() + ":0";
    UdpRelay* raw = r.get();
    r->thread_ = std::thread([raw] { raw->Run(); });
    return r;
  }
  ~UdpRelay() { Stop(); }

  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }

  const SocketAddress& front() const { return front_.local(); }
  RelayCounters to_server() const { return Counters(0); }
  RelayCounters to_client() const { return Counters(1); }
  std::vector<SocketAddress> clients() const {
    std::lock_guard<std::mutex> lock(mutex_);
    std::vector<SocketAddress> out;
    for (const auto& c : clients_) out.push_back(c->address);
    return out;
  }
  // Copies of the datagrams forwarded to clients (RelayOptions::record).
  std::vector<std::vector<uint8_t>> recorded() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return recorded_;
  }
  // Sends bytes out of the front to `client` (as if from the server) or out
  // of the first client's upstream socket to the server (as if from it).
  Status InjectToClient(const SocketAddress& client, const std::vector<uint8_t>& bytes) {
    return front_.SendTo(client, bytes.data(), bytes.size());
  }
  Status InjectToServer(const std::vector<uint8_t>& bytes) {
    std::lock_guard<std::mutex> lock(mutex_);
    if (clients_.empty()) return FailedPrecondition("no client has sent anything yet");
    return clients_.front()->socket.SendTo(options_.upstream, bytes.data(), bytes.size());
  }

 private:
  struct Client {
    SocketAddress address;
    UdpSocket socket;  // towards the server
  };
  struct Pending {
    uint64_t due_us;
    uint64_t order;
    int direction;     // 0: to the server, 1: to a client
    size_t client;
    std::vector<uint8_t> bytes;
    bool operator>(const Pending& o) const { return due_us != o.due_us ? due_us > o.due_us : order > o.order; }
  };
  struct Direction {
    SimulatedLink link;
    RelayCounters counters;
  };

  explicit UdpRelay(const RelayOptions& options)
      : options_(options),
        directions_{Direction{SimulatedLink(options.to_server, options.to_server.seed), {}},
                    Direction{SimulatedLink(options.to_client, options.to_client.seed ^ 0x9E3779B97F4A7C15ull), {}}} {}

  RelayCounters Counters(int d) const {
    std::lock_guard<std::mutex> lock(mutex_);
    return directions_[d].counters;
  }

  // Decides the fate of one datagram and queues its copies.
  void Admit(int direction, size_t client, std::vector<uint8_t>&& bytes, uint64_t now) {
    Direction& d = directions_[direction];
    ++d.counters.in;
    d.counters.bytes += bytes.size();
    const DatagramFate fate = d.link.Next();
    if (fate.copies == 0) {
      ++d.counters.dropped;
      return;
    }
    if (fate.copies == 2) ++d.counters.duplicated;
    for (int c = 0; c < fate.copies; ++c) {
      if (queue_.size() >= options_.max_queued) {
        ++d.counters.dropped;
        continue;
      }
      queue_.push(Pending{now + fate.delay_us[c], order_++, direction, client,
                          c + 1 < fate.copies ? bytes : std::move(bytes)});
    }
  }

  void Deliver(const Pending& p) {
    std::lock_guard<std::mutex> lock(mutex_);
    Direction& d = directions_[p.direction];
    Client& c = *clients_[p.client];
    const Status s = p.direction == 0 ? c.socket.SendTo(options_.upstream, p.bytes.data(), p.bytes.size())
                                      : front_.SendTo(c.address, p.bytes.data(), p.bytes.size());
    if (s.ok()) {
      ++d.counters.forwarded;
      if (p.direction == 1 && recorded_.size() < options_.record) recorded_.push_back(p.bytes);
    }
  }

  void Run() {
    std::vector<IncomingDatagram> batch(32);
    while (!stop_) {
      uint64_t now = SteadyNowUs();
      while (!queue_.empty() && queue_.top().due_us <= now) {
        Deliver(queue_.top());
        queue_.pop();
      }
      int timeout_ms = 20;
      if (!queue_.empty()) timeout_ms = static_cast<int>(std::min<uint64_t>(20, (queue_.top().due_us - now) / 1000));
      std::vector<pollfd> fds;
      fds.push_back({front_.fd(), POLLIN, 0});
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (const auto& c : clients_) fds.push_back({c->socket.fd(), POLLIN, 0});
      }
      if (poll(fds.data(), fds.size(), timeout_ms) <= 0) continue;
      now = SteadyNowUs();
      for (size_t f = 0; f < fds.size(); ++f) {
        if ((fds[f].revents & POLLIN) == 0) continue;
        UdpSocket* socket = nullptr;
        {
          std::lock_guard<std::mutex> lock(mutex_);
          socket = f == 0 ? &front_ : &clients_[f - 1]->socket;
        }
        auto n = socket->ReceiveBatch(&batch, 65536, 0);
        if (!n.ok()) continue;
        std::lock_guard<std::mutex> lock(mutex_);
        for (size_t i = 0; i < n.value(); ++i) {
          if (f == 0) {
            size_t index = SIZE_MAX;
            for (size_t k = 0; k < clients_.size(); ++k) {
              if (clients_[k]->address == batch[i].from) index = k;
            }
            if (index == SIZE_MAX) {
              if (clients_.size() >= options_.max_clients) continue;
              auto upstream = UdpSocket::Bind(*SocketAddress::Parse(upstream_bind_));
              if (!upstream.ok()) continue;
              clients_.push_back(std::make_unique<Client>(Client{batch[i].from, std::move(upstream).value()}));
              index = clients_.size() - 1;
            }
            Admit(0, index, std::move(batch[i].data), now);
          } else {
            Admit(1, f - 1, std::move(batch[i].data), now);
          }
        }
      }
    }
  }

  RelayOptions options_;
  std::string upstream_bind_;  // "HOST:0", HOST the front's
  UdpSocket front_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;  // clients_, counters, recorded_ (the queue is the thread's)
  std::vector<std::unique_ptr<Client>> clients_;
  Direction directions_[2];
  std::vector<std::vector<uint8_t>> recorded_;
  std::priority_queue<Pending, std::vector<Pending>, std::greater<Pending>> queue_;
  uint64_t order_ = 0;
};

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTING_UDP_RELAY_H_
