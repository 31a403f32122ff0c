#include "bench/bench_util.h"

#include <sys/utsname.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <string>
#include <sstream>

#include "importers/draco_base_coder.h"

namespace meshstream::bench {
namespace {

std::string& ProgramName() {
  static std::string name = "bench";
  return name;
}

}  // namespace

void SetProgramName(const std::string& name) { ProgramName() = name; }

void Die(const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", ProgramName().c_str(), what.c_str());
  std::exit(1);
}

std::vector<std::string> SplitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

long ParseInt(const std::string& s, const std::string& flag, long lo, long hi) {
  char* end = nullptr;
  const long v = std::strtol(s.c_str(), &end, 10);
  if (end == s.c_str() || *end != '\0' || v < lo || v > hi) {
    Die(flag + ": expected an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got '" + s + "'");
  }
  return v;
}

double ParseDouble(const std::string& s, const std::string& flag) {
  char* end = nullptr;
  const double v = std::strtod(s.c_str(), &end);
  if (end == s.c_str() || *end != '\0' || !std::isfinite(v)) Die(flag + ": not a number: '" + s + "'");
  return v;
}

double Ms(Clock::time_point a, Clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); }

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Stem(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  const size_t dot = name.find_last_of('.');
  return dot == std::string::npos ? name : name.substr(0, dot);
}

std::string ShellQuote(const std::string& s) {
  std::string out = "'";
  for (char c : s) {
    if (c == '\'') out += "'\\''";
    else out += c;
  }
  return out + "'";
}

std::string FirstLineOf(const std::string& cmd) {
  std::string out;
  FILE* p = popen(cmd.c_str(), "r");
  if (!p) return out;
  char buf[512];
  if (std::fgets(buf, sizeof buf, p)) out = buf;
  pclose(p);
  while (!out.empty() && (out.back() == '\n' || out.back() == '\r')) out.pop_back();
  return out;
}

std::string KernelName() {
  utsname u{};
  uname(&u);
  return std::string(u.sysname) + " " + u.release;
}

std::string GitShortCommit(const std::string& dir) {
  return FirstLineOf("git -C " + ShellQuote(dir) + " rev-parse --short HEAD 2>/dev/null");
}

std::string GitCommitLabel(const std::string& dir) {
  const std::string commit = GitShortCommit(dir);
  if (commit.empty()) return "";
  const std::string dirty =
      FirstLineOf("git -C " + ShellQuote(dir) + " status --porcelain --untracked-files=no 2>/dev/null");
  return commit + (dirty.empty() ? "" : " (with uncommitted changes)");
}

std::vector<std::string> ChooseSharedModels(const std::vector<std::string>& only) {
  std::vector<std::string> chosen;
  for (const std::string& f : kSharedModels) {
    if (only.empty() || std::find(only.begin(), only.end(), f) != only.end() ||
        std::find(only.begin(), only.end(), Stem(f)) != only.end()) {
      chosen.push_back(f);
    }
  }
  if (chosen.empty()) Die("no model matches --model");
  return chosen;
}

std::vector<const Primitive*> Primitives(const Scene& scene) {
  std::vector<const Primitive*> out;
  for (const Mesh& m : scene.meshes)
    for (const Primitive& p : m.primitives)
      if (p.face_count() > 0) out.push_back(&p);
  return out;
}

double Diagonal(const Primitive& p) {
  std::array<double, 3> lo = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (uint32_t i : p.indices)
    for (int c = 0; c < 3; ++c) {
      lo[c] = std::min<double>(lo[c], p.positions[i][c]);
      hi[c] = std::max<double>(hi[c], p.positions[i][c]);
    }
  double d = 0;
  for (int c = 0; c < 3; ++c) d += (hi[c] - lo[c]) * (hi[c] - lo[c]);
  return std::sqrt(d);
}

ProgressiveEncoded EncodeWithDracoBase(const Primitive& prim, const ProgressiveEncodeOptions& options,
                                       DracoAttributeIds* ids, const std::string& what) {
  return Check(EncodeProgressive(prim, options,
                                 [ids](const QuantizedMesh& base, int method) {
                                   return EncodeDracoBase(base, method, 7, ids);
                                 }),
               what + ": EncodeProgressive");
}

std::string CpuModel() {
  std::ifstream f("/proc/cpuinfo");
  std::string line;
  while (std::getline(f, line)) {
    if (line.rfind("model name", 0) == 0) {
      const size_t c = line.find(':');
      if (c != std::string::npos) {
        size_t s = c + 1;
        while (s < line.size() && line[s] == ' ') ++s;
        return line.substr(s);
      }
    }
  }
  return "unknown";
}

std::string LoadAverage() {
  std::ifstream f("/proc/loadavg");
  std::string a, b, c;
  if (!(f >> a >> b >> c)) return "unknown";
  return a + " " + b + " " + c;
}

std::string UtcNow() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

}  // namespace meshstream::bench
