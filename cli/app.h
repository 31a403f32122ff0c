// The meshstream command line on CLI11: one subcommand per verb, typed options
// with their valid ranges, help for every verb, and the environment-variable
// rule (docs/spec/cli.md).
#ifndef MESHSTREAM_CLI_APP_H_
#define MESHSTREAM_CLI_APP_H_

#include <functional>
#include <string>

#include <CLI/CLI.hpp>

namespace meshstream::cli {

// A verb: its subcommand and what runs when it was chosen (returns the exit code).
struct Verb {
  CLI::App* command = nullptr;
  std::function<int()> run;
};

// Adds the subcommand `name`. `summary` is one sentence (listed by
// `meshstream --help`); `details` follows the options in `meshstream NAME --help`
// and ends with an example.
CLI::App* AddVerb(CLI::App& root, const std::string& name, const std::string& summary, const std::string& details);

// The environment rule: an option --foo-bar may be read from MESHSTREAM_FOO_BAR
// (upper case, '-' becomes '_'); the command line wins over the environment.
std::string EnvName(const std::string& long_option_name);
// Lets `option` be read from EnvName(its long name). Returns `option`.
CLI::Option* FromEnv(CLI::Option* option);

// A finite number in [lo, hi] (CLI::Range lets "nan" through).
CLI::Validator NumberIn(double lo, double hi);

// Parses argv, runs the chosen verb, and returns the exit code. Throws only
// what a verb throws (main catches everything).
int Main(int argc, char** argv);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_APP_H_
