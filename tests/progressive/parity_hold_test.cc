// The reconstructor's hold for parity (codec/loss/reconstructor.h,
// parity_hold_us): a refinement the sender said parity follows for
// (ControlBlock.parity_follows, the simulator's ChannelEvent) waits for that
// parity when incomplete, and is decoded once instead of predicted and
// decoded again with every refinement after it; the final mesh is the same.
#include <gtest/gtest.h>

#include "codec/loss/lossy_decode.h"
#include "fec/reed_solomon.h"
#include "tests/common/model_stream.h"

namespace meshstream {
namespace {

TEST(ParityHold, DecodesOnceWhatParityRebuildsAndEndsTheSame) {
  QuantizationParams q;
  auto m = test_util::EncodeModelStream("stanford-bunny.obj", q, Packing::kSplit);
  ASSERT_TRUE(m.ok()) << m.status().ToString();
  uint64_t held = 0, again_with_hold = 0, again_without = 0, recovered = 0;
  for (uint64_t seed = 1; seed <= 4; ++seed) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    LossyDecodeOptions o;
    o.loss.loss = 0.12;
    o.loss.seed = seed;
    o.parity.code = &fec::DefaultErasureCode();
    o.parity.loss = 0.12;
    LossyDecodeReport with_hold, without_hold;
    auto a = DecodeStreamLossy(m->stream, 0, m->base, o, &with_hold);
    o.reconstructor.parity_hold_us = 0;
    auto b = DecodeStreamLossy(m->stream, 0, m->base, o, &without_hold);
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(with_hold.reconstructor.recovered, without_hold.reconstructor.recovered);
    EXPECT_TRUE(a->Mesh().positions == b->Mesh().positions) << "the hold changes when, not what";
    EXPECT_EQ(a->inexact_positions(), b->inexact_positions());
    held += with_hold.reconstructor.held_for_parity;
    again_with_hold += with_hold.reconstructor.redecoded;
    again_without += without_hold.reconstructor.redecoded;
    recovered += with_hold.reconstructor.recovered;
    EXPECT_EQ(without_hold.reconstructor.held_for_parity, 0u);
  }
  EXPECT_GT(recovered, 0u);
  EXPECT_GT(held, 0u);
  EXPECT_GT(again_without, 0u) << "without the hold, parity after a prediction decodes again";
  EXPECT_LT(again_with_hold * 4, again_without) << "the hold removes most of those decodes";
}

}  // namespace
}  // namespace meshstream
