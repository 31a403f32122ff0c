// The one place where an outcome becomes a process exit code and a message.
//   0  success (also --help and --version)
//   1  bad input: the file is missing, malformed, unsupported or too large;
//      also an internal error (an exception that should not have happened)
//   2  bad usage: unknown verb or option, missing or out-of-range argument
//   3  the server cannot be reached, is shutting down, or a request ran out
//      of time (--timeout): retry later (kUnavailable, kDeadlineExceeded)
// Every failure prints exactly one line on stderr.
#ifndef MESHSTREAM_CLI_EXIT_CODES_H_
#define MESHSTREAM_CLI_EXIT_CODES_H_

#include <cstdio>
#include <string>

#include "codec/core/status.h"

namespace meshstream::cli {

constexpr int kExitOk = 0;
constexpr int kExitBadInput = 1;
constexpr int kExitUsage = 2;
constexpr int kExitUnavailable = 3;

inline int ExitCodeFor(const Status& status) {
  if (status.ok()) return kExitOk;
  if (status.code() == StatusCode::kInvalidArgument) return kExitUsage;
  if (status.code() == StatusCode::kUnavailable || status.code() == StatusCode::kDeadlineExceeded) {
    return kExitUnavailable;
  }
  return kExitBadInput;
}

inline std::string OneLine(std::string message) {
  for (char& c : message) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  while (!message.empty() && message.back() == ' ') message.pop_back();
  return message;
}

// Prints "meshstream <verb>: <message>" on stderr (one line) and returns the
// exit code. `verb` may be empty (a usage error before any verb).
inline int ReportError(const std::string& verb, const Status& status) {
  const std::string prefix = verb.empty() ? "meshstream" : "meshstream " + verb;
  std::string line = OneLine(status.message());
  if (status.code() == StatusCode::kInvalidArgument) line += " (see '" + prefix + " --help')";
  std::fprintf(stderr, "%s: %s\n", prefix.c_str(), line.c_str());
  return ExitCodeFor(status);
}

// The last resort of main: an exception reached the top.
inline int ReportInternalError(const std::string& what) {
  std::fprintf(stderr, "meshstream: internal error: %s\n", OneLine(what).c_str());
  return kExitBadInput;
}

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_EXIT_CODES_H_
