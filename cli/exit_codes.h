// The one place where a Status becomes a process exit code and a message.
//   0  success
//   1  bad input: the file is missing, malformed, unsupported or too large
//   2  bad usage: unknown verb or option, missing or out-of-range argument
#ifndef MESHSTREAM_CLI_EXIT_CODES_H_
#define MESHSTREAM_CLI_EXIT_CODES_H_

#include <cstdio>
#include <string>

#include "codec/core/status.h"

namespace meshstream::cli {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;

inline int ExitCodeFor(const Status& status) {
  if (status.ok()) return kExitOk;
  return status.code() == StatusCode::kInvalidArgument ? kExitUsage : kExitBadInput;
}

// Prints "meshstream <verb>: <message>" on stderr (one line) and returns the exit code.
inline int ReportError(const std::string& verb, const Status& status) {
  std::string message = status.message();
  for (char& c : message) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  std::fprintf(stderr, "meshstream %s: %s\n", verb.c_str(), message.c_str());
  if (status.code() == StatusCode::kInvalidArgument) {
    std::fprintf(stderr, "Try 'meshstream %s --help'.\n", verb.c_str());
  }
  return ExitCodeFor(status);
}

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_EXIT_CODES_H_
