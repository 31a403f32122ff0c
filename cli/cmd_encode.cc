// meshstream encode IN -o OUT.glb [options]
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "cli/json_out.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/bitstream/format.h"
#include "codec/mesh/quantization.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "parallel/fork_join_pool.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "IN is .gltf .glb .obj .ply .off .stl. The base mesh goes under\n"
    "KHR_draco_mesh_compression (any glTF viewer shows it), the refinements into the\n"
    "MESHSTREAM_progressive extension (docs/spec/progressive-format.md). --packing split keeps\n"
    "structure and geometry in separate datagrams; bundled puts one fragment per split.\n"
    "\n"
    "Example:\n"
    "  meshstream encode --json --qp 14 --packet-bytes 1200 bunny.obj -o bunny.glb";

struct EncodeArgs {
  std::string in, out;
  ProgressiveGlbOptions options;
  int levels = 0;
  int format_version = kStreamVersion;
  std::string packing = "split";
  std::string profile = "reliable";
  std::string batch_rule = "strict";
  std::string tools = "default";
  bool json = false;
  bool profile_given = false;
  int threads = 0;
};

// --tools: "default", "all", "none" or names of kToolNames; an unknown name
// is an error that lists the known ones, and so is a name the format
// `version` does not define ("all" is every tool of the version, "default"
// the measured defaults of codec/progressive/coding_tools.h, kAllTools).
StatusOr<ToolSet> ParseTools(const std::string& list_of_names, uint8_t version) {
  ToolSet tools = 0;
  std::vector<std::string> names;
  for (size_t at = 0;;) {
    const size_t comma = list_of_names.find(',', at);
    names.push_back(list_of_names.substr(at, comma == std::string::npos ? std::string::npos : comma - at));
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  for (const std::string& n : names) {
    if (n == "all") {
      tools |= DefinedTools(version);
      continue;
    }
    if (n == "default") {
      tools |= kAllTools & DefinedTools(version);
      continue;
    }
    if (n == "none") continue;
    bool known = false;
    for (const ToolName& t : kToolNames) {
      if (n == t.name) {
        if ((DefinedTools(version) & t.tool) == 0) {
          uint8_t needs = version;
          while (needs < kStreamVersion && (DefinedTools(needs) & t.tool) == 0) ++needs;
          return InvalidArgument("--tools: " + n + " is not a tool of format version " + std::to_string(version) +
                                 (version >= 2 ? " (it needs --format-version " + std::to_string(needs) + ")"
                                               : " (version 1 has no tools)"));
        }
        tools |= t.tool;
        known = true;
      }
    }
    if (!known) {
      std::string list = "default, all, none";
      for (const ToolName& t : kToolNames) list += std::string(", ") + t.name;
      return InvalidArgument("--tools: unknown tool '" + n + "' (known: " + list + ")");
    }
  }
  return tools;
}

int RunEncode(EncodeArgs& args) {
  const std::string& out = args.out;
  if (FileExtension(out) != ".glb") return ReportError("encode", InvalidArgument(out + ": the progressive file must be a .glb"));
  ProgressiveGlbOptions& options = args.options;
  const QuantizationParams& q = options.encode.quantization;
  const std::string& packing = args.packing;
  options.encode.simplify.max_levels = static_cast<uint32_t>(args.levels);
  options.stream.version = static_cast<uint8_t>(args.format_version);
  options.stream.packing = packing == "split" ? Packing::kSplit : Packing::kBundled;
  // The reliable profile is version 4's default; an older version is loss-tolerant.
  if (options.stream.version < 4) {
    if (args.profile_given && args.profile != "loss-tolerant") {
      return ReportError("encode", InvalidArgument("--profile " + args.profile + " needs --format-version 4"));
    }
    options.profiles = ProfileSet::kLossTolerant;
  } else {
    options.profiles = args.profile == "both"       ? ProfileSet::kBoth
                       : args.profile == "reliable" ? ProfileSet::kReliable
                                                    : ProfileSet::kLossTolerant;
  }
  options.reliable_rule = args.batch_rule == "strict" ? BatchRule::kStrict : BatchRule::kMatching;
  if (args.batch_rule == "matching" && options.profiles != ProfileSet::kReliable) {
    return ReportError("encode", InvalidArgument("--batch-rule matching: only for --profile reliable (the "
                                                 "loss-tolerant profile needs the strict rule)"));
  }
  auto tools = ParseTools(args.tools, options.stream.version);
  if (!tools.ok()) return ReportError("encode", tools.status());
  options.stream.tools = tools.value();
  const bool json_out = args.json;
  if (!json_out && isatty(STDERR_FILENO)) {
    options.progress = [](size_t primitive, int batch, size_t left) {
      std::fprintf(stderr, "\rencoding primitive %zu: refinement %d, %zu vertices left   ", primitive, batch, left);
      std::fflush(stderr);
    };
  }

  const std::string& in = args.in;
  auto scene = ImportFile(in);
  if (!scene.ok()) return ReportError("encode", scene.status());

  // Streams (primitives, spatial parts) encode at once on these workers; the
  // file does not depend on their count. The pool starts outside the timing.
  const int threads = args.threads == 0 ? ForkJoinPool::HardwareWorkers() : args.threads;
  std::unique_ptr<ForkJoinPool> pool;
  if (threads > 1) {
    pool = std::make_unique<ForkJoinPool>(threads);
    options.runner = pool.get();
  }

  const auto start = std::chrono::steady_clock::now();
  ProgressiveGlbReport report;
  // The refined primitives' float arrays are dropped as each is quantized
  // (the encoder's peak memory; the warnings below are kept).
  auto glb = EncodeProgressiveGlbReleasing(&scene.value(), options, &report);
  const double encode_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (options.progress) std::fputs("\r\033[K", stderr);
  if (!glb.ok()) return ReportError("encode", glb.status().WithContext(in));
  const Status written = WriteFileBytes(out, glb.value());
  if (!written.ok()) return ReportError("encode", written);
  // The warnings only on success, so that a failure is one line.
  for (const std::string& w : scene->warnings) std::fprintf(stderr, "meshstream encode: warning: %s: %s\n", in.c_str(), w.c_str());

  const PrimitiveStreamReport total = report.Total();
  const uint64_t vertices = total.vertices, faces = total.faces, base_bytes = total.base_bytes,
                 reliable = total.base_bytes + total.reliable_bytes, unreliable = total.unreliable_bytes,
                 datagrams = total.datagrams, removed = total.removed_faces;
  const std::vector<uint32_t>& level_vertices = total.level_vertices;
  // level_bytes: the file's bytes up to each level (its container, JSON and
  // carried data counted at the base: a client reads them first).
  // With both profiles, each profile's levels count its own stream (the
  // other's bytes are not read by a client of this one).
  std::vector<uint64_t> level_bytes = total.level_bytes, reliable_level_bytes = total.reliable_level_bytes;
  const uint64_t streams = (level_bytes.empty() ? 0 : level_bytes.back()) + total.reliable_profile_bytes;
  const uint64_t container = report.file_bytes > streams ? report.file_bytes - streams : 0;
  for (uint64_t& b : level_bytes) b += container;
  for (uint64_t& b : reliable_level_bytes) b += container;
  const double v = vertices ? static_cast<double>(vertices) : 1.0;
  nlohmann::json j = {
      {"input", Utf8(in)},
      {"output", Utf8(out)},
      {"vertices", vertices},
      {"faces", faces},
      {"primitives", report.primitives.size()},  // streams: a spatial part counts as one
      {"part_vertices", options.part_vertices},
      {"threads", threads},
      {"levels", level_vertices.empty() ? 0 : level_vertices.size() - 1},
      {"level_vertices", level_vertices},
      {"base_vertices", level_vertices.empty() ? 0 : level_vertices.front()},
      {"base_bytes", base_bytes},
      {"reliable_bytes", reliable},
      {"unreliable_bytes", unreliable},
      {"datagrams", datagrams},
      {"reliable_share", options.reliable_share},
      {"reliable_cut_bytes", total.reliable_cut_bytes},
      {"total_bytes", reliable + unreliable},
      {"file_bytes", report.file_bytes},
      {"reliable_bpv", 8.0 * reliable / v},
      {"unreliable_bpv", 8.0 * unreliable / v},
      {"total_bpv", 8.0 * (reliable + unreliable) / v},
      {"removed_faces", removed},
      {"packing", packing},
      {"packet_bytes", options.stream.packet_bytes},
      {"format_version", options.stream.version},
      {"profile", options.profiles == ProfileSet::kBoth       ? "both"
                  : options.profiles == ProfileSet::kReliable ? "reliable"
                                                              : "loss-tolerant"},
      {"level_bytes", level_bytes},
      {"reliable_level_bytes", reliable_level_bytes},
      {"tools", ToolNamesOf(total.tools)},
      {"qp", q.qp},
      {"encode_ms", encode_ms},
      // What each step of the encoding took (docs/spec/cli.md): the rest of
      // encode_ms is reading, quantizing and writing the file.
      {"step_ms",
       {{"hierarchy", total.hierarchy_ms}, {"stream", total.stream_ms}, {"harm", total.harm_ms},
        {"delivery", total.delivery_ms}}},
  };
  if (json_out) {
    PrintJson(j);
  } else {
    std::printf("%s -> %s: %llu vertices in %zu levels (base %u), %llu bytes (%.2f bits/vertex: %.2f reliable, %.2f in %llu datagrams), %.0f ms\n",
                in.c_str(), out.c_str(), static_cast<unsigned long long>(vertices),
                level_vertices.empty() ? 0 : level_vertices.size() - 1, level_vertices.empty() ? 0u : level_vertices.front(),
                static_cast<unsigned long long>(reliable + unreliable), 8.0 * (reliable + unreliable) / v,
                8.0 * reliable / v, 8.0 * unreliable / v, static_cast<unsigned long long>(datagrams), encode_ms);
  }
  return kExitOk;
}

}  // namespace

Verb AddEncode(CLI::App& root) {
  auto args = std::make_shared<EncodeArgs>();
  CLI::App* cmd = AddVerb(root, "encode",
                          "Encodes every primitive of a mesh or scene into a progressive .glb (base mesh + refinements).",
                          kDetails);
  ProgressiveGlbOptions& o = args->options;
  QuantizationParams& q = o.encode.quantization;
  args->levels = static_cast<int>(o.encode.simplify.max_levels);
  cmd->add_option("IN", args->in, "the input file")->required();
  cmd->add_option("-o,--output", args->out, "the progressive file, .glb")->required();
  // The encoding settings are what an ingesting server is configured with:
  // each may come from MESHSTREAM_<NAME> (docs/spec/cli.md).
  const int max_bits = kMaxQuantizationBits;
  FromEnv(cmd->add_option("--qp", q.qp, "position quantization bits")->check(CLI::Range(kMinQuantizationBits, max_bits)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--qn", q.qn, "normal quantization bits")->check(CLI::Range(2, 15)))->capture_default_str();
  FromEnv(cmd->add_option("--qt", q.qt, "texture coordinate bits")->check(CLI::Range(kMinQuantizationBits, max_bits)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--qc", q.qc, "colour bits")->check(CLI::Range(kMinQuantizationBits, 16)))->capture_default_str();
  FromEnv(cmd->add_option("--levels", args->levels, "at most N refinements")
              ->check(CLI::Range(0, static_cast<int>(kMaxRefinements))))
      ->capture_default_str();
  FromEnv(cmd->add_option("--base-ratio", o.encode.simplify.base_ratio, "stop simplifying at this fraction of the vertices")
              ->check(NumberIn(1e-6, 1.0)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--packing", args->packing, "split or bundled (the loss-tolerant profile's datagrams)")
              ->check(CLI::IsMember({"split", "bundled"})))
      ->capture_default_str();
  CLI::Option* profile =
      cmd->add_option("--profile", args->profile,
                      "reliable (files, HTTP, WebSocket and gRPC-only sessions: smaller, faster to decode), "
                      "loss-tolerant (UDP sessions: datagrams that decode on their own), or both in one file (what "
                      "the server stores); docs/spec/progressive-format.md")
          ->check(CLI::IsMember({"reliable", "loss-tolerant", "both"}));
  FromEnv(profile)->capture_default_str();
  profile->each([args](const std::string&) { args->profile_given = true; });
  FromEnv(cmd->add_option("--batch-rule", args->batch_rule,
                          "the batch rule of --profile reliable: strict (the loss-tolerant profile's hierarchy; "
                          "smaller on most meshes) or matching (fuller batches, fewer levels; docs/design/codec.md)")
              ->check(CLI::IsMember({"matching", "strict"})))
      ->capture_default_str();
  FromEnv(cmd->add_option("--packet-bytes", o.stream.packet_bytes, "datagram payload limit, header included")
              ->check(CLI::Range(kMinPacketBytes, kMaxPacketBytes)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--format-version", args->format_version,
                          "progressive format version: 4, or 3, 2 or 1 for decoders that predate it (larger "
                          "streams, loss-tolerant only; an older version drops the tools it does not define)")
              ->check(CLI::Range(static_cast<int>(kOldestStreamVersion), static_cast<int>(kStreamVersion))))
      ->capture_default_str();
  FromEnv(cmd->add_option("--tools", args->tools,
                          "coding tools, comma-separated: default (the measured defaults), all, none, geometry, "
                          "frame, rank, normals, texcoords, seams (version 2 and later), splitbits, models, predictor "
                          "(version 3), crossings (version 4) (docs/design/codec.md; fewer tools, larger stream)")
              ->capture_default_str());
  FromEnv(cmd->add_option("--ring-term-bits", o.stream.ring_term_bits,
                          "bits per split the predictor's 2-ring term must save before a refinement uses it (it "
                          "costs the decoder about 15 % more time; 0: wherever it saves; docs/design/codec.md)")
              ->check(NumberIn(0, 64)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--reliable-share", o.reliable_share,
                          "share of each stream's bytes whose refinements a session sends reliably, the most "
                          "important per byte first (docs/design/loss-tolerance.md; 0: none)")
              ->check(NumberIn(0, 1)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--cl", o.draco_compression_level, "Draco compression level of the base mesh")
              ->check(CLI::Range(0, 10)))
      ->capture_default_str();
  FromEnv(cmd->add_option("--part-vertices", o.part_vertices,
                          "cut a primitive of more vertices than this into spatial parts, each a stream of its own "
                          "that decodes on its own core (0: never; docs/design/codec.md, \"Spatial parts\")"))
      ->capture_default_str();
  cmd->add_option("--threads", args->threads,
                  "threads that encode streams (primitives and parts) at once (0: one per core; the file does not "
                  "change)")
      ->check(CLI::Range(0, ForkJoinPool::kMaxWorkers))
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "print one JSON object with sizes and timings");
  return {cmd, [args] { return RunEncode(*args); }};
}

}  // namespace meshstream::cli
