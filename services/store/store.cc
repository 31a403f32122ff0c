#include "services/store/store.h"

#include <chrono>

namespace meshstream {

bool IsValidName(const std::string& name) {
  if (name.empty() || name.size() > 128) return false;
  for (const char c : name) {
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '.' ||
                    c == '_' || c == '-';
    if (!ok) return false;
  }
  return true;
}

Status CheckName(const std::string& field, const std::string& name) {
  if (IsValidName(name)) return Status::Ok();
  if (name.empty()) return InvalidArgument(field + ": must not be empty");
  if (name.size() > 128) return InvalidArgument(field + ": " + std::to_string(name.size()) + " characters, at most 128");
  return InvalidArgument(field + ": only letters, digits, '.', '_' and '-' are allowed");
}

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace meshstream
