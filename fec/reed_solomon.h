// The codec's erasure code (codec/core/erasure_code.h) on Intel's ISA-L
// (Debian's libisal-dev): the Cauchy matrix of the spec built with
// ISA-L's gf_inv, tables by ec_init_tables, symbols multiplied by
// ec_encode_data (SIMD, dispatched at run time), and a rebuild that
// subtracts the known data rows from the parity rows given and solves the
// e x e Cauchy system of the e missing rows (gf_invert_matrix on e x e, not
// k x k: the cost of a rebuild grows with what was lost).
//
// Contract: as ErasureCode; safe to call from several threads at once (no
// state). Allocates O(k e + e^2) bytes of coefficients and tables per call.
#ifndef MESHSTREAM_FEC_REED_SOLOMON_H_
#define MESHSTREAM_FEC_REED_SOLOMON_H_

#include "codec/core/erasure_code.h"

namespace meshstream::fec {

class ReedSolomon final : public ErasureCode {
 public:
  Status Encode(size_t k, size_t len, const uint8_t* const* data, const uint32_t* rows, size_t m,
                uint8_t* const* parity) override;
  Status Rebuild(size_t k, size_t len, const uint32_t* rows, const uint8_t* const* symbols, const uint32_t* wanted,
                 size_t w, uint8_t* const* out) override;
};

// One code for the process (it has no state).
ErasureCode& DefaultErasureCode();

}  // namespace meshstream::fec

#endif  // MESHSTREAM_FEC_REED_SOLOMON_H_
