// The pacer spaces datagrams at its rate after one burst; the server's share
// hands out slots in order at the shared rate.
#include "net/pacer.h"

#include <gtest/gtest.h>

namespace meshstream {
namespace {

TEST(Pacer, ABurstGoesAtOnceThenTheRateSpacesTheRest) {
  // 8 Mbit/s = 1 byte per microsecond; a burst of 4000 bytes.
  Pacer p(8e6, 4000);
  uint64_t now = 1000000;
  for (int i = 0; i < 4; ++i) {
    EXPECT_EQ(p.DueUs(now, 1000), now) << "datagram " << i << " is in the burst";
    p.OnSent(now, 1000);
  }
  // The bucket is full (4000 bytes ahead): the next 1000 bytes wait 1000 us.
  EXPECT_EQ(p.DueUs(now, 1000), now + 1000);
  // Sent when due, each further one is due 1000 us after the previous.
  uint64_t t = now;
  for (int i = 0; i < 10; ++i) {
    const uint64_t due = p.DueUs(t, 1000);
    EXPECT_EQ(due, now + 1000 * static_cast<uint64_t>(i + 1));
    t = due;
    p.OnSent(t, 1000);
  }
}

TEST(Pacer, AnIdleSpellEarnsOneBurstNotMore) {
  Pacer p(8e6, 3000);
  p.OnSent(0, 1000);
  // A second later the bucket is empty again, never "negative": 3 datagrams
  // of 1000 go at once, the fourth waits.
  const uint64_t later = 1000000;
  for (int i = 0; i < 3; ++i) {
    ASSERT_EQ(p.DueUs(later, 1000), later);
    p.OnSent(later, 1000);
  }
  EXPECT_GT(p.DueUs(later, 1000), later);
}

TEST(Pacer, ARateChangeAppliesToTheNextDatagram) {
  Pacer p(8e6, 1000);
  p.OnSent(0, 1000);
  EXPECT_EQ(p.DueUs(0, 1000), 1000u);
  p.SetRate(16e6);  // twice as fast: the backlog drains in half the time
  EXPECT_EQ(p.DueUs(0, 1000), 500u);
  p.SetRate(1);  // clamped to 1000 bit/s, never zero
  EXPECT_EQ(p.rate_bps(), 1000.0);
}

TEST(RateShare, SessionsShareOneRate) {
  RateShare share(8e6);  // 1 byte/us, burst 64 KiB
  uint64_t last = 0;
  // 200 reservations of 1000 bytes at time 0 from "different sessions":
  // the first 64 KiB at once, then one every 1000 us, in order.
  for (int i = 0; i < 200; ++i) {
    const uint64_t due = share.Reserve(0, 1000);
    EXPECT_GE(due, last);
    last = due;
  }
  // 200 000 bytes at 1 byte/us, less the 64 KiB burst.
  EXPECT_NEAR(static_cast<double>(last), 200000.0 - 65536.0, 1000.0);
}

}  // namespace
}  // namespace meshstream
