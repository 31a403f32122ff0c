// Helpers for tests that run the meshstream CLI and the Khronos validator as
// real processes (tests/cli/).
#ifndef MESHSTREAM_TESTS_COMMON_CLI_UTIL_H_
#define MESHSTREAM_TESTS_COMMON_CLI_UTIL_H_

#include <algorithm>
#include <atomic>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "testing/test_util.h"

namespace meshstream::test_util {

// Runs `meshstream ARGS`, expects exit 0 and one JSON object on stdout.
inline nlohmann::json RunCliJson(const std::string& args) {
  const auto r = RunCommand(Cli() + " " + args);
  EXPECT_EQ(r.exit_code, 0) << args << "\n" << r.err;
  nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
  EXPECT_FALSE(j.is_discarded()) << args << "\n" << r.out;
  return j.is_discarded() ? nlohmann::json::object() : j;
}

// The Khronos validator's report (tools/validate-gltf.js): one JSON object per
// file, with "errors", "warnings", "infos" and the first error messages.
inline std::vector<nlohmann::json> ValidateGltf(const std::vector<std::string>& files) {
  std::string command = "node " + Quote(SourcePath("tools/validate-gltf.js"));
  for (const std::string& f : files) command += " " + Quote(f);
  const auto r = RunCommand(command);
  std::vector<nlohmann::json> reports;
  size_t start = 0;
  while (start < r.out.size()) {
    const size_t end = std::min(r.out.find('\n', start), r.out.size());
    if (end > start) reports.push_back(nlohmann::json::parse(r.out.substr(start, end - start), nullptr, false));
    start = end + 1;
  }
  EXPECT_EQ(reports.size(), files.size()) << "validator output: " << r.out << r.err;
  return reports;
}

// Runs every command (through RunCommand) on a pool of `workers` threads and
// returns the results in the order of `commands`.
inline std::vector<CommandResult> RunCommandsInParallel(const std::vector<std::string>& commands, int workers) {
  std::vector<CommandResult> results(commands.size());
  std::atomic<size_t> next{0};
  std::vector<std::thread> pool;
  for (int w = 0; w < std::max(1, workers); ++w) {
    pool.emplace_back([&] {
      for (size_t i = next++; i < commands.size(); i = next++) results[i] = RunCommand(commands[i]);
    });
  }
  for (std::thread& t : pool) t.join();
  return results;
}

}  // namespace meshstream::test_util

#endif  // MESHSTREAM_TESTS_COMMON_CLI_UTIL_H_
