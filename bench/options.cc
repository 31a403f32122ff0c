#include "bench/options.h"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <utility>

#include "bench/bench_util.h"

namespace meshstream::bench {
namespace {

constexpr size_t kHelpColumn = 22;   // where an option's help starts
constexpr size_t kUsageWidth = 100;  // the usage line wraps before this

std::string Range(double lo, double hi, bool lo_open) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%c%g, %g]", lo_open ? '(' : '[', lo, hi);
  return buf;
}

}  // namespace

Options::Options(std::string program, std::string about) : program_(std::move(program)), about_(std::move(about)) {}

Options& Options::Add(Entry e) {
  entries_.push_back(std::move(e));
  return *this;
}

Options& Options::Flag(const std::string& name, bool* target, const std::string& help) {
  return Add({name, "", help, false, [target](const std::string&) { *target = true; }});
}

Options& Options::Action(const std::string& name, std::function<void()> on, const std::string& help) {
  return Add({name, "", help, false, [on = std::move(on)](const std::string&) { on(); }});
}

Options& Options::Int(const std::string& name, const std::string& value, int* target, long lo, long hi,
                      const std::string& help) {
  return Add({name, value, help, false,
              [=](const std::string& v) { *target = static_cast<int>(ParseInt(v, name, lo, hi)); }});
}

Options& Options::Int64(const std::string& name, const std::string& value, int64_t* target, long lo, long hi,
                        const std::string& help) {
  return Add({name, value, help, false, [=](const std::string& v) { *target = ParseInt(v, name, lo, hi); }});
}

Options& Options::Unsigned(const std::string& name, const std::string& value, unsigned* target, long lo, long hi,
                           const std::string& help) {
  return Add({name, value, help, false,
              [=](const std::string& v) { *target = static_cast<unsigned>(ParseInt(v, name, lo, hi)); }});
}

Options& Options::Double(const std::string& name, const std::string& value, double* target, double lo, double hi,
                         const std::string& help, bool lo_open) {
  return Add({name, value, help, false, [=](const std::string& v) {
                const double d = ParseDouble(v, name);
                if (d < lo || d > hi || (lo_open && d == lo)) Die(name + ": expected a number in " + Range(lo, hi, lo_open));
                *target = d;
              }});
}

Options& Options::String(const std::string& name, const std::string& value, std::string* target,
                         const std::string& help) {
  return Add({name, value, help, false, [target](const std::string& v) { *target = v; }});
}

Options& Options::Append(const std::string& name, const std::string& value, std::vector<std::string>* target,
                         const std::string& help) {
  return Add({name, value, help, true, [target](const std::string& v) { target->push_back(v); }});
}

Options& Options::IntList(const std::string& name, const std::string& value, std::vector<int>* target, long lo,
                          long hi, const std::string& help) {
  return Add({name, value, help, false, [=](const std::string& v) {
                target->clear();
                for (const std::string& s : SplitList(v)) target->push_back(static_cast<int>(ParseInt(s, name, lo, hi)));
                if (target->empty()) Die(name + ": empty list");
              }});
}

Options& Options::Custom(const std::string& name, const std::string& value,
                         std::function<void(const std::string&)> on, const std::string& help) {
  return Add({name, value, help, false, std::move(on)});
}

Options& Options::CustomN(const std::string& name, const std::string& values, int count,
                          std::function<void(const std::vector<std::string>&)> on, const std::string& help) {
  Entry e{name, values, help, false, nullptr};
  e.count = count;
  e.on_n = std::move(on);
  return Add(std::move(e));
}

Options& Options::Section(const std::string& title) { return Add({"", "", title, false, nullptr}); }

void Options::Parse(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string f = argv[i];
    if (f == "--help" || f == "-h") {
      std::fputs(Help().c_str(), stdout);
      std::exit(0);
    }
    const Entry* entry = nullptr;
    for (const Entry& e : entries_) {
      if (!e.name.empty() && e.name == f) entry = &e;
    }
    if (entry == nullptr) Die("unknown option " + f + " (see --help)");
    if (entry->on_n) {
      std::vector<std::string> values;
      for (int k = 0; k < entry->count; ++k) {
        if (i + 1 >= argc) Die(f + " needs " + std::to_string(entry->count) + " values (" + entry->value + ")");
        values.push_back(argv[++i]);
      }
      entry->on_n(values);
    } else {
      std::string value;
      if (!entry->value.empty()) {
        if (i + 1 >= argc) Die(f + " needs a value");
        value = argv[++i];
      }
      entry->on(value);
    }
    given_.insert(f);
  }
}

std::string Options::Help() const {
  // The usage line: every option in brackets, wrapped under the first.
  const std::string head = "usage: " + program_ + " ";
  std::string usage = head, line;
  for (const Entry& e : entries_) {
    if (e.name.empty()) continue;
    const std::string item = "[" + e.name + (e.value.empty() ? "" : " " + e.value) + "]" + (e.repeatable ? "..." : "");
    if (!line.empty() && head.size() + line.size() + 1 + item.size() > kUsageWidth) {
      usage += line + "\n" + std::string(head.size(), ' ');
      line.clear();
    }
    line += (line.empty() ? "" : " ") + item;
  }
  std::string out = usage + line + "\n\n" + about_;
  // One line per option; the help's own line breaks continue at the column.
  for (const Entry& e : entries_) {
    if (e.name.empty()) {
      out += e.help + "\n";
      continue;
    }
    std::string left = "  " + e.name + (e.value.empty() ? "" : " " + e.value);
    left += left.size() + 2 <= kHelpColumn ? std::string(kHelpColumn - left.size(), ' ') : "  ";
    std::string help = e.help;
    for (size_t at = 0; (at = help.find('\n', at)) != std::string::npos; at += kHelpColumn + 1) {
      help.insert(at + 1, std::string(kHelpColumn, ' '));
    }
    out += left + help + "\n";
  }
  return out;
}

void AddModelOptions(Options& o, std::string* dir, std::vector<std::string>* only, const std::string& model_help) {
  o.String("--models", "DIR", dir, "folder of the shared models (default: the build's MESHSTREAM_MODELS_DIR)");
  o.Append("--model", "NAME", only, model_help);
}

}  // namespace meshstream::bench
