// The erasure code of parity datagrams (docs/spec/progressive-format.md, section
// 7 "Parity"), as a caller gives it to the codec: codec/ links no
// third-party library (docs/architecture.md), so the code's arithmetic comes
// from outside, as threads do (task_runner.h). fec/reed_solomon.h has the one
// made with Intel's ISA-L.
//
// The code: a systematic Reed-Solomon code over GF(2^8) with the polynomial
// x^8 + x^4 + x^3 + x^2 + 1 (0x11D). A block has k data symbols (rows
// 0..k-1) of `len` bytes; parity row r (k <= r < 256) is, byte by byte,
//   parity_r = sum over i < k of c(r, i) * data_i,   c(r, i) = 1 / (r XOR i)
// (a Cauchy matrix below the identity: any k of the rows are independent).
// A row's coefficients do not depend on how many parity rows there are, so
// a sender may add parity rows to a block later and the earlier ones stay.
//
// Contract: every function checks its sizes (k >= 1, rows below 256, data
// rows below k, parity rows in [k, 256), no row twice, wanted rows below k)
// and returns kInvalidArgument without writing anything when one is wrong.
// Thread safety: an implementation must allow concurrent calls.
#ifndef MESHSTREAM_CODEC_CORE_ERASURE_CODE_H_
#define MESHSTREAM_CODEC_CORE_ERASURE_CODE_H_

#include <cstddef>
#include <cstdint>

#include "codec/core/status.h"

namespace meshstream {

constexpr size_t kErasureRows = 256;  // k + m <= 256: rows are GF(2^8) elements

class ErasureCode {
 public:
  virtual ~ErasureCode() = default;
  // Writes parity rows `rows[0..m)` (each in [k, 256)) of the k data symbols
  // data[0..k) of `len` bytes into parity[0..m).
  virtual Status Encode(size_t k, size_t len, const uint8_t* const* data, const uint32_t* rows, size_t m,
                        uint8_t* const* parity) = 0;
  // Rebuilds data symbols: given k symbols of distinct rows (`rows[i]` is
  // symbols[i]'s row: below k a data symbol, else a parity row), writes the
  // data symbols of rows wanted[0..w) (each below k) into out[0..w).
  virtual Status Rebuild(size_t k, size_t len, const uint32_t* rows, const uint8_t* const* symbols,
                         const uint32_t* wanted, size_t w, uint8_t* const* out) = 0;
};

// The checks of the contract above, shared by every implementation.
Status CheckEncodeRows(size_t k, const uint32_t* rows, size_t m);
Status CheckRebuildRows(size_t k, const uint32_t* rows, const uint32_t* wanted, size_t w);

}  // namespace meshstream

#endif  // MESHSTREAM_CODEC_CORE_ERASURE_CODE_H_
