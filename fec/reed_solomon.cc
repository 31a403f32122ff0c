#include "fec/reed_solomon.h"

#include <isa-l/erasure_code.h>

#include <cstring>
#include <vector>

namespace meshstream::fec {

namespace {

// Row r of the code's generator matrix (k coefficients).
void GeneratorRow(size_t k, uint32_t r, uint8_t* out) {
  if (r < k) {
    std::memset(out, 0, k);
    out[r] = 1;
    return;
  }
  for (size_t i = 0; i < k; ++i) out[i] = gf_inv(static_cast<unsigned char>(r ^ static_cast<uint32_t>(i)));
}

// out[j] = sum_i coefficients[j * k + i] * in[i], for j < rows.
void Multiply(size_t k, size_t rows, size_t len, const uint8_t* coefficients, const uint8_t* const* in,
              uint8_t* const* out) {
  if (rows == 0 || len == 0) return;
  std::vector<uint8_t> tables(32 * k * rows);
  ec_init_tables(static_cast<int>(k), static_cast<int>(rows), const_cast<unsigned char*>(coefficients), tables.data());
  ec_encode_data(static_cast<int>(len), static_cast<int>(k), static_cast<int>(rows), tables.data(),
                 const_cast<unsigned char**>(in), const_cast<unsigned char**>(out));
}

}  // namespace

Status ReedSolomon::Encode(size_t k, size_t len, const uint8_t* const* data, const uint32_t* rows, size_t m,
                           uint8_t* const* parity) {
  MS_RETURN_IF_ERROR(CheckEncodeRows(k, rows, m));
  std::vector<uint8_t> coefficients(k * m);
  for (size_t j = 0; j < m; ++j) GeneratorRow(k, rows[j], &coefficients[j * k]);
  Multiply(k, m, len, coefficients.data(), data, parity);
  return Status::Ok();
}

Status ReedSolomon::Rebuild(size_t k, size_t len, const uint32_t* rows, const uint8_t* const* symbols,
                            const uint32_t* wanted, size_t w, uint8_t* const* out) {
  MS_RETURN_IF_ERROR(CheckRebuildRows(k, rows, wanted, w));
  // symbols = B data, B the rows given; data = B^-1 symbols.
  std::vector<uint8_t> b(k * k), inverse(k * k);
  for (size_t i = 0; i < k; ++i) GeneratorRow(k, rows[i], &b[i * k]);
  if (gf_invert_matrix(b.data(), inverse.data(), static_cast<int>(k)) != 0) {
    // Any k distinct rows of the Cauchy code are independent: not reached.
    return Internal("erasure code: the rows given are not independent");
  }
  std::vector<uint8_t> decode(k * w);
  for (size_t j = 0; j < w; ++j) std::memcpy(&decode[j * k], &inverse[wanted[j] * k], k);
  Multiply(k, w, len, decode.data(), symbols, out);
  return Status::Ok();
}

ErasureCode& DefaultErasureCode() {
  static ReedSolomon code;
  return code;
}

}  // namespace meshstream::fec
