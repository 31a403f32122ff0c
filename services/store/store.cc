#include "services/store/store.h"

#include <chrono>

namespace meshstream {

bool IsValidName(const std::string& name) {
  if (name.empty() || name.size() > 128) return false;
  if (name == "." || name == "..") return false;  // they would name folders (uploads/<tenant>/)
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
  if (name == "." || name == "..") return InvalidArgument(field + ": '" + name + "' is not a name");
  return InvalidArgument(field + ": only letters, digits, '.', '_' and '-' are allowed");
}

std::string TruncateMessage(const std::string& message, size_t max_bytes) {
  if (message.size() <= max_bytes) return message;
  const std::string ellipsis = "...";
  size_t cut = max_bytes > ellipsis.size() ? max_bytes - ellipsis.size() : 0;
  // Back to the start of a UTF-8 sequence (continuation bytes are 10xxxxxx).
  while (cut > 0 && (static_cast<unsigned char>(message[cut]) & 0xC0) == 0x80) --cut;
  return message.substr(0, cut) + ellipsis;
}

int64_t NowMs() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace meshstream
