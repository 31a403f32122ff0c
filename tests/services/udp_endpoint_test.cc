// The server's UDP endpoint with real sockets on loopback: a client proves
// its address by the HELLO / HELLO_ACK round trip and only then gets DATA;
// garbage, forged, replayed, oversized and unknown-session datagrams are
// dropped and counted without a reply; an address that copies a genuine
// HELLO gets at most a HELLO_ACK (never more bytes than it sent, never DATA)
// and cannot redirect the session.
#include "services/streaming/udp_endpoint.h"

#include <gtest/gtest.h>

#include <atomic>
#include <memory>
#include <utility>
#include <chrono>
#include <thread>
#include <vector>

#include "net/hello.h"
#include "net/packet_crypto.h"

namespace meshstream {
namespace {

struct Peer {
  UdpSocket socket;
  uint64_t next_pn = 0;
  static Peer Make() {
    Peer p;
    p.socket = std::move(UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"))).value();
    return p;
  }
  std::vector<uint8_t> Hello(const UdpEndpoint::Session& s, const Challenge& echo, const PacketKey* key = nullptr) {
    const std::vector<uint8_t> payload = HelloPayload(echo);
    return SealPacket(PacketType::kHello, s.id(), next_pn++, key ? *key : s.keys().client_to_server, payload.data(),
                      payload.size())
        .value();
  }
  void Send(const UdpEndpoint& e, const std::vector<uint8_t>& bytes) {
    ASSERT_TRUE(socket.SendTo(e.local(), bytes.data(), bytes.size()).ok());
  }
  // Everything that arrives within `ms`; with `want`, first until `want`
  // arrived (a 10 s deadline that only bounds an answer that never comes),
  // then `ms` more for any extra one, so the count is the endpoint's and
  // not the scheduler's.
  std::vector<std::vector<uint8_t>> Drain(int ms, size_t want = 0) {
    std::vector<std::vector<uint8_t>> out;
    std::vector<IncomingDatagram> in(16);
    auto receive = [&](std::chrono::steady_clock::time_point until) {
      while (std::chrono::steady_clock::now() < until) {
        auto n = socket.ReceiveBatch(&in, 2000, 10);
        if (!n.ok()) break;
        for (size_t i = 0; i < n.value(); ++i) out.push_back(in[i].data);
        if (want > 0 && out.size() >= want) break;
      }
    };
    if (want > 0) receive(std::chrono::steady_clock::now() + std::chrono::seconds(10));
    want = 0;
    receive(std::chrono::steady_clock::now() + std::chrono::milliseconds(ms));
    return out;
  }
};

Challenge ChallengeOf(const std::vector<uint8_t>& ack, const UdpEndpoint::Session& s) {
  OpenedPacket opened;
  EXPECT_EQ(OpenPacket(ack.data(), ack.size(), Direction::kServerToClient, s.keys().server_to_client, &opened),
            DropReason::kNone);
  EXPECT_EQ(opened.header.type, PacketType::kHelloAck);
  return ParseHelloAckPayload(opened.payload).value();
}

// Waits until the session has a proven address (true) or `ms` ran out.
bool WaitProven(const UdpEndpoint::Session& s, int ms) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(ms);
  while (!s.proven()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return true;
}

// Waits until the endpoint has looked at `count` datagrams (a 10 s deadline
// that only bounds an endpoint that never looks; then the test fails here).
void WaitCounted(const UdpEndpoint& e, uint64_t count) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (std::chrono::steady_clock::now() < until) {
    const UdpEndpointStats s = e.stats();
    if (s.received.accepted() + s.received.dropped() >= count) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  ADD_FAILURE() << "the endpoint never looked at " << count << " datagrams";
}

TEST(UdpEndpoint, TheRoundTripProvesTheAddressThenDataFlows) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok()) << endpoint.status().ToString();
  auto session = (*endpoint)->RegisterSession();
  ASSERT_TRUE(session.ok());
  UdpEndpoint::Session& s = **session;
  EXPECT_EQ((*endpoint)->session_count(), 1u);
  const uint8_t data[] = {1, 2, 3};
  const std::vector<DatagramPayload> one = {{data, 3}};
  EXPECT_EQ(s.SendData(one, 0).code(), StatusCode::kFailedPrecondition) << "no DATA before a proof";

  Peer client = Peer::Make();
  client.Send(**endpoint, client.Hello(s, Challenge{}));
  auto replies = client.Drain(300, 1);
  ASSERT_EQ(replies.size(), 1u);
  EXPECT_EQ(replies[0].size(), kHelloAckDatagramBytes);
  EXPECT_FALSE(s.proven()) << "a HELLO alone proves nothing";
  const Challenge challenge = ChallengeOf(replies[0], s);
  client.Send(**endpoint, client.Hello(s, challenge));
  ASSERT_TRUE(WaitProven(s, 10000));
  EXPECT_EQ(s.address(), client.socket.local());

  const uint64_t first = s.ReservePacketNumbers(2);
  const uint8_t more[] = {4, 5};
  const std::vector<DatagramPayload> two = {{data, 3}, {more, 2}};
  ASSERT_TRUE(s.SendData(two, first).ok());
  auto got = client.Drain(300, 2);
  ASSERT_EQ(got.size(), 2u);
  OpenedPacket p;
  ASSERT_EQ(OpenPacket(got[0].data(), got[0].size(), Direction::kServerToClient, s.keys().server_to_client, &p),
            DropReason::kNone);
  EXPECT_EQ(p.header.type, PacketType::kData);
  EXPECT_EQ(p.header.packet_number, first);
  EXPECT_EQ(p.payload, std::vector<uint8_t>(data, data + 3));
  EXPECT_EQ((*endpoint)->stats().data_sent, 2u);
  session->reset();
  EXPECT_EQ((*endpoint)->session_count(), 0u) << "a session leaves the table with its handle";
}

// A proven session of `endpoint` and its client.
std::pair<std::shared_ptr<UdpEndpoint::Session>, Peer> Proven(UdpEndpoint& endpoint) {
  auto session = endpoint.RegisterSession();
  EXPECT_TRUE(session.ok());
  Peer client = Peer::Make();
  client.Send(endpoint, client.Hello(**session, Challenge{}));
  auto replies = client.Drain(200, 1);
  EXPECT_EQ(replies.size(), 1u);
  if (replies.size() == 1) client.Send(endpoint, client.Hello(**session, ChallengeOf(replies[0], **session)));
  EXPECT_TRUE(WaitProven(**session, 10000));
  return {std::move(session).value(), std::move(client)};
}

TEST(UdpEndpoint, DatagramsOfSeveralSessionsLeaveInOneSendmmsg) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok()) << endpoint.status().ToString();
  auto [a, client_a] = Proven(**endpoint);
  auto [b, client_b] = Proven(**endpoint);
  const uint64_t calls = (*endpoint)->stats().send_calls;
  const std::vector<uint8_t> payload(1000, 0x33);
  const std::vector<DatagramPayload> three(3, {payload.data(), payload.size()});
  DatagramOutbox outbox;
  ASSERT_TRUE(a->SealData(three, a->ReservePacketNumbers(3), &outbox).ok());
  ASSERT_TRUE(b->SealData(three, b->ReservePacketNumbers(3), &outbox).ok());
  EXPECT_EQ(outbox.pending(), 6u);
  EXPECT_EQ(outbox.Flush(), 0u);
  EXPECT_EQ((*endpoint)->stats().send_calls, calls + 1) << "one system call for both sessions";
  EXPECT_EQ((*endpoint)->stats().data_sent, 6u);
  for (auto* c : {&client_a, &client_b}) {
    const auto got = c->Drain(200, 3);
    ASSERT_EQ(got.size(), 3u);
    const UdpEndpoint::Session& s = c == &client_a ? *a : *b;
    for (const auto& d : got) {
      OpenedPacket p;
      EXPECT_EQ(OpenPacket(d.data(), d.size(), Direction::kServerToClient, s.keys().server_to_client, &p),
                DropReason::kNone) << "each sealed under its own session's key";
    }
  }
  // The outbox's buffers are reused: the next batch seals into them again.
  ASSERT_TRUE(a->SealData(three, a->ReservePacketNumbers(3), &outbox).ok());
  EXPECT_EQ(outbox.Flush(), 0u);
  EXPECT_EQ(client_a.Drain(200, 3).size(), 3u);
}

TEST(UdpEndpoint, HostileDatagramsAreDroppedCountedAndNeverAnswered) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok());
  auto session = (*endpoint)->RegisterSession();
  ASSERT_TRUE(session.ok());
  UdpEndpoint::Session& s = **session;
  Peer attacker = Peer::Make();
  const std::vector<uint8_t> garbage(100, 0x41);
  attacker.Send(**endpoint, garbage);                                    // bad magic
  attacker.Send(**endpoint, std::vector<uint8_t>(10, 0xD3));             // too short
  attacker.Send(**endpoint, std::vector<uint8_t>(1473, 0));              // too long
  PacketKey wrong{};
  wrong[0] = 1;
  attacker.Send(**endpoint, attacker.Hello(s, Challenge{}, &wrong));      // forged: auth fails
  std::vector<uint8_t> unknown = attacker.Hello(s, Challenge{});
  unknown[4] ^= 0xFF;                                                    // another session id
  attacker.Send(**endpoint, unknown);
  std::vector<uint8_t> flipped = attacker.Hello(s, Challenge{});
  flipped[30] ^= 1;                                                      // a payload bit
  attacker.Send(**endpoint, flipped);
  // A server->client type sent to the server (reflection of its own DATA).
  const uint8_t payload[] = {9};
  attacker.Send(**endpoint, SealPacket(PacketType::kData, s.id(), 0, s.keys().server_to_client, payload, 1).value());
  WaitCounted(**endpoint, 7);
  EXPECT_TRUE(attacker.Drain(200).empty()) << "nothing is answered";
  const UdpEndpointStats st = (*endpoint)->stats();
  EXPECT_EQ(st.received.Get(DropReason::kBadMagic), 1u);
  EXPECT_EQ(st.received.Get(DropReason::kTooShort), 1u);
  EXPECT_EQ(st.received.Get(DropReason::kTooLong), 1u);
  EXPECT_EQ(st.received.Get(DropReason::kAuthFailed), 2u);
  EXPECT_EQ(st.received.Get(DropReason::kUnknownSession), 1u);
  EXPECT_EQ(st.received.Get(DropReason::kBadType), 1u);
  EXPECT_EQ(st.received.accepted(), 0u);
  EXPECT_EQ(st.hello_acks_sent, 0u);
  EXPECT_FALSE(s.proven());
}

TEST(UdpEndpoint, ACopiedHelloEarnsAtMostAnAckAndCannotRedirect) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok());
  auto session = (*endpoint)->RegisterSession();
  ASSERT_TRUE(session.ok());
  UdpEndpoint::Session& s = **session;
  Peer client = Peer::Make();
  Peer attacker = Peer::Make();
  // The genuine client proves its address.
  client.Send(**endpoint, client.Hello(s, Challenge{}));
  auto acks = client.Drain(300, 1);
  ASSERT_EQ(acks.size(), 1u);
  client.Send(**endpoint, client.Hello(s, ChallengeOf(acks[0], s)));
  ASSERT_TRUE(WaitProven(s, 10000));
  // An on-path attacker copies a genuine HELLO (fresh packet number, as if
  // it had captured one in flight) and sends it from its own address.
  const std::vector<uint8_t> captured = client.Hello(s, Challenge{});
  attacker.Send(**endpoint, captured);
  attacker.Send(**endpoint, captured);  // and again: replayed
  WaitCounted(**endpoint, 4);
  const auto to_attacker = attacker.Drain(300);
  size_t bytes = 0;
  for (const auto& d : to_attacker) {
    bytes += d.size();
    ASSERT_GE(d.size(), 3u);
    EXPECT_NE(d[2], static_cast<uint8_t>(PacketType::kData)) << "never DATA to an unproven address";
  }
  EXPECT_LE(bytes, 2 * captured.size()) << "no amplification";
  EXPECT_LE(to_attacker.size(), 1u);
  EXPECT_EQ((*endpoint)->stats().received.Get(DropReason::kReplayed), 1u);
  // The session's DATA still goes to the proven client.
  EXPECT_EQ(s.address(), client.socket.local());
  const uint8_t d[] = {7};
  const std::vector<DatagramPayload> one = {{d, 1}};
  ASSERT_TRUE(s.SendData(one, s.ReservePacketNumbers(1)).ok());
  EXPECT_EQ(client.Drain(200, 1).size(), 1u);
  EXPECT_TRUE(attacker.Drain(100).empty());
}

TEST(UdpEndpoint, ASessionTakesAtMostFourAddresses) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok());
  auto session = (*endpoint)->RegisterSession();
  ASSERT_TRUE(session.ok());
  std::vector<Peer> peers;
  for (size_t i = 0; i < UdpEndpoint::kMaxAddressesPerSession + 2; ++i) peers.push_back(Peer::Make());
  uint64_t pn = 0;
  for (Peer& p : peers) {
    p.next_pn = pn++;
    p.Send(**endpoint, p.Hello(**session, Challenge{}));
  }
  WaitCounted(**endpoint, peers.size());
  const UdpEndpointStats st = (*endpoint)->stats();
  EXPECT_EQ(st.hello_acks_sent, UdpEndpoint::kMaxAddressesPerSession);
  EXPECT_EQ(st.addresses_refused, 2u);
}

}  // namespace
}  // namespace meshstream

namespace meshstream {
namespace {

// SetOnHello wakes a waiting session (the send loop's): once for an
// authenticated HELLO, again when its echo proves the address; a forged
// HELLO wakes nobody, and a hook that was replaced is never called again.
TEST(UdpEndpoint, TheHelloHookFiresForAuthenticatedHellosAndTheProof) {
  auto endpoint = UdpEndpoint::Start(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(endpoint.ok()) << endpoint.status().ToString();
  auto session = (*endpoint)->RegisterSession();
  ASSERT_TRUE(session.ok());
  UdpEndpoint::Session& s = **session;
  std::atomic<int> calls{0};
  s.SetOnHello([&calls] { ++calls; });
  Peer client = Peer::Make();
  PacketKey wrong{};
  client.Send(**endpoint, client.Hello(s, Challenge{}, &wrong));
  WaitCounted(**endpoint, 1);
  EXPECT_EQ(calls.load(), 0) << "a forged HELLO wakes nobody";
  client.Send(**endpoint, client.Hello(s, Challenge{}));
  const std::vector<std::vector<uint8_t>> acks = client.Drain(300, 1);
  ASSERT_EQ(acks.size(), 1u);
  EXPECT_EQ(calls.load(), 1) << "the authenticated HELLO";
  client.Send(**endpoint, client.Hello(s, ChallengeOf(acks[0], s)));
  ASSERT_TRUE(WaitProven(s, 10000));
  EXPECT_EQ(calls.load(), 3) << "the echo: heard, then proven";
  s.SetOnHello(nullptr);
  client.Send(**endpoint, client.Hello(s, Challenge{}));
  WaitCounted(**endpoint, 4);
  EXPECT_EQ(calls.load(), 3) << "a replaced hook is not called";
}

}  // namespace
}  // namespace meshstream
