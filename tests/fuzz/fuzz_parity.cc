// libFuzzer target for parity datagrams (docs/spec/progressive-format.md, section
// 6.1; codec/loss/parity.h, parity_recovery.h): whatever bytes arrive, the
// parser refuses them or describes members and rows that the bytes hold, and
// the receiver never crashes, never holds more than its budget, and hands
// back only datagrams that name a member of their block.
//
// Input: a sequence of datagrams, each a 2-byte little-endian length and its
// bytes (a length past the end takes what is left), offered to one
// ParityRecovery of stream 0 in order: parity datagrams (kind 4) as parity,
// anything else that parses as a data datagram of stream 0 as data. A fixed
// block of eight real data datagrams (refinements 3 and 4) is offered after
// the input with its first two left out, so that real parity in the input
// can rebuild them. Byte pairs decide nothing else.
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes seeds there: the
// block's real parity datagrams, alone and with some members.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <vector>

#include "codec/core/byte_io.h"
#include "codec/loss/parity.h"
#include "codec/loss/parity_recovery.h"
#include "fec/reed_solomon.h"
#include "tests/common/test_datagram.h"
#include "tests/fuzz/sphere_stream.h"

namespace {

using namespace meshstream;  // NOLINT
using meshstream::fuzz::Bug;
constexpr char kTarget[] = "fuzz_parity";
constexpr size_t kBudget = 1 << 16;

const std::vector<std::vector<uint8_t>>& Block() {
  static const std::vector<std::vector<uint8_t>> block = [] {
    std::vector<std::vector<uint8_t>> out;
    for (uint32_t i = 0; i < 8; ++i) {
      std::vector<uint8_t> payload(20 + 13 * i);
      for (uint32_t b = 0; b < payload.size(); ++b) payload[b] = static_cast<uint8_t>(i * 31 + b * 7);
      out.push_back(test_util::TestDatagram(0, 3 + i / 5, i < 5 ? DatagramKind::kStructure : DatagramKind::kGeometry,
                                            5, i % 5, payload));
    }
    return out;
  }();
  return block;
}

std::vector<std::vector<uint8_t>> RealParity() {
  std::vector<const std::vector<uint8_t>*> members;
  uint32_t k = 0;
  for (const auto& d : Block()) {
    members.push_back(&d);
    k += static_cast<uint32_t>(SymbolsOf(d.size(), 32));
  }
  ParityShape shape;
  shape.symbol_size = 32;
  shape.k = k;
  shape.m = 12;
  shape.per_datagram = 4;
  auto parity = EncodeParity(fec::DefaultErasureCode(), 0, members, shape);
  if (!parity.ok()) Bug(kTarget, "the real block's parity: " + parity.status().ToString());
  return parity.value();
}

void Frame(std::vector<uint8_t>& out, const std::vector<uint8_t>& d) {
  out.push_back(static_cast<uint8_t>(d.size()));
  out.push_back(static_cast<uint8_t>(d.size() >> 8));
  out.insert(out.end(), d.begin(), d.end());
}

void WriteSeeds() {
  const char* dir = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (!dir) return;
  const auto parity = RealParity();
  for (size_t j = 0; j < parity.size(); ++j) {
    std::vector<uint8_t> seed;
    Frame(seed, parity[j]);
    meshstream::fuzz::WriteSeed(dir, "parity-" + std::to_string(j), seed);
  }
  std::vector<uint8_t> all;
  for (const auto& p : parity) Frame(all, p);
  meshstream::fuzz::WriteSeed(dir, "parity-all", all);
  std::vector<uint8_t> mixed;
  Frame(mixed, Block()[3]);
  Frame(mixed, parity[1]);
  Frame(mixed, Block()[5]);
  meshstream::fuzz::WriteSeed(dir, "mixed", mixed);
}

void Check(const ParsedDatagram& d) {
  auto p = ParityDatagram::Parse(d);
  if (!p.ok()) return;
  if (p->symbols + size_t(p->count) * p->symbol_size != d.data() + d.size()) Bug(kTarget, "rows past the bytes");
  uint64_t rows = 0;
  for (size_t i = 0; i < p->members.size(); ++i) {
    if (i > 0 && !MemberBefore(p->members[i - 1], p->members[i])) Bug(kTarget, "members out of order");
    rows += SymbolsOf(p->members[i].length, p->symbol_size);
  }
  if (rows != p->k || p->first_row < p->k || p->first_row + p->count > p->rows || p->rows > 256) {
    Bug(kTarget, "rows that do not add up");
  }
}

void Offer(ParityRecovery& rec, const uint8_t* data, size_t size, std::vector<std::vector<uint8_t>>* rebuilt) {
  auto d = ParsedDatagram::Parse(data, size);
  if (!d.ok()) return;
  if (d->header().kind == DatagramKind::kParity) {
    Check(d.value());
    rec.OnParity(d.value(), rebuilt);
  } else if (d->header().kind != DatagramKind::kEnd && d->header().stream == 0) {
    rec.OnData(d.value(), rebuilt);
  }
  if (rec.held_bytes() > kBudget) Bug(kTarget, "held beyond the budget");
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  ParityRecovery rec(&fec::DefaultErasureCode(), 0, kBudget);
  std::vector<std::vector<uint8_t>> rebuilt;
  size_t at = 0;
  while (at + 2 <= size) {
    size_t n = size_t(data[at]) | (size_t(data[at + 1]) << 8);
    at += 2;
    n = std::min(n, size - at);
    Offer(rec, data + at, n, &rebuilt);
    at += n;
  }
  for (size_t i = 2; i < Block().size(); ++i) Offer(rec, Block()[i].data(), Block()[i].size(), &rebuilt);
  for (const auto& r : rebuilt) {
    auto d = ParsedDatagram::Parse(r.data(), r.size());
    if (!d.ok() || d->header().stream != 0 || d->header().kind == DatagramKind::kParity ||
        d->header().kind == DatagramKind::kEnd) {
      Bug(kTarget, "a rebuilt datagram that is not a data datagram of the stream");
    }
  }
  return 0;
}
