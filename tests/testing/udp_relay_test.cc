// The tests' UDP relay (testing/udp_relay.h) with real sockets: clean
// forwarding both ways in order, Bernoulli loss near its rate and the same
// losses for the same seed, Gilbert-Elliott bursts longer than Bernoulli's at
// the same mean, duplicates, delay, one upstream socket per client, and a
// front bound where asked (RelayOptions::bind).
#include "testing/udp_relay.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <set>
#include <thread>

namespace meshstream::test_util {
namespace {

struct Endpoint {
  UdpSocket socket = std::move(UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"))).value();
  // Until `want` arrived or nothing came for `idle_ms` (a bound on a datagram that will not come).
  std::vector<IncomingDatagram> Receive(size_t want, int idle_ms = 2000) {
    std::vector<IncomingDatagram> out, batch(32);
    while (out.size() < want) {
      auto n = socket.ReceiveBatch(&batch, 2000, idle_ms);
      if (!n.ok() || n.value() == 0) break;
      for (size_t i = 0; i < n.value(); ++i) out.push_back(batch[i]);
    }
    return out;
  }
};

std::vector<uint8_t> Numbered(uint32_t i) {
  std::vector<uint8_t> d(64, 0);
  for (int b = 0; b < 4; ++b) d[static_cast<size_t>(b)] = static_cast<uint8_t>(i >> (8 * b));
  return d;
}
uint32_t NumberOf(const std::vector<uint8_t>& d) {
  return static_cast<uint32_t>(d[0]) | static_cast<uint32_t>(d[1]) << 8 | static_cast<uint32_t>(d[2]) << 16 |
         static_cast<uint32_t>(d[3]) << 24;
}

// Sends n numbered datagrams from `from` through the relay, 64 at a time:
// the next 64 only once the relay has taken the last ones in (its counter),
// so no socket buffer overflows however slowly its thread runs, and the
// kernel never drops what the seeded link model did not. Returns the
// numbers that arrived.
std::vector<uint32_t> Through(UdpRelay& relay, Endpoint& from, Endpoint& server, uint32_t n) {
  std::vector<uint32_t> got;
  std::vector<IncomingDatagram> batch(64);
  for (uint32_t i = 0; i < n; ++i) {
    const std::vector<uint8_t> d = Numbered(i);
    EXPECT_TRUE(from.socket.SendTo(relay.front(), d.data(), d.size()).ok());
    if (i % 64 == 63 || i + 1 == n) {
      const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
      while (relay.to_server().in < i + 1 && std::chrono::steady_clock::now() < deadline) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      EXPECT_EQ(relay.to_server().in, i + 1u) << "the relay did not take the datagrams in";
      // Everything the relay has forwarded so far, taken off the server's
      // socket before the next batch (so that it never overflows either).
      const uint64_t forwarded = relay.to_server().forwarded;
      while (got.size() < forwarded && std::chrono::steady_clock::now() < deadline) {
        auto k = server.socket.ReceiveBatch(&batch, 2000, 100);
        if (!k.ok()) break;
        for (size_t j = 0; j < k.value(); ++j) got.push_back(NumberOf(batch[j].data));
      }
    }
  }
  for (const IncomingDatagram& d : server.Receive(n)) got.push_back(NumberOf(d.data));
  return got;
}

TEST(UdpRelay, ForwardsBothWaysInOrderWhenClean) {
  Endpoint server, client;
  RelayOptions o;
  o.upstream = server.socket.local();
  auto relay = UdpRelay::Start(o);
  ASSERT_TRUE(relay.ok());
  const std::vector<uint32_t> got = Through(**relay, client, server, 500);
  ASSERT_EQ(got.size(), 500u);
  for (uint32_t i = 0; i < 500; ++i) EXPECT_EQ(got[i], i);
  // A reply goes back through the relay to the client.
  const SocketAddress upstream_of_client = [&] {
    const std::vector<uint8_t> d = Numbered(9999);
    EXPECT_TRUE(client.socket.SendTo((*relay)->front(), d.data(), d.size()).ok());
    return server.Receive(1).at(0).from;
  }();
  const std::vector<uint8_t> reply = Numbered(42);
  ASSERT_TRUE(server.socket.SendTo(upstream_of_client, reply.data(), reply.size()).ok());
  const auto back = client.Receive(1);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(NumberOf(back[0].data), 42u);
  EXPECT_EQ(back[0].from, (*relay)->front());
  EXPECT_EQ((*relay)->to_server().forwarded, 501u);
  EXPECT_EQ((*relay)->to_client().forwarded, 1u);
}

TEST(UdpRelay, BernoulliLossIsNearItsRateAndTheSameForTheSameSeed) {
  std::vector<std::vector<uint32_t>> runs;
  for (int run = 0; run < 2; ++run) {
    Endpoint server, client;
    RelayOptions o;
    o.upstream = server.socket.local();
    o.to_server = LinkModel::Loss(0.3, 7);
    auto relay = UdpRelay::Start(o);
    ASSERT_TRUE(relay.ok());
    runs.push_back(Through(**relay, client, server, 20000));
    const double loss = 1.0 - static_cast<double>(runs.back().size()) / 20000.0;
    // sigma = sqrt(0.3 * 0.7 / 20000) = 0.0032: 5 sigma.
    EXPECT_NEAR(loss, 0.3, 0.016);
    EXPECT_EQ((*relay)->to_server().dropped + (*relay)->to_server().forwarded, 20000u);
  }
  EXPECT_EQ(runs[0], runs[1]) << "the same seed drops the same datagrams";
}

double MeanBurst(const std::vector<uint32_t>& got, uint32_t n) {
  std::set<uint32_t> arrived(got.begin(), got.end());
  uint64_t bursts = 0, lost = 0;
  bool in = false;
  for (uint32_t i = 0; i < n; ++i) {
    const bool l = arrived.count(i) == 0;
    lost += l;
    if (l && !in) ++bursts;
    in = l;
  }
  return bursts == 0 ? 0 : static_cast<double>(lost) / static_cast<double>(bursts);
}

TEST(UdpRelay, GilbertElliottBurstsAreLongerAtTheSameMean) {
  Endpoint server_a, client_a, server_b, client_b;
  RelayOptions a, b;
  a.upstream = server_a.socket.local();
  a.to_server = LinkModel::Bursts(0.12, 4.0, 3);
  b.upstream = server_b.socket.local();
  b.to_server = LinkModel::Loss(0.12, 3);
  auto ra = UdpRelay::Start(a), rb = UdpRelay::Start(b);
  ASSERT_TRUE(ra.ok() && rb.ok());
  const uint32_t n = 20000;
  const auto got_a = Through(**ra, client_a, server_a, n);
  const auto got_b = Through(**rb, client_b, server_b, n);
  const double loss_a = 1.0 - static_cast<double>(got_a.size()) / n;
  EXPECT_NEAR(loss_a, 0.12, 0.03) << "bursts vary more than Bernoulli";
  const double burst_a = MeanBurst(got_a, n), burst_b = MeanBurst(got_b, n);
  EXPECT_NEAR(burst_a, 4.0, 1.0);
  EXPECT_LT(burst_b, 1.5) << "Bernoulli at 12 %: runs of about 1.14";
}

TEST(UdpRelay, ABurstyRunReplaysInProcessFromTheLinkModel) {
  // The relay draws its fates from the one link model: the datagrams a
  // bursty run dropped are those a SimulatedLink of the same model and seed
  // drops, so the session cores' simulated network can replay the run.
  Endpoint server, client;
  RelayOptions o;
  o.upstream = server.socket.local();
  o.to_server = LinkModel::Bursts(0.2, 5.0, 17);
  auto relay = UdpRelay::Start(o);
  ASSERT_TRUE(relay.ok());
  const uint32_t n = 5000;
  const std::vector<uint32_t> got = Through(**relay, client, server, n);
  SimulatedLink replay(o.to_server, o.to_server.seed);
  std::vector<uint32_t> want;
  for (uint32_t i = 0; i < n; ++i) {
    if (replay.Next().copies > 0) want.push_back(i);
  }
  EXPECT_EQ(got, want);
  EXPECT_GT(n - want.size(), 500u) << "the run lost something to replay";
}

TEST(UdpRelay, DuplicatesDelayAndReordering) {
  Endpoint server, client;
  RelayOptions o;
  o.upstream = server.socket.local();
  o.to_server.duplicate = 0.5;
  o.to_server.delay_us = 20000;
  o.to_server.jitter_us = 10000;
  o.to_server.seed = 5;
  auto relay = UdpRelay::Start(o);
  ASSERT_TRUE(relay.ok());
  const auto sent = std::chrono::steady_clock::now();
  for (uint32_t i = 0; i < 200; ++i) {
    const std::vector<uint8_t> d = Numbered(i);
    ASSERT_TRUE(client.socket.SendTo((*relay)->front(), d.data(), d.size()).ok());
  }
  const auto first = server.Receive(1, 10000);
  ASSERT_GE(first.size(), 1u);
  EXPECT_GE(std::chrono::steady_clock::now() - sent, std::chrono::milliseconds(19)) << "not before the delay";
  auto rest = server.Receive(1000);
  rest.insert(rest.begin(), first.begin(), first.end());
  EXPECT_GT(rest.size(), 250u);
  EXPECT_LT(rest.size(), 350u);
  EXPECT_EQ(rest.size(), 200 + (*relay)->to_server().duplicated);
  bool out_of_order = false;
  for (size_t i = 1; i < rest.size(); ++i) out_of_order = out_of_order || NumberOf(rest[i].data) < NumberOf(rest[i - 1].data);
  EXPECT_TRUE(out_of_order) << "jitter reorders";
}

TEST(UdpRelay, EachClientHasItsOwnUpstreamSocket) {
  Endpoint server, one, two;
  RelayOptions o;
  o.upstream = server.socket.local();
  auto relay = UdpRelay::Start(o);
  ASSERT_TRUE(relay.ok());
  const std::vector<uint8_t> d1 = Numbered(1), d2 = Numbered(2);
  ASSERT_TRUE(one.socket.SendTo((*relay)->front(), d1.data(), d1.size()).ok());
  const auto a = server.Receive(1);
  ASSERT_TRUE(two.socket.SendTo((*relay)->front(), d2.data(), d2.size()).ok());
  const auto b = server.Receive(1);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NE(a[0].from, b[0].from);
  EXPECT_EQ((*relay)->clients().size(), 2u);
  // Replies to each upstream socket reach their own client.
  const std::vector<uint8_t> r2 = Numbered(22);
  ASSERT_TRUE(server.socket.SendTo(b[0].from, r2.data(), r2.size()).ok());
  const auto to_two = two.Receive(1);
  ASSERT_EQ(to_two.size(), 1u);
  EXPECT_EQ(NumberOf(to_two[0].data), 22u);
  EXPECT_TRUE(one.Receive(1, 100).empty());
}

TEST(UdpRelay, BindsTheFrontAndTheUpstreamSocketsWhereAsked) {
  Endpoint server, client;
  RelayOptions o;
  o.upstream = server.socket.local();
  o.bind = "127.0.0.2:0";  // any loopback address but the default
  auto relay = UdpRelay::Start(o);
  ASSERT_TRUE(relay.ok()) << relay.status().ToString();
  EXPECT_EQ((*relay)->front().host(), "127.0.0.2");
  EXPECT_NE((*relay)->front().port(), 0);
  const std::vector<uint8_t> d = Numbered(7);
  ASSERT_TRUE(client.socket.SendTo((*relay)->front(), d.data(), d.size()).ok());
  const auto got = server.Receive(1);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(NumberOf(got[0].data), 7u);
  EXPECT_EQ(got[0].from.host(), "127.0.0.2") << "the upstream socket on the front's host";
  const std::vector<uint8_t> reply = Numbered(8);
  ASSERT_TRUE(server.socket.SendTo(got[0].from, reply.data(), reply.size()).ok());
  const auto back = client.Receive(1);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].from, (*relay)->front());

  RelayOptions bad = o;
  bad.bind = "not an address";
  EXPECT_FALSE(UdpRelay::Start(bad).ok());
}

}  // namespace
}  // namespace meshstream::test_util
