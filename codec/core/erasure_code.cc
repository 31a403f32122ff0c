#include "codec/core/erasure_code.h"

#include <string>

namespace meshstream {

namespace {

Status CheckK(size_t k) {
  if (k == 0 || k >= kErasureRows) {
    return InvalidArgument("erasure code: " + std::to_string(k) + " data symbols (1 to 255)");
  }
  return Status::Ok();
}

}  // namespace

Status CheckEncodeRows(size_t k, const uint32_t* rows, size_t m) {
  MS_RETURN_IF_ERROR(CheckK(k));
  bool seen[kErasureRows] = {};
  for (size_t j = 0; j < m; ++j) {
    if (rows[j] < k || rows[j] >= kErasureRows) {
      return InvalidArgument("erasure code: parity row " + std::to_string(rows[j]) + " is not in [" +
                             std::to_string(k) + ", 256)");
    }
    if (seen[rows[j]]) return InvalidArgument("erasure code: parity row " + std::to_string(rows[j]) + " twice");
    seen[rows[j]] = true;
  }
  return Status::Ok();
}

Status CheckRebuildRows(size_t k, const uint32_t* rows, const uint32_t* wanted, size_t w) {
  MS_RETURN_IF_ERROR(CheckK(k));
  bool seen[kErasureRows] = {};
  for (size_t i = 0; i < k; ++i) {
    if (rows[i] >= kErasureRows) {
      return InvalidArgument("erasure code: row " + std::to_string(rows[i]) + " is not below 256");
    }
    if (seen[rows[i]]) return InvalidArgument("erasure code: row " + std::to_string(rows[i]) + " given twice");
    seen[rows[i]] = true;
  }
  for (size_t i = 0; i < w; ++i) {
    if (wanted[i] >= k) {
      return InvalidArgument("erasure code: wanted row " + std::to_string(wanted[i]) + " is not a data row (below " +
                             std::to_string(k) + ")");
    }
  }
  return Status::Ok();
}

}  // namespace meshstream
