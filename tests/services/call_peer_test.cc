// gRPC's peer strings to the numeric host the UDP endpoint compares HELLO
// sources with; anything it cannot read trusts no host.
#include "services/api/call_peer.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

TEST(CallPeer, TheHostOfEveryFormGrpcWrites) {
  EXPECT_EQ(PeerHost("ipv4:127.0.0.1:54321"), "127.0.0.1");
  EXPECT_EQ(PeerHost("ipv6:[::1]:443"), "::1");
  EXPECT_EQ(PeerHost("ipv6:%5B::1%5D:443"), "::1");
  EXPECT_EQ(PeerHost("ipv6:%5B2001:DB8:0:0::1%5D:8443"), "2001:db8::1") << "canonical form";
  EXPECT_EQ(PeerHost("ipv6:%5B::ffff:10.0.0.7%5D:1"), "::ffff:10.0.0.7");
}

TEST(CallPeer, AnythingElseTrustsNoHost) {
  for (const char* peer : {"", "unix:/tmp/socket", "unix-abstract:x", "inproc:", "ipv4:", "ipv4:localhost:80",
                           "ipv4:1.2.3.4", "ipv6:%5B::1:80", "ipv6:%ZZ::1%5D:80", "ipv6:[fe80::1%25eth0]:80",
                           "ipv4:1.2.3.400:80", "dns:///1.2.3.4:80"}) {
    EXPECT_EQ(PeerHost(peer), "") << peer;
  }
}

}  // namespace
}  // namespace meshstream
