// No verb of the built CLI ends with a signal, on any input: every fuzz-corpus
// file (tests/fuzz/corpus/*/) goes through info, info --json, convert,
// encode, compare and (for .glb inputs) decode, and every run must exit 0, 1
// or 2 within a time bound, with one line on stderr when it fails and never
// an "internal error" (an exception that reached main).
//
// Run time on 2 cores: the processes run on a small pool (2 workers). The
// corpora of file formats (gltf, progressive_glb, and obj/ply/off/stl when
// they exist) run in full, up to kMaxPerCorpus files each; the corpora of raw
// codec bytes (datagram, reconstructor, split_bits, ...), which every
// importer refuses at the container or the first line, are sampled
// deterministically: every k-th file in name order, kRawSample files each,
// fed both as .glb and as .obj. Today: about 2,800 runs, 20-60 s depending
// on the machine's load (encode runs with --levels 4 to stay in that bound).
// MESHSTREAM_NO_SIGNAL_ALL=1 in the environment runs every file of every
// corpus instead (about 20,000 runs).
#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "tests/common/cli_util.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

namespace fs = std::filesystem;
using test_util::Cli;
using test_util::CommandResult;
using test_util::ModelPath;
using test_util::Quote;
using test_util::RunCommand;
using test_util::RunCommandsInParallel;
using test_util::SourcePath;
using test_util::TempDir;

constexpr size_t kMaxPerCorpus = 150;  // files of a file-format corpus
constexpr size_t kRawSample = 60;      // files of a raw-bytes corpus
constexpr int kWorkers = 2;
constexpr int kTimeoutSeconds = 60;    // per process

// The extensions a corpus's files are fed with.
std::vector<std::string> ExtensionsFor(const std::string& corpus, const std::string& bytes) {
  if (corpus == "gltf") return {bytes.compare(0, 4, "glTF") == 0 ? ".glb" : ".gltf"};
  if (corpus == "progressive_glb") return {".glb"};
  for (const char* format : {"obj", "ply", "off", "stl", "glb"}) {
    if (corpus == format) return {std::string(".") + format};
  }
  return {".glb", ".obj"};  // raw codec bytes: exercise the refusal paths
}

bool IsFormatCorpus(const std::string& corpus) {
  for (const char* format : {"gltf", "progressive_glb", "obj", "ply", "off", "stl", "glb"}) {
    if (corpus == format) return true;
  }
  return false;
}

// Every k-th entry, so that at most `n` are left, in a fixed order.
std::vector<fs::path> Sample(std::vector<fs::path> files, size_t n) {
  std::sort(files.begin(), files.end());
  if (files.size() <= n) return files;
  std::vector<fs::path> out;
  const size_t stride = (files.size() + n - 1) / n;
  for (size_t i = 0; i < files.size(); i += stride) out.push_back(files[i]);
  return out;
}

struct CliRun {
  std::string label;  // what to print when it fails
  std::string command;
};

std::string Timed(const std::string& args) {
  return "timeout -k 5 " + std::to_string(kTimeoutSeconds) + " " + Cli() + " " + args;
}

// The checks every run must pass: a clean exit code, one line on failure.
void ExpectCleanExit(const CliRun& run, const CommandResult& r) {
  EXPECT_TRUE(r.exit_code == 0 || r.exit_code == 1 || r.exit_code == 2)
      << run.label << ": exit " << r.exit_code << (r.exit_code == 124 ? " (timed out)" : "") << "\n" << r.err;
  if (r.exit_code != 0) {
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << run.label << ": stderr\n" << r.err;
  }
  EXPECT_EQ(r.err.find("internal error"), std::string::npos) << run.label << ": " << r.err;
}

void RunAll(const std::vector<CliRun>& runs) {
  const std::vector<CommandResult> results = RunCommandsInParallel(
      [&] {
        std::vector<std::string> commands;
        for (const CliRun& r : runs) commands.push_back(r.command);
        return commands;
      }(),
      kWorkers);
  for (size_t i = 0; i < runs.size(); ++i) ExpectCleanExit(runs[i], results[i]);
}

const char kTetrahedron[] =
    "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"
    "f 1 3 2\nf 1 2 4\nf 2 3 4\nf 1 4 3\n";

TEST(NoSignal, EveryVerbOnEveryCorpusFile) {
  const auto start = std::chrono::steady_clock::now();
  const fs::path corpus_root = SourcePath("tests/fuzz/corpus");
  ASSERT_TRUE(fs::is_directory(corpus_root)) << corpus_root;
  TempDir dir;
  const std::string small = dir.File("small.obj");
  test_util::WriteText(small, kTetrahedron);

  std::vector<CliRun> runs;
  std::map<std::string, size_t> files_per_corpus;
  size_t n = 0;
  for (const fs::directory_entry& corpus : fs::directory_iterator(corpus_root)) {
    if (!corpus.is_directory()) continue;
    const std::string name = corpus.path().filename().string();
    // The service's corpora are gRPC messages, names and page tokens, not
    // files any verb reads (their own replays run them).
    if (name.rfind("service_", 0) == 0) continue;
    std::vector<fs::path> files;
    for (const fs::directory_entry& f : fs::directory_iterator(corpus.path())) {
      if (f.is_regular_file()) files.push_back(f.path());
    }
    // MESHSTREAM_NO_SIGNAL_ALL=1 runs every file (a one-off check before a release).
    const char* all = std::getenv("MESHSTREAM_NO_SIGNAL_ALL");
    if (!(all && std::string(all) == "1")) files = Sample(files, IsFormatCorpus(name) ? kMaxPerCorpus : kRawSample);
    files_per_corpus[name] = files.size();
    for (const fs::path& file : files) {
      const std::string bytes = test_util::ReadText(file.string());
      for (const std::string& ext : ExtensionsFor(name, bytes)) {
        // Files whose name already says what they are run in place (a
        // .gltf's relative URIs still resolve); the others get a copy.
        std::string input = file.string();
        if (file.extension() != ext) {
          input = dir.File(name + "-" + std::to_string(n) + ext);
          test_util::WriteText(input, bytes);
        }
        const std::string out = dir.File("out-" + std::to_string(n++));
        const std::string in = Quote(input);
        const std::string label = name + "/" + file.filename().string() + " as " + ext;
        runs.push_back({label + ": info", Timed("info " + in)});
        runs.push_back({label + ": info --json", Timed("info --json " + in)});
        runs.push_back({label + ": convert", Timed("convert --quiet " + in + " " + Quote(out + ".glb"))});
        runs.push_back({label + ": encode", Timed("encode --levels 4 " + in + " -o " + Quote(out + "-p.glb"))});
        runs.push_back({label + ": compare", Timed("compare --samples 1000 " + in + " " + Quote(small))});
        if (ext == ".glb") {
          runs.push_back({label + ": decode", Timed("decode --loss 0.2 " + in + " -o " + Quote(out + "-d.ply"))});
        }
      }
    }
  }
  ASSERT_GT(files_per_corpus["gltf"], 0u);
  ASSERT_GT(files_per_corpus["progressive_glb"], 0u);
  RunAll(runs);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::string summary;
  for (const auto& [name, count] : files_per_corpus) summary += " " + name + ":" + std::to_string(count);
  std::printf("no-signal: %zu runs on%s files in %.1f s\n", runs.size(), summary.c_str(), seconds);
}

// A file name that is not valid UTF-8 reaches every JSON the CLI writes (its
// own output and the glTF it exports): each verb still succeeds and prints
// valid JSON, with U+FFFD where the bad byte was.
TEST(NoSignal, FileNamesThatAreNotUtf8) {
  TempDir dir;
  const std::string bad = dir.File("bad\xff.obj");
  test_util::WriteText(bad, test_util::ReadText(ModelPath("spot.obj")));
  ASSERT_TRUE(fs::exists(bad));
  const std::string glb = dir.File("out\xfe.glb");
  const std::string progressive = dir.File("prog\xff.glb");
  const std::vector<std::string> commands = {
      "info --json " + Quote(bad),
      "convert " + Quote(bad) + " " + Quote(glb),
      "encode --json --levels 3 " + Quote(bad) + " -o " + Quote(progressive),
      "info --json " + Quote(glb),
      "decode --json " + Quote(progressive) + " -o " + Quote(dir.File("dec\xff.ply")),
      "compare --json --samples 1000 " + Quote(bad) + " " + Quote(glb),
  };
  for (const std::string& args : commands) {
    const CommandResult r = RunCommand(Cli() + " " + args);
    ASSERT_EQ(r.exit_code, 0) << args << "\n" << r.err;
    if (args.find("--json") != std::string::npos) {
      const nlohmann::json j = nlohmann::json::parse(r.out, nullptr, false);
      ASSERT_FALSE(j.is_discarded()) << args << ": not valid JSON (UTF-8): " << r.out;
      EXPECT_NE(r.out.find("\xef\xbf\xbd"), std::string::npos) << args << ": no U+FFFD in " << r.out;
    }
  }
  // The exported glTF names the mesh after the file; its JSON is valid.
  const CommandResult info = RunCommand(Cli() + " info --json " + Quote(glb));
  const nlohmann::json j = nlohmann::json::parse(info.out, nullptr, false);
  ASSERT_FALSE(j.is_discarded());
  ASSERT_FALSE(j["mesh_list"].empty());
  // The validator (node) cannot open a name that is not UTF-8: it reads copies.
  const std::string glb_copy = dir.File("plain.glb"), progressive_copy = dir.File("progressive.glb");
  fs::copy_file(glb, glb_copy);
  fs::copy_file(progressive, progressive_copy);
  for (const nlohmann::json& report : test_util::ValidateGltf({glb_copy, progressive_copy})) {
    EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
  }
}

}  // namespace
}  // namespace meshstream
