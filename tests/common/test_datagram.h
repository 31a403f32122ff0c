// A data datagram with a real header and a payload of the test's choosing,
// for tests that need datagrams (the parity's members, a sender's artifact)
// without a stream behind them.
#ifndef MESHSTREAM_TESTS_COMMON_TEST_DATAGRAM_H_
#define MESHSTREAM_TESTS_COMMON_TEST_DATAGRAM_H_

#include <cstdint>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/byte_io.h"

namespace meshstream::test_util {

// The header (version 3, `kind`, `stream`, `refinement`, `stride`, `offset`,
// count 1), then `payload`.
inline std::vector<uint8_t> TestDatagram(uint32_t stream, uint32_t refinement, DatagramKind kind, uint32_t stride,
                                         uint32_t offset, const std::vector<uint8_t>& payload) {
  DatagramHeader h;
  h.kind = kind;
  h.stream = stream;
  h.refinement = refinement;
  h.stride = stride;
  h.offset = offset;
  h.count = 1;
  ByteWriter w;
  h.Serialize(w);
  std::vector<uint8_t> out = std::move(w.bytes());
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

// A stream without a mesh behind it (the simulator's and the parity's tests
// need only bytes): `refinements` refinements, each a two-byte control block
// and `per_refinement` structure datagrams of stream 0 dealt as a writer
// deals them (stride per_refinement, offset d) with payload(r, d).
template <typename Payload>
ProgressiveStream SyntheticStream(uint32_t refinements, uint32_t per_refinement, Payload payload) {
  ProgressiveStream s;
  s.header = {1, 2, 3};
  for (uint32_t r = 0; r < refinements; ++r) {
    s.control.push_back({static_cast<uint8_t>(r), 0xC0});
    std::vector<std::vector<uint8_t>> level;
    for (uint32_t d = 0; d < per_refinement; ++d) {
      level.push_back(TestDatagram(0, r, DatagramKind::kStructure, per_refinement, d, payload(r, d)));
    }
    s.datagrams.push_back(std::move(level));
  }
  return s;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_TEST_DATAGRAM_H_
