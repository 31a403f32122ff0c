// Helpers every benchmark program shares: error exits, parsing option
// values, timing, file names, machine facts, and the progressive encode with
// a Draco base. The option table itself is bench/options.h.
//
// Contract: for benchmark programs only. Die and Check end the process; the
// rest are pure or only read the machine (/proc, uname, a child process).
#ifndef MESHSTREAM_BENCH_BENCH_UTIL_H_
#define MESHSTREAM_BENCH_BENCH_UTIL_H_

#include <chrono>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/progressive/encoder.h"
#include "codec/core/status.h"
#include "importers/draco_codec.h"

namespace meshstream::bench {

using Clock = std::chrono::steady_clock;

// The name Die prints before every message; call first thing in main.
void SetProgramName(const std::string& name);

// Prints "<program>: <what>" to stderr and exits with status 1.
[[noreturn]] void Die(const std::string& what);

// The value of `v`, or Die("<what>: <status>").
template <class T>
T Check(StatusOr<T> v, const std::string& what) {
  if (!v.ok()) Die(what + ": " + v.status().ToString());
  return std::move(v).value();
}

// The comma-separated items of `s`, empty ones dropped.
std::vector<std::string> SplitList(const std::string& s);

// `s` as a whole integer in [lo, hi]; otherwise Die naming `flag`.
long ParseInt(const std::string& s, const std::string& flag, long lo, long hi);

// `s` as a whole, finite number; otherwise Die naming `flag`.
double ParseDouble(const std::string& s, const std::string& flag);

// Milliseconds from a to b.
double Ms(Clock::time_point a, Clock::time_point b);

// The median of `v`; 0 when empty.
double Median(std::vector<double> v);

// The file name of `path` without folder and extension.
std::string Stem(const std::string& path);

// `s` in single quotes for /bin/sh.
std::string ShellQuote(const std::string& s);

// The first line `cmd` prints on stdout (run by /bin/sh), without the line
// end; "" when it prints nothing or cannot start.
std::string FirstLineOf(const std::string& cmd);

// "<sysname> <release>" from uname, e.g. "Linux 6.1.0".
std::string KernelName();
// The CPU's model name (/proc/cpuinfo), the load average (/proc/loadavg) and
// the time now (UTC, ISO 8601): what every benchmark's JSON records.
std::string CpuModel();
std::string LoadAverage();
std::string UtcNow();

// The short commit hash of the checkout at `dir`; "" when git cannot tell.
std::string GitShortCommit(const std::string& dir);

// GitShortCommit(dir), followed by " (with uncommitted changes)" when a
// tracked file differs from it; "" when git cannot tell.
std::string GitCommitLabel(const std::string& dir);

// The shared models the codec benchmarks measure, in the order they report
// them (files under the shared models' folder, MESHSTREAM_MODELS_DIR).
inline const std::vector<std::string> kSharedModels = {"stanford-bunny.obj", "horse.ply", "fandisk.obj",
                                                       "rocker-arm.obj", "spot.obj"};

// The files of kSharedModels that `only` names (a file name, with or
// without its extension), in kSharedModels's order; all of them when `only`
// is empty. Die("no model matches --model") when none is left.
std::vector<std::string> ChooseSharedModels(const std::vector<std::string>& only);

// The primitives of `scene` that have at least one face, in mesh order.
std::vector<const Primitive*> Primitives(const Scene& scene);

// The diagonal of the bounding box of the vertices `p` references.
double Diagonal(const Primitive& p);

// EncodeProgressive of `prim` with Draco at compression level 7 as the base
// coder (EncodeDracoBase, which fills *ids); Die("<what>: EncodeProgressive:
// ...") on failure.
ProgressiveEncoded EncodeWithDracoBase(const Primitive& prim, const ProgressiveEncodeOptions& options,
                                       DracoAttributeIds* ids, const std::string& what);

}  // namespace meshstream::bench

#endif  // MESHSTREAM_BENCH_BENCH_UTIL_H_
