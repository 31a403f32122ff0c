// What the service's fuzz targets share: how a broken invariant ends the
// run (a message, then a trap libFuzzer reports), how a string is shown in
// that message, and where a target keeps its temporary store.
#ifndef MESHSTREAM_TESTS_FUZZ_FUZZ_SERVICE_UTIL_H_
#define MESHSTREAM_TESTS_FUZZ_FUZZ_SERVICE_UTIL_H_

#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>

namespace meshstream::fuzz {

[[noreturn]] inline void FuzzBug(const char* target, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", target, what.c_str());
  __builtin_trap();
}

// At most 80 bytes of `s`, printable ASCII kept, everything else as \xNN.
inline std::string Shown(const std::string& s) {
  std::string out;
  for (unsigned char c : s.substr(0, 80)) {
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      out.push_back(static_cast<char>(c));
    } else {
      char hex[5];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      out += hex;
    }
  }
  return s.size() > 80 ? out + "..." : out;
}

// /dev/shm when writable (a store there costs no disk), else $TMPDIR or /tmp.
inline std::string TempRoot() {
  if (access("/dev/shm", W_OK) == 0) return "/dev/shm";
  const char* tmp = std::getenv("TMPDIR");
  return tmp != nullptr && *tmp != '\0' ? tmp : "/tmp";
}

// Removes the folders `<root>/<prefix><pid>` of earlier runs whose process
// is gone (a crash skips the atexit handler).
inline void RemoveStaleFolders(const std::string& root, const std::string& prefix) {
  namespace fs = std::filesystem;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(root, ec)) {
    const std::string name = entry.path().filename().string();
    if (name.compare(0, prefix.size(), prefix) != 0) continue;
    const long pid = std::strtol(name.c_str() + prefix.size(), nullptr, 10);
    if (pid <= 0 || pid == static_cast<long>(getpid())) continue;
    if (kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH) continue;
    fs::remove_all(entry.path(), ec);
  }
}

}  // namespace meshstream::fuzz

#endif  // MESHSTREAM_TESTS_FUZZ_FUZZ_SERVICE_UTIL_H_
