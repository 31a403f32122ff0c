// Real UDP sockets on loopback: addresses parse and print, a batch goes out
// with one sendmmsg and comes in with recvmmsg, a datagram longer than the
// buffer is reported truncated, and a receive times out.
#include "net/udp_socket.h"

#include <gtest/gtest.h>

#include <vector>

namespace meshstream {
namespace {

TEST(SocketAddress, ParsesAndPrints) {
  auto v4 = SocketAddress::Parse("127.0.0.1:7600");
  ASSERT_TRUE(v4.ok()) << v4.status().ToString();
  EXPECT_EQ(v4->ToString(), "127.0.0.1:7600");
  EXPECT_EQ(v4->port(), 7600);
  EXPECT_FALSE(v4->IsUnspecified());
  auto v6 = SocketAddress::Parse("[::1]:9");
  ASSERT_TRUE(v6.ok());
  EXPECT_EQ(v6->ToString(), "[::1]:9");
  auto any = SocketAddress::Parse("0.0.0.0:0");
  ASSERT_TRUE(any.ok());
  EXPECT_TRUE(any->IsUnspecified());
  EXPECT_EQ(*v4, *SocketAddress::Parse("127.0.0.1:7600"));
  EXPECT_NE(*v4, *SocketAddress::Parse("127.0.0.1:7601"));
  EXPECT_EQ(v4->Hash(), SocketAddress::Parse("127.0.0.1:7600")->Hash());
  for (const char* bad : {"", "host", "1.2.3.4:", ":80", "1.2.3.4:99999", "[::1:80", "::1:80", "a:b"}) {
    EXPECT_FALSE(SocketAddress::Parse(bad).ok()) << bad;
  }
}

TEST(UdpSocket, ABatchGoesOutAndComesIn) {
  auto a = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  auto b = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_NE(b->local().port(), 0);
  std::vector<std::vector<uint8_t>> payloads;
  std::vector<OutgoingDatagram> batch;
  const SocketAddress to = b->local();
  for (int i = 0; i < 100; ++i) payloads.push_back(std::vector<uint8_t>(static_cast<size_t>(10 + i), static_cast<uint8_t>(i)));
  for (const auto& p : payloads) batch.push_back({&to, p.data(), p.size()});
  auto sent = a->SendBatch(batch.data(), batch.size());
  ASSERT_TRUE(sent.ok());
  EXPECT_EQ(sent.value(), 100u);
  std::vector<IncomingDatagram> in(32);
  std::vector<std::vector<uint8_t>> got;
  while (got.size() < 100) {
    auto n = b->ReceiveBatch(&in, 1500, 1000);
    ASSERT_TRUE(n.ok());
    ASSERT_GT(n.value(), 0u) << "timed out after " << got.size();
    for (size_t i = 0; i < n.value(); ++i) {
      EXPECT_EQ(in[i].from, a->local());
      EXPECT_FALSE(in[i].truncated);
      got.push_back(in[i].data);
    }
  }
  EXPECT_EQ(got, payloads) << "loopback keeps order and bytes";
}

TEST(UdpSocket, ALongDatagramIsTruncatedAndSaysSo) {
  auto a = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  auto b = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(a.ok() && b.ok());
  const std::vector<uint8_t> big(3000, 7);
  ASSERT_TRUE(a->SendTo(b->local(), big.data(), big.size()).ok());
  std::vector<IncomingDatagram> in(1);
  auto n = b->ReceiveBatch(&in, 1473, 1000);
  ASSERT_TRUE(n.ok());
  ASSERT_EQ(n.value(), 1u);
  EXPECT_TRUE(in[0].truncated);
  EXPECT_EQ(in[0].data.size(), 1473u);
}

TEST(UdpSocket, AReceiveTimesOutAndTheFamilyIsChecked) {
  auto a = UdpSocket::Bind(*SocketAddress::Parse("127.0.0.1:0"));
  ASSERT_TRUE(a.ok());
  std::vector<IncomingDatagram> in(4);
  auto n = a->ReceiveBatch(&in, 1500, 20);
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(n.value(), 0u);
  const SocketAddress v6 = *SocketAddress::Parse("[::1]:9");
  const uint8_t byte = 1;
  EXPECT_EQ(a->SendTo(v6, &byte, 1).code(), StatusCode::kInvalidArgument);
  EXPECT_FALSE(UdpSocket::Bind(SocketAddress()).ok());
}

}  // namespace
}  // namespace meshstream
