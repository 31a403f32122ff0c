// A small command-line flag parser for the meshstream verbs.
// Flags are "--name value" or "--name=value"; boolean flags take no value.
// Unknown flags and missing values are usage errors (InvalidArgument).
#ifndef MESHSTREAM_CLI_ARGS_H_
#define MESHSTREAM_CLI_ARGS_H_

#include <map>
#include <set>
#include <string>
#include <vector>

#include "codec/core/status.h"

namespace meshstream::cli {

struct FlagSpec {
  std::string name;  // without the leading "--"
  bool takes_value = false;
};

class ParsedArgs {
 public:
  std::vector<std::string> positional;
  std::map<std::string, std::string> values;
  std::set<std::string> switches;

  bool Has(const std::string& name) const { return switches.count(name) || values.count(name); }
  // The integer value of --name within [lo, hi], or `fallback` when absent.
  StatusOr<int> Int(const std::string& name, int fallback, int lo, int hi) const;
  StatusOr<double> Double(const std::string& name, double fallback, double lo, double hi) const;
  std::string String(const std::string& name, const std::string& fallback) const;
};

// "--help"/"-h" anywhere sets the switch "help".
StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs);

}  // namespace meshstream::cli

#endif  // MESHSTREAM_CLI_ARGS_H_
