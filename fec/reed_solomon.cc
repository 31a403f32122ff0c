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
  // The data rows given are known; the e missing ones are solved from the e
  // parity rows given, without inverting the whole k x k matrix (k^3 for
  // k = 160 dominated a decode): with P the parity rows and M the missing
  // data rows, parity_p - sum over known i of c(p, i) data_i =
  // sum over m in M of c(p, m) data_m, an e x e system.
  std::vector<uint32_t> known, parity_rows;
  std::vector<const uint8_t*> known_symbols, parity_symbols;
  std::vector<bool> present(k, false);
  for (size_t i = 0; i < k; ++i) {
    if (rows[i] < k) {
      present[rows[i]] = true;
      known.push_back(rows[i]);
      known_symbols.push_back(symbols[i]);
    } else {
      parity_rows.push_back(rows[i]);
      parity_symbols.push_back(symbols[i]);
    }
  }
  std::vector<uint32_t> missing;
  for (uint32_t r = 0; r < k; ++r) {
    if (!present[r]) missing.push_back(r);
  }
  const size_t e = missing.size();  // == parity_rows.size(): k distinct rows in all
  std::vector<size_t> slot(k, SIZE_MAX);
  for (size_t j = 0; j < e; ++j) slot[missing[j]] = j;
  for (size_t j = 0; j < w; ++j) {
    if (slot[wanted[j]] == SIZE_MAX) {  // wanted but given: a copy
      for (size_t i = 0; i < k; ++i) {
        if (rows[i] == wanted[j]) std::memcpy(out[j], symbols[i], len);
      }
    }
  }
  if (e == 0 || len == 0) return Status::Ok();
  // 1. The right-hand sides: each parity row plus the known rows' part of it
  // (addition is subtraction in GF(2^8)), in one multiply over
  // [known..., parity...].
  const size_t inputs = known.size() + e;
  std::vector<uint8_t> coefficients(e * inputs, 0);
  for (size_t a = 0; a < e; ++a) {
    for (size_t i = 0; i < known.size(); ++i) {
      coefficients[a * inputs + i] = gf_inv(static_cast<unsigned char>(parity_rows[a] ^ known[i]));
    }
    coefficients[a * inputs + known.size() + a] = 1;
  }
  std::vector<const uint8_t*> in(known_symbols);
  in.insert(in.end(), parity_symbols.begin(), parity_symbols.end());
  std::vector<uint8_t> rhs(e * len);
  std::vector<uint8_t*> rhs_ptrs(e);
  for (size_t a = 0; a < e; ++a) rhs_ptrs[a] = &rhs[a * len];
  Multiply(inputs, e, len, coefficients.data(), in.data(), rhs_ptrs.data());
  // 2. The e x e Cauchy system of the missing rows, inverted.
  std::vector<uint8_t> system(e * e), inverse(e * e);
  for (size_t a = 0; a < e; ++a) {
    for (size_t b = 0; b < e; ++b) system[a * e + b] = gf_inv(static_cast<unsigned char>(parity_rows[a] ^ missing[b]));
  }
  if (gf_invert_matrix(system.data(), inverse.data(), static_cast<int>(e)) != 0) {
    // A square submatrix of a Cauchy matrix is never singular: not reached.
    return Internal("erasure code: the rows given are not independent");
  }
  // 3. The wanted missing rows: their rows of the inverse times the right-hand sides.
  std::vector<uint8_t> decode;
  std::vector<uint8_t*> targets;
  for (size_t j = 0; j < w; ++j) {
    const size_t m = slot[wanted[j]];
    if (m == SIZE_MAX) continue;
    decode.insert(decode.end(), &inverse[m * e], &inverse[m * e] + e);
    targets.push_back(out[j]);
  }
  std::vector<const uint8_t*> rhs_in(e);
  for (size_t a = 0; a < e; ++a) rhs_in[a] = &rhs[a * len];
  Multiply(e, targets.size(), len, decode.data(), rhs_in.data(), targets.data());
  return Status::Ok();
}

ErasureCode& DefaultErasureCode() {
  static ReedSolomon code;
  return code;
}

}  // namespace meshstream::fec
