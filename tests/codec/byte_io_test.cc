// ByteWriter / ByteReader (codec/core/byte_io.h): round trips of every width
// and of varints at their boundaries, the little-endian layout against literal
// bytes, and the untrusted-input contract (no read past the span, malformed
// or too-large varints refused, errors naming `what`).
#include "codec/core/byte_io.h"

#include <cmath>
#include <limits>

#include <gtest/gtest.h>

namespace meshstream {
namespace {

using Bytes = std::vector<uint8_t>;

TEST(ByteIo, FixedWidthsAreLittleEndian) {
  ByteWriter w;
  w.U8(0xA5);
  w.U16(0x1234);
  w.U32(0xDEADBEEF);
  w.F32(1.0f);  // 0x3F800000
  EXPECT_EQ(w.bytes(), (Bytes{0xA5, 0x34, 0x12, 0xEF, 0xBE, 0xAD, 0xDE, 0x00, 0x00, 0x80, 0x3F}));
  EXPECT_EQ(w.size(), 11u);

  ByteReader r(w.bytes().data(), w.size());
  EXPECT_EQ(r.U8("a").value(), 0xA5);
  EXPECT_EQ(r.U16("b").value(), 0x1234);
  EXPECT_EQ(r.U32("c").value(), 0xDEADBEEFu);
  EXPECT_EQ(r.F32("d").value(), 1.0f);
  EXPECT_EQ(r.remaining(), 0u);
  EXPECT_EQ(r.position(), 11u);
}

TEST(ByteIo, FixedWidthsRoundTripAtTheirBoundaries) {
  const uint16_t u16[] = {0, 1, 0x7F, 0x80, 0xFF, 0x100, 0x7FFF, 0x8000, 0xFFFF};
  const uint32_t u32[] = {0, 1, 0xFF, 0x100, 0xFFFF, 0x10000, 0x7FFFFFFF, 0x80000000u, 0xFFFFFFFFu};
  const float f32[] = {0.0f, -0.0f, 1.5f, -3.25e-7f, std::numeric_limits<float>::max(),
                       std::numeric_limits<float>::denorm_min(), std::numeric_limits<float>::infinity()};
  ByteWriter w;
  for (int v = 0; v < 256; ++v) w.U8(static_cast<uint8_t>(v));
  for (uint16_t v : u16) w.U16(v);
  for (uint32_t v : u32) w.U32(v);
  for (float v : f32) w.F32(v);
  w.F32(std::numeric_limits<float>::quiet_NaN());
  ByteReader r(w.bytes().data(), w.size());
  for (int v = 0; v < 256; ++v) EXPECT_EQ(r.U8("u8").value(), v);
  for (uint16_t v : u16) EXPECT_EQ(r.U16("u16").value(), v);
  for (uint32_t v : u32) EXPECT_EQ(r.U32("u32").value(), v);
  for (float v : f32) {
    const float got = r.F32("f32").value();
    EXPECT_EQ(got, v);
    EXPECT_EQ(std::signbit(got), std::signbit(v));
  }
  EXPECT_TRUE(std::isnan(r.F32("nan").value()));
  EXPECT_EQ(r.remaining(), 0u);
}

TEST(ByteIo, VarintLayoutIsLeb128) {
  struct Case {
    uint64_t value;
    Bytes bytes;
  };
  const Case cases[] = {
      {0, {0x00}},
      {1, {0x01}},
      {127, {0x7F}},
      {128, {0x80, 0x01}},
      {300, {0xAC, 0x02}},
      {16383, {0xFF, 0x7F}},
      {16384, {0x80, 0x80, 0x01}},
      {0xFFFFFFFFull, {0xFF, 0xFF, 0xFF, 0xFF, 0x0F}},
      {0x100000000ull, {0x80, 0x80, 0x80, 0x80, 0x10}},
      {UINT64_MAX, {0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0x01}},
  };
  for (const Case& c : cases) {
    ByteWriter w;
    w.Varint(c.value);
    EXPECT_EQ(w.bytes(), c.bytes) << c.value;
    ByteReader r(c.bytes.data(), c.bytes.size());
    auto v = r.Varint("v", UINT64_MAX);
    ASSERT_TRUE(v.ok()) << c.value << ": " << v.status().ToString();
    EXPECT_EQ(v.value(), c.value);
    EXPECT_EQ(r.remaining(), 0u) << c.value;
  }
}

TEST(ByteIo, VarintRoundTripsAroundEverySevenBitBoundary) {
  std::vector<uint64_t> values = {0, UINT64_MAX, UINT64_MAX - 1};
  for (int shift = 7; shift < 64; shift += 7) {
    const uint64_t p = uint64_t{1} << shift;
    values.insert(values.end(), {p - 1, p, p + 1});
  }
  for (int shift = 1; shift < 64; ++shift) values.push_back((uint64_t{1} << shift) - 1);
  ByteWriter w;
  for (uint64_t v : values) w.Varint(v);
  ByteReader r(w.bytes().data(), w.size());
  for (uint64_t v : values) EXPECT_EQ(r.Varint("v", UINT64_MAX).value(), v);
  EXPECT_EQ(r.remaining(), 0u);
}

TEST(ByteIo, VarintAtTheLimitIsAcceptedAboveIsRefused) {
  for (uint64_t max : {uint64_t{0}, uint64_t{127}, uint64_t{128}, uint64_t{0xFFFFFFFF}}) {
    ByteWriter w;
    w.Varint(max);
    w.Varint(max + 1);
    ByteReader r(w.bytes().data(), w.size());
    auto at = r.Varint("count", max);
    ASSERT_TRUE(at.ok()) << at.status().ToString();
    EXPECT_EQ(at.value(), max);
    auto above = r.Varint("count", max);
    ASSERT_FALSE(above.ok());
    EXPECT_EQ(above.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(above.status().message().find("count"), std::string::npos) << above.status().message();
    EXPECT_NE(above.status().message().find(std::to_string(max + 1)), std::string::npos) << above.status().message();
  }
}

TEST(ByteIo, VarintLongerThanTenBytesIsMalformed) {
  // Ten continuation bytes: the value would need more than 64 bits.
  Bytes b(10, 0x80);
  b.push_back(0x00);
  ByteReader r(b.data(), b.size());
  auto v = r.Varint("split count", UINT64_MAX);
  ASSERT_FALSE(v.ok());
  EXPECT_EQ(v.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(v.status().message().find("split count"), std::string::npos);
  EXPECT_NE(v.status().message().find("malformed"), std::string::npos) << v.status().message();
  // It stopped within the ten bytes a 64-bit value may take.
  EXPECT_LE(r.position(), 10u);
}

TEST(ByteIo, VarintAboveSixtyFourBitsIsRefusedNotWrapped) {
  // Ten bytes whose last one carries bits beyond bit 63: the value is at
  // least 2^64 and must not wrap to a small one that passes the limit
  // (here 2^64 would wrap to 0).
  Bytes b(9, 0x80);
  b.push_back(0x02);
  ByteReader r(b.data(), b.size());
  auto v = r.Varint("refinement count", 255);
  ASSERT_FALSE(v.ok()) << "decoded " << v.value();
  EXPECT_EQ(v.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(v.status().message().find("refinement count"), std::string::npos);
  // The largest ten-byte value, 2^64 - 1, ends in 0x01 and is fine.
  Bytes max(9, 0xFF);
  max.push_back(0x01);
  ByteReader m(max.data(), max.size());
  EXPECT_EQ(m.Varint("max", UINT64_MAX).value(), UINT64_MAX);
}

TEST(ByteIo, ReadingPastTheEndFailsAndNamesWhat) {
  const Bytes b = {0x01, 0x02, 0x03};
  {
    ByteReader r(b.data(), b.size());
    auto v = r.U32("grid origin");
    ASSERT_FALSE(v.ok());
    EXPECT_EQ(v.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(v.status().message().find("grid origin"), std::string::npos) << v.status().message();
    EXPECT_NE(v.status().message().find("truncated"), std::string::npos) << v.status().message();
    EXPECT_EQ(r.position(), 0u);  // nothing consumed
    EXPECT_EQ(r.U16("x").value(), 0x0201);
    EXPECT_FALSE(r.U16("x").ok());
    EXPECT_EQ(r.U8("x").value(), 0x03);
    EXPECT_FALSE(r.U8("last").ok());
    EXPECT_FALSE(r.F32("f").ok());
    EXPECT_FALSE(r.Varint("v", UINT64_MAX).ok());
    EXPECT_EQ(r.remaining(), 0u);
  }
  {
    ByteReader r(nullptr, 0);
    EXPECT_FALSE(r.U8("empty").ok());
    EXPECT_FALSE(r.Take(1, "empty").ok());
    EXPECT_TRUE(r.Take(0, "empty").ok());
  }
  {
    // A varint whose continuation bit promises a byte that is not there.
    const Bytes cut = {0x80, 0x80};
    ByteReader r(cut.data(), cut.size());
    auto v = r.Varint("base vertex count", UINT64_MAX);
    ASSERT_FALSE(v.ok());
    EXPECT_NE(v.status().message().find("base vertex count"), std::string::npos);
    EXPECT_NE(v.status().message().find("truncated"), std::string::npos) << v.status().message();
  }
}

TEST(ByteIo, BlocksRoundTripAndPointIntoTheSpan) {
  const Bytes payload = {9, 8, 7, 6, 5};
  ByteWriter w;
  w.Block(payload);
  w.Block({});
  w.Block(Bytes(200, 0x42));  // a two-byte length
  EXPECT_EQ(w.bytes()[0], 5);
  ByteReader r(w.bytes().data(), w.size());
  size_t n = 99;
  auto p = r.Block("first", &n);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(n, 5u);
  EXPECT_EQ(p.value(), w.bytes().data() + 1);
  EXPECT_EQ(Bytes(p.value(), p.value() + n), payload);
  p = r.Block("empty", &n);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(n, 0u);
  p = r.Block("long", &n);
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(Bytes(p.value(), p.value() + n), Bytes(200, 0x42));
  EXPECT_EQ(r.remaining(), 0u);
}

TEST(ByteIo, BlockLongerThanTheRestIsRefused) {
  // Every cut of a block, and a length that exceeds the rest by one byte
  // (the varint's own byte would still have fitted in the limit).
  ByteWriter w;
  w.Block(Bytes(20, 1));
  const Bytes full = w.bytes();
  for (size_t cut = 0; cut < full.size(); ++cut) {
    ByteReader r(full.data(), cut);
    size_t n = 0;
    auto p = r.Block("fix-ups", &n);
    ASSERT_FALSE(p.ok()) << cut;
    EXPECT_NE(p.status().message().find("fix-ups"), std::string::npos) << p.status().message();
  }
  const Bytes lie = {3, 1, 2};  // three promised, two present
  ByteReader r(lie.data(), lie.size());
  size_t n = 0;
  EXPECT_FALSE(r.Block("lie", &n).ok());
}

TEST(ByteIo, TakeReturnsTheBytesAndRefusesTooMany) {
  const Bytes b = {1, 2, 3, 4};
  ByteReader r(b.data(), b.size());
  auto p = r.Take(3, "payload");
  ASSERT_TRUE(p.ok());
  EXPECT_EQ(p.value(), b.data());
  auto q = r.Take(2, "payload tail");
  ASSERT_FALSE(q.ok());
  EXPECT_NE(q.status().message().find("payload tail"), std::string::npos);
  EXPECT_EQ(r.remaining(), 1u);
  EXPECT_FALSE(r.Take(SIZE_MAX, "huge").ok());
}

}  // namespace
}  // namespace meshstream
