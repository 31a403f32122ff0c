#include "net/drop_reason.h"

namespace meshstream {

const char* DropReasonName(DropReason reason) {
  switch (reason) {
    case DropReason::kNone: return "none";
    case DropReason::kTooShort: return "too_short";
    case DropReason::kTooLong: return "too_long";
    case DropReason::kBadMagic: return "bad_magic";
    case DropReason::kBadVersion: return "bad_version";
    case DropReason::kBadType: return "bad_type";
    case DropReason::kBadReserved: return "bad_reserved";
    case DropReason::kUnknownSession: return "unknown_session";
    case DropReason::kAuthFailed: return "auth_failed";
    case DropReason::kReplayed: return "replayed";
    case DropReason::kTooOld: return "too_old";
    case DropReason::kBadPayload: return "bad_payload";
  }
  return "unknown";
}

uint64_t DropCounters::dropped() const {
  uint64_t total = 0;
  for (size_t i = 1; i < by_reason.size(); ++i) total += by_reason[i];
  return total;
}

}  // namespace meshstream
