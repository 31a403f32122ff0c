// The option table of a benchmark program: every option once, with the name
// of its value, its help line and where its value goes. Parse walks argv
// against the table; --help prints a usage made from the same table, so the
// help and the parser cannot disagree.
//
//   bench::Options o("meshstream_bench_x", "Benchmarks x; writes one JSON object.");
//   o.Flag("--quick", &args.quick, "a short run");
//   o.Int("--samples", "N", &args.samples, 1, 100000, "timed sessions per row (default 200)");
//   o.Parse(argc, argv);
//   if (args.quick && !o.Given("--samples")) args.samples = 20;
//
// Contract: for benchmark programs only. Parse ends the process: with status
// 0 after printing the help (--help, -h), with Die (status 1) on an unknown
// option, a missing value or a value out of its range. The targets must
// outlive Parse. Not thread-safe (one table per program, filled and parsed
// by main).
#ifndef MESHSTREAM_BENCH_OPTIONS_H_
#define MESHSTREAM_BENCH_OPTIONS_H_

#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

namespace meshstream::bench {

class Options {
 public:
  // `program` heads the usage line; `about` (lines ending in '\n') follows it.
  Options(std::string program, std::string about);

  // A flag without a value: *target = true.
  Options& Flag(const std::string& name, bool* target, const std::string& help);
  // A flag without a value that runs `on`.
  Options& Action(const std::string& name, std::function<void()> on, const std::string& help);
  // A whole number in [lo, hi].
  Options& Int(const std::string& name, const std::string& value, int* target, long lo, long hi,
               const std::string& help);
  Options& Int64(const std::string& name, const std::string& value, int64_t* target, long lo, long hi,
                 const std::string& help);
  Options& Unsigned(const std::string& name, const std::string& value, unsigned* target, long lo, long hi,
                    const std::string& help);
  // A finite number in [lo, hi], or in (lo, hi] when `lo_open`.
  Options& Double(const std::string& name, const std::string& value, double* target, double lo, double hi,
                  const std::string& help, bool lo_open = false);
  Options& String(const std::string& name, const std::string& value, std::string* target, const std::string& help);
  // Repeatable: each use appends its value.
  Options& Append(const std::string& name, const std::string& value, std::vector<std::string>* target,
                  const std::string& help);
  // A comma-separated list of whole numbers in [lo, hi], not empty; it
  // replaces the default.
  Options& IntList(const std::string& name, const std::string& value, std::vector<int>* target, long lo, long hi,
                   const std::string& help);
  // Any other value: `on` receives it (and may Die).
  Options& Custom(const std::string& name, const std::string& value, std::function<void(const std::string&)> on,
                  const std::string& help);
  // An option of `count` values (named `values`, e.g. "MODEL SEC"): `on`
  // receives them in order.
  Options& CustomN(const std::string& name, const std::string& values, int count,
                   std::function<void(const std::vector<std::string>&)> on, const std::string& help);
  // A heading in the help, before the options that follow.
  Options& Section(const std::string& title);

  // Parses argv[1..]; see the contract above.
  void Parse(int argc, char** argv);
  // Whether `name` was on the command line (Parse first).
  bool Given(const std::string& name) const { return given_.count(name) > 0; }
  // The usage line, `about` and one line per option (help continuation
  // lines indented under the first).
  std::string Help() const;

 private:
  struct Entry {
    Entry() = default;
    Entry(std::string name_, std::string value_, std::string help_, bool repeatable_,
          std::function<void(const std::string&)> on_)
        : name(std::move(name_)), value(std::move(value_)), help(std::move(help_)), repeatable(repeatable_),
          on(std::move(on_)) {}
    std::string name;   // "" for a section heading
    std::string value;  // "" for a flag
    std::string help;
    bool repeatable = false;
    std::function<void(const std::string&)> on;  // one value ("" for a flag)
    int count = 1;                                // values; when more than one, on_n takes them
    std::function<void(const std::vector<std::string>&)> on_n;
  };
  Options& Add(Entry e);

  std::string program_, about_;
  std::vector<Entry> entries_;
  std::set<std::string> given_;
};

// --models DIR (the shared models' folder) into *dir and --model NAME
// (repeatable, `model_help` its help) into *only: the model options of
// every program that reads the shared models.
void AddModelOptions(Options& o, std::string* dir, std::vector<std::string>* only,
                     const std::string& model_help = "only this model (file name, with or without extension); repeatable");

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_OPTIONS_H_
