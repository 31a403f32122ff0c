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

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_TEST_DATAGRAM_H_
