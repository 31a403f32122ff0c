// sdk::LossMemory (sdk/client.h): the loss a client states for its next
// session, from the sessions before.
#include <gtest/gtest.h>

#include "sdk/client.h"

namespace meshstream::sdk {
namespace {

TEST(LossMemory, AddsSessionsWithTheEarlierOnesHalved) {
  LossMemory m;
  EXPECT_EQ(m.Rate(), -1.0) << "nothing before a session";
  m.Add(1, 10);
  EXPECT_EQ(m.Rate(), -1.0) << "11 UDP datagrams say too little";
  m.Add(3, 27);
  EXPECT_DOUBLE_EQ(m.Rate(), 0.1);
  m.Add(0, 30);  // (3 / 2 + 0) / (30 / 2 + 30)
  EXPECT_DOUBLE_EQ(m.Rate(), 1.5 / 45);
  for (int i = 0; i < 40; ++i) m.Add(0, 100);
  EXPECT_LT(m.Rate(), 1e-9) << "a clean link is soon remembered as clean";
  m.Add(100, 0);
  EXPECT_GT(m.Rate(), 0.3) << "and a session that lost everything shows at once";
}

}  // namespace
}  // namespace meshstream::sdk
