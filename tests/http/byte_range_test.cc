// The Range header parser (services/http/byte_range.h): every form a client
// may send against bodies of several sizes, including the empty one.
#include "services/http/byte_range.h"

#include <gtest/gtest.h>

#include <string>

namespace meshstream {
namespace {

using Kind = HttpRange::Kind;

void ExpectPartial(const std::string& header, uint64_t size, uint64_t first, uint64_t last) {
  const HttpRange r = ParseByteRange(header, size);
  EXPECT_EQ(r.kind, Kind::kPartial) << "'" << header << "' of " << size;
  EXPECT_EQ(r.first, first) << "'" << header << "' of " << size;
  EXPECT_EQ(r.last, last) << "'" << header << "' of " << size;
  EXPECT_EQ(r.length(), last - first + 1);
}

void ExpectKind(const std::string& header, uint64_t size, Kind kind) {
  EXPECT_EQ(ParseByteRange(header, size).kind, kind) << "'" << header << "' of " << size;
}

TEST(HttpRange, ClosedRanges) {
  ExpectPartial("bytes=0-0", 100, 0, 0);
  ExpectPartial("bytes=0-99", 100, 0, 99);
  ExpectPartial("bytes=10-19", 100, 10, 19);
  ExpectPartial("bytes=99-99", 100, 99, 99);
}

TEST(HttpRange, LastBeyondTheEndIsCut) {
  ExpectPartial("bytes=10-1000", 100, 10, 99);
  ExpectPartial("bytes=0-100", 100, 0, 99);
}

TEST(HttpRange, OpenEnded) {
  ExpectPartial("bytes=0-", 100, 0, 99);
  ExpectPartial("bytes=42-", 100, 42, 99);
  ExpectPartial("bytes=99-", 100, 99, 99);
}

TEST(HttpRange, Suffix) {
  ExpectPartial("bytes=-1", 100, 99, 99);
  ExpectPartial("bytes=-10", 100, 90, 99);
  ExpectPartial("bytes=-100", 100, 0, 99);
  // A suffix longer than the body is the whole body, as 206.
  ExpectPartial("bytes=-1000", 100, 0, 99);
}

TEST(HttpRange, Unsatisfiable) {
  ExpectKind("bytes=100-", 100, Kind::kUnsatisfiable);
  ExpectKind("bytes=100-200", 100, Kind::kUnsatisfiable);
  ExpectKind("bytes=5000-", 100, Kind::kUnsatisfiable);
  ExpectKind("bytes=-0", 100, Kind::kUnsatisfiable);
}

TEST(HttpRange, EmptyBody) {
  ExpectKind("bytes=0-", 0, Kind::kUnsatisfiable);
  ExpectKind("bytes=0-0", 0, Kind::kUnsatisfiable);
  ExpectKind("bytes=-0", 0, Kind::kUnsatisfiable);
  // No byte range can name the empty body: it is sent whole.
  ExpectKind("bytes=-5", 0, Kind::kWhole);
}

TEST(HttpRange, LastBeforeFirstIsIgnored) {
  ExpectKind("bytes=20-10", 100, Kind::kWhole);
  ExpectKind("bytes=200-100", 100, Kind::kWhole);
}

TEST(HttpRange, SeveralRangesAreServedWhole) {
  ExpectKind("bytes=0-1,5-6", 100, Kind::kWhole);
  ExpectKind("bytes=0-1, 5-6", 100, Kind::kWhole);
  ExpectKind("bytes=-1,0-0", 100, Kind::kWhole);
  // Even when one of them is malformed or unsatisfiable.
  ExpectKind("bytes=0-1,x", 100, Kind::kWhole);
  ExpectKind("bytes=500-,600-", 100, Kind::kWhole);
}

TEST(HttpRange, EmptyListElementsAreSkipped) {
  ExpectPartial("bytes=0-9,", 100, 0, 9);
  ExpectPartial("bytes=, 0-9 ,,", 100, 0, 9);
  ExpectKind("bytes=,", 100, Kind::kWhole);
  ExpectKind("bytes=", 100, Kind::kWhole);
}

TEST(HttpRange, Whitespace) {
  ExpectPartial("  bytes=0-9  ", 100, 0, 9);
  ExpectPartial("bytes= 0-9", 100, 0, 9);
  ExpectPartial("bytes=\t0-9\t", 100, 0, 9);
  // Inside a spec, or around '=', whitespace is not allowed.
  ExpectKind("bytes=0 -9", 100, Kind::kWhole);
  ExpectKind("bytes=0- 9", 100, Kind::kWhole);
  ExpectKind("bytes =0-9", 100, Kind::kWhole);
  ExpectKind("bytes=- 5", 100, Kind::kWhole);
}

TEST(HttpRange, Units) {
  ExpectPartial("Bytes=0-9", 100, 0, 9);
  ExpectPartial("BYTES=0-9", 100, 0, 9);
  ExpectKind("items=0-9", 100, Kind::kWhole);
  ExpectKind("byte=0-9", 100, Kind::kWhole);
  ExpectKind("bytes0-9", 100, Kind::kWhole);
  ExpectKind("=0-9", 100, Kind::kWhole);
}

TEST(HttpRange, Malformed) {
  for (const char* header : {"", "bytes", "bytes=-", "bytes=abc", "bytes=1", "bytes=+1-2", "bytes=1-+2",
                             "bytes=-+5", "bytes=-5-", "bytes=1-2-3", "bytes=0x10-20", "bytes=1.5-2",
                             "bytes=\xff-1"}) {
    ExpectKind(header, 100, Kind::kWhole);
  }
  ExpectKind(std::string("bytes=1-2\0", 10), 100, Kind::kWhole);
  ExpectKind(std::string("bytes=\0-2", 9), 100, Kind::kWhole);
}

TEST(HttpRange, OverflowingDigitsSaturate) {
  const std::string huge = "99999999999999999999999999999999999999";  // far above 2^64
  ExpectKind("bytes=" + huge + "-", 100, Kind::kUnsatisfiable);
  ExpectKind("bytes=" + huge + "-" + huge, 100, Kind::kUnsatisfiable);
  ExpectPartial("bytes=10-" + huge, 100, 10, 99);
  ExpectPartial("bytes=-" + huge, 100, 0, 99);
  ExpectPartial("bytes=0-18446744073709551615", 100, 0, 99);  // 2^64 - 1
  ExpectPartial("bytes=0-18446744073709551616", 100, 0, 99);  // 2^64
  ExpectKind("bytes=18446744073709551615-", UINT64_MAX, Kind::kUnsatisfiable);
  ExpectPartial("bytes=18446744073709551614-", UINT64_MAX, UINT64_MAX - 1, UINT64_MAX - 1);
  // Leading zeros are digits like any other.
  ExpectPartial("bytes=0000000000000000000000000000010-00000000000000000000000000019", 100, 10, 19);
  // A very long header costs time linear in its length and nothing more.
  ExpectKind("bytes=" + std::string(100000, '9') + "-", 100, Kind::kUnsatisfiable);
}

TEST(HttpRange, OneByteBody) {
  ExpectPartial("bytes=0-0", 1, 0, 0);
  ExpectPartial("bytes=0-", 1, 0, 0);
  ExpectPartial("bytes=-1", 1, 0, 0);
  ExpectPartial("bytes=-2", 1, 0, 0);
  ExpectKind("bytes=1-", 1, Kind::kUnsatisfiable);
}

}  // namespace
}  // namespace meshstream
