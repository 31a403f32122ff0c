#include "cli/args.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>

namespace meshstream::cli {

StatusOr<int> ParsedArgs::Int(const std::string& name, int fallback, int lo, int hi) const {
  auto it = values.find(name);
  if (it == values.end()) return fallback;
  errno = 0;
  char* end = nullptr;
  const long v = std::strtol(it->second.c_str(), &end, 10);
  if (it->second.empty() || *end != '\0' || errno != 0 || v < lo || v > hi) {
    return InvalidArgument("--" + name + " must be an integer between " + std::to_string(lo) + " and " +
                           std::to_string(hi) + ", got '" + it->second + "'");
  }
  return static_cast<int>(v);
}

StatusOr<double> ParsedArgs::Double(const std::string& name, double fallback, double lo, double hi) const {
  auto it = values.find(name);
  if (it == values.end()) return fallback;
  char* end = nullptr;
  const double v = std::strtod(it->second.c_str(), &end);
  if (it->second.empty() || *end != '\0' || !std::isfinite(v) || v < lo || v > hi) {
    return InvalidArgument("--" + name + " must be a number between " + std::to_string(lo) + " and " +
                           std::to_string(hi) + ", got '" + it->second + "'");
  }
  return v;
}

std::string ParsedArgs::String(const std::string& name, const std::string& fallback) const {
  auto it = values.find(name);
  return it == values.end() ? fallback : it->second;
}

StatusOr<ParsedArgs> ParseArgs(const std::vector<std::string>& args, const std::vector<FlagSpec>& specs) {
  ParsedArgs out;
  for (size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "--help" || a == "-h") {
      out.switches.insert("help");
      continue;
    }
    if (a == "--") {
      for (++i; i < args.size(); ++i) out.positional.push_back(args[i]);
      break;
    }
    // "--name" for every option; "-x" for one-letter options (e.g. -o).
    const bool long_form = a.size() > 2 && a.compare(0, 2, "--") == 0;
    const bool short_form = a.size() == 2 && a[0] == '-' && a[1] != '-';
    if (long_form || short_form) {
      std::string name = a.substr(long_form ? 2 : 1);
      if (short_form && !(a[1] >= 'a' && a[1] <= 'z')) return InvalidArgument("unknown option " + a);
      std::string value;
      bool has_inline = false;
      if (const size_t eq = name.find('='); eq != std::string::npos) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
        has_inline = true;
      }
      const FlagSpec* spec = nullptr;
      for (const FlagSpec& s : specs) {
        if (s.name == name) spec = &s;
      }
      if (!spec) return InvalidArgument("unknown option --" + name);
      if (spec->takes_value) {
        if (!has_inline) {
          if (i + 1 >= args.size()) return InvalidArgument("--" + name + " needs a value");
          value = args[++i];
        }
        out.values[name] = value;
      } else {
        if (has_inline) return InvalidArgument("--" + name + " takes no value");
        out.switches.insert(name);
      }
      continue;
    }
    if (a.size() > 1 && a[0] == '-' && !(a[1] >= '0' && a[1] <= '9') && a[1] != '.') {
      return InvalidArgument("unknown option " + a);
    }
    out.positional.push_back(a);
  }
  return out;
}

}  // namespace meshstream::cli
