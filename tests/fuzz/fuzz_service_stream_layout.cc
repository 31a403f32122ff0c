// libFuzzer target for the stream layout (services/pipeline/stream_layout.h):
// the JSON a version stores (ParseStreamLayout, untrusted text) and the walk
// over an artifact's bytes that a streaming session does with it
// (LocateStreamBlocks), plus ComputeStreamLayout, which reads the layout from
// a progressive .glb.
//
// Input: the bytes up to the first NUL are the layout JSON (JSON text holds
// no raw NUL), the bytes after it a .glb (in a buffer of its own size, so
// ASan sees any read past it). No NUL: all of it is JSON and the .glb is empty.
//
// Invariants (a violation stops the fuzzer, __builtin_trap):
//   - ParseStreamLayout and ComputeStreamLayout answer a layout or an
//     InvalidInput, Unsupported or ResourceExhausted with a message, and
//     LocateStreamBlocks a list of blocks or an InvalidInput, DataLoss or
//     ResourceExhausted; nothing else, no crash, no exception;
//   - a parsed layout is consistent (ranges inside file_bytes, one split and
//     datagram count per refinement, one more level vertex count, quantization
//     bits 1..30, at most kMaxRefinements refinements, reliable and unreliable
//     bytes within the stream blob) and StreamLayoutJson of it parses back to
//     the same layout;
//   - every block LocateStreamBlocks returns lies inside the .glb buffer (each
//     byte is read, so ASan checks it too): the base where the layout says,
//     the header, controls and datagrams inside the stream blob, in file
//     order without overlap, one control and the layout's datagram count per
//     refinement;
//   - a layout computed from the .glb has file_bytes equal to its size, streams
//     numbered 0, 1, ... in order, round-trips through its JSON, and locates
//     in that same file, with reliable_bytes = header + controls and
//     unreliable_bytes = the datagrams, as the blocks measure them.
//
// With MESHSTREAM_FUZZ_SEED_DIR set, the first run writes seeds there: small
// progressive .glb files (a bumpy sphere in both packings, a mesh of two
// primitives) encoded by EncodeProgressiveGlb, each with its layout, and
// near misses of both halves.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <initializer_list>
#include <string>
#include <utility>
#include <vector>

#include "codec/bitstream/format.h"
#include "codec/core/status.h"
#include "tests/fuzz/fuzz_service_util.h"
#include "codec/mesh/mesh.h"
#include "importers/progressive_glb.h"
#include "services/pipeline/stream_layout.h"
#include "tests/fuzz/sphere_stream.h"

namespace {

using meshstream::ByteRange;
using meshstream::PrimitiveLayout;
using meshstream::Status;
using meshstream::StatusCode;
using meshstream::StreamBlocks;
using meshstream::StreamLayout;

constexpr char kTarget[] = "fuzz_service_stream_layout";
[[noreturn]] void Bug(const std::string& what) { meshstream::fuzz::FuzzBug(kTarget, what); }
constexpr size_t kMaxInputBytes = size_t{1} << 20;
constexpr size_t kMaxLocated = 64;  // primitives of a parsed layout walked per input

std::string Str(const ByteRange& r) {
  return "[" + std::to_string(r.offset) + ", +" + std::to_string(r.length) + ")";
}

void CheckError(const char* what, const Status& s, std::initializer_list<StatusCode> allowed) {
  if (s.message().empty()) Bug(std::string(what) + " failed without a message: " + s.ToString());
  if (std::find(allowed.begin(), allowed.end(), s.code()) == allowed.end()) {
    Bug(std::string(what) + " failed with an unexpected code: " + s.ToString());
  }
}

bool Inside(const ByteRange& r, uint64_t offset, uint64_t size) {
  return r.offset >= offset && r.offset <= offset + size && r.length <= offset + size - r.offset;
}

bool SamePrimitive(const PrimitiveLayout& a, const PrimitiveLayout& b) {
  return a.mesh == b.mesh && a.primitive == b.primitive && a.stream == b.stream && a.base == b.base &&
         a.stream_blob == b.stream_blob && a.quantization.qp == b.quantization.qp &&
         a.quantization.qn == b.quantization.qn && a.quantization.qt == b.quantization.qt &&
         a.quantization.qc == b.quantization.qc && a.packing == b.packing && a.refinements == b.refinements &&
         a.split_counts == b.split_counts && a.datagram_counts == b.datagram_counts &&
         a.level_vertices == b.level_vertices && a.reliable_bytes == b.reliable_bytes &&
         a.unreliable_bytes == b.unreliable_bytes && a.delivery.share == b.delivery.share &&
         a.delivery.ranking == b.delivery.ranking && a.delivery.reliable == b.delivery.reliable;
}

void CheckRoundTrip(const StreamLayout& layout, const char* from) {
  const std::string json = meshstream::StreamLayoutJson(layout);
  auto back = meshstream::ParseStreamLayout(json);
  if (!back.ok()) Bug(std::string(from) + ": the layout's JSON does not parse: " + back.status().ToString());
  if (back->file_bytes != layout.file_bytes || back->primitives.size() != layout.primitives.size()) {
    Bug(std::string(from) + ": the layout's JSON parses to another layout");
  }
  for (size_t i = 0; i < layout.primitives.size(); ++i) {
    if (!SamePrimitive(back->primitives[i], layout.primitives[i])) {
      Bug(std::string(from) + ": primitive " + std::to_string(i) + " changes through its JSON");
    }
  }
  if (meshstream::StreamLayoutJson(back.value()) != json) Bug(std::string(from) + ": the layout's JSON is not stable");
  if (back->levels() != layout.levels()) Bug(std::string(from) + ": levels() changes through JSON");
}

void CheckConsistent(const StreamLayout& layout) {
  for (size_t i = 0; i < layout.primitives.size(); ++i) {
    const PrimitiveLayout& p = layout.primitives[i];
    const std::string at = "primitives[" + std::to_string(i) + "]";
    if (!Inside(p.base, 0, layout.file_bytes) || !Inside(p.stream_blob, 0, layout.file_bytes)) {
      Bug(at + ": a range " + Str(p.base) + " " + Str(p.stream_blob) + " leaves file_bytes " +
          std::to_string(layout.file_bytes));
    }
    if (p.refinements > meshstream::kMaxRefinements || p.split_counts.size() != p.refinements ||
        p.datagram_counts.size() != p.refinements || p.level_vertices.size() != size_t{p.refinements} + 1) {
      Bug(at + ": the per-refinement arrays do not match refinements");
    }
    for (int q : {p.quantization.qp, p.quantization.qn, p.quantization.qt, p.quantization.qc}) {
      if (q < 1 || q > 30) Bug(at + ": quantization bits " + std::to_string(q));
    }
    if (p.reliable_bytes > p.stream_blob.length || p.unreliable_bytes > p.stream_blob.length) {
      Bug(at + ": reliable or unreliable bytes exceed the stream blob");
    }
    if (p.packing != meshstream::Packing::kSplit && p.packing != meshstream::Packing::kBundled) {
      Bug(at + ": packing is neither split nor bundled");
    }
  }
}

// Every byte of `r`, read from `glb` (so ASan checks the range), folded into `sum`.
void Touch(const std::vector<uint8_t>& glb, const ByteRange& r, const std::string& what, uint32_t* sum) {
  if (!Inside(r, 0, glb.size())) Bug(what + " " + Str(r) + " lies outside the " + std::to_string(glb.size()) + "-byte file");
  const uint8_t* p = glb.data() + r.offset;
  for (uint64_t k = 0; k < r.length; ++k) *sum = *sum * 31 + p[k];
}

// Checks the blocks of `p` and returns header + controls, datagrams (bytes).
std::pair<uint64_t, uint64_t> CheckBlocks(const std::vector<uint8_t>& glb, const PrimitiveLayout& p,
                                          const StreamBlocks& b) {
  uint32_t sum = 0;
  Touch(glb, b.base, "the base", &sum);
  if (!(b.base == p.base)) Bug("the base " + Str(b.base) + " is not where the layout says, " + Str(p.base));
  if (b.control.size() != p.refinements || b.datagrams.size() != p.refinements) {
    Bug("blocks for " + std::to_string(b.control.size()) + " refinements, the layout has " +
        std::to_string(p.refinements));
  }
  uint64_t end = p.stream_blob.offset;  // blocks follow each other in the blob
  auto next = [&](const ByteRange& r, const std::string& what) {
    Touch(glb, r, what, &sum);
    if (!Inside(r, p.stream_blob.offset, p.stream_blob.length)) {
      Bug(what + " " + Str(r) + " lies outside the stream blob " + Str(p.stream_blob));
    }
    if (r.offset < end) Bug(what + " " + Str(r) + " overlaps the block before it (which ends at " + std::to_string(end) + ")");
    end = r.offset + r.length;
  };
  next(b.header, "the header");
  uint64_t reliable = b.header.length, unreliable = 0;
  for (size_t i = 0; i < b.control.size(); ++i) {
    next(b.control[i], "control " + std::to_string(i));
    reliable += b.control[i].length;
    if (b.datagrams[i].size() != p.datagram_counts[i]) {
      Bug("refinement " + std::to_string(i) + ": " + std::to_string(b.datagrams[i].size()) + " datagrams, the layout says " +
          std::to_string(p.datagram_counts[i]));
    }
    for (size_t d = 0; d < b.datagrams[i].size(); ++d) {
      next(b.datagrams[i][d], "datagram " + std::to_string(i) + "." + std::to_string(d));
      unreliable += b.datagrams[i][d].length;
    }
  }
  if (end > p.stream_blob.offset + p.stream_blob.length) Bug("the blocks run past the stream blob");
  volatile uint32_t sink = sum;
  (void)sink;
  return {reliable, unreliable};
}

void CheckParsed(const std::string& text, const std::vector<uint8_t>& glb) {
  auto parsed = meshstream::ParseStreamLayout(text);
  if (!parsed.ok()) {
    CheckError("ParseStreamLayout", parsed.status(),
               {StatusCode::kInvalidInput, StatusCode::kUnsupported, StatusCode::kResourceExhausted});
    return;
  }
  CheckConsistent(parsed.value());
  CheckRoundTrip(parsed.value(), "ParseStreamLayout");
  const size_t n = std::min(parsed->primitives.size(), kMaxLocated);
  for (size_t i = 0; i < n; ++i) {
    const PrimitiveLayout& p = parsed->primitives[i];
    auto blocks = meshstream::LocateStreamBlocks(glb.data(), glb.size(), p);
    if (!blocks.ok()) {
      CheckError("LocateStreamBlocks", blocks.status(),
                 {StatusCode::kInvalidInput, StatusCode::kDataLoss, StatusCode::kResourceExhausted,
                  StatusCode::kUnsupported});
      continue;
    }
    CheckBlocks(glb, p, blocks.value());
  }
}

void CheckComputed(const std::vector<uint8_t>& glb) {
  auto computed = meshstream::ComputeStreamLayout(glb.data(), glb.size());
  if (!computed.ok()) {
    CheckError("ComputeStreamLayout", computed.status(),
               {StatusCode::kInvalidInput, StatusCode::kUnsupported, StatusCode::kResourceExhausted});
    return;
  }
  const StreamLayout& layout = computed.value();
  if (layout.file_bytes != glb.size()) Bug("a computed layout's file_bytes is not the file's size");
  CheckConsistent(layout);
  CheckRoundTrip(layout, "ComputeStreamLayout");
  for (size_t i = 0; i < layout.primitives.size(); ++i) {
    const PrimitiveLayout& p = layout.primitives[i];
    if (p.stream != i) Bug("computed streams are not numbered in order");
    auto blocks = meshstream::LocateStreamBlocks(glb.data(), glb.size(), p);
    if (!blocks.ok()) Bug("a layout computed from a file does not locate in it: " + blocks.status().ToString());
    const auto [reliable, unreliable] = CheckBlocks(glb, p, blocks.value());
    if (reliable != p.reliable_bytes || unreliable != p.unreliable_bytes) {
      Bug("stream " + std::to_string(i) + ": the layout says " + std::to_string(p.reliable_bytes) + " reliable and " +
          std::to_string(p.unreliable_bytes) + " unreliable bytes, the blocks measure " + std::to_string(reliable) +
          " and " + std::to_string(unreliable));
    }
  }
}

void WriteSeeds();

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const bool seeded = (WriteSeeds(), true);
  (void)seeded;
  if (size > kMaxInputBytes) return 0;
  const uint8_t* nul = static_cast<const uint8_t*>(std::memchr(data, 0, size));
  const size_t text_size = nul == nullptr ? size : static_cast<size_t>(nul - data);
  const std::string text(reinterpret_cast<const char*>(data), text_size);
  const std::vector<uint8_t> glb(nul == nullptr ? data + size : nul + 1, data + size);
  CheckParsed(text, glb);
  CheckComputed(glb);
  return 0;
}

namespace {

void WriteSeed(const std::string& dir, const std::string& name, const std::string& text,
               const std::vector<uint8_t>& glb, bool separator = true) {
  std::vector<uint8_t> seed(text.begin(), text.end());
  if (separator) seed.push_back(0);
  seed.insert(seed.end(), glb.begin(), glb.end());
  meshstream::fuzz::WriteSeed(dir, name, seed);
}

meshstream::Scene SceneOf(std::vector<meshstream::Primitive> primitives) {
  meshstream::Scene scene;
  scene.meshes.emplace_back();
  scene.meshes[0].name = "fuzz";
  scene.meshes[0].primitives = std::move(primitives);
  scene.nodes.emplace_back();
  scene.nodes[0].mesh = 0;
  scene.scenes.push_back(meshstream::SceneRoot{"", {0}, ""});
  scene.default_scene = 0;
  return scene;
}

void WriteSeeds() {
  const char* env = std::getenv("MESHSTREAM_FUZZ_SEED_DIR");
  if (env == nullptr) return;
  const std::string dir = env;
  struct Case {
    std::string name;
    meshstream::Scene scene;
    meshstream::Packing packing;
  };
  meshstream::Primitive small = meshstream::fuzz::BumpySphere(6, 8);
  meshstream::Primitive other = meshstream::fuzz::BumpySphere(5, 7);
  for (auto& v : other.positions) v[0] += 3.0f;
  std::vector<Case> cases;
  cases.push_back({"sphere-split", SceneOf({small}), meshstream::Packing::kSplit});
  cases.push_back({"sphere-bundled", SceneOf({small}), meshstream::Packing::kBundled});
  cases.push_back({"two-primitives", SceneOf({small, other}), meshstream::Packing::kSplit});
  for (const Case& c : cases) {
    meshstream::ProgressiveGlbOptions options;
    options.stream.packing = c.packing;
    options.stream.packet_bytes = 256;
    auto glb = meshstream::EncodeProgressiveGlb(c.scene, options, nullptr);
    if (!glb.ok()) Bug("seed " + c.name + ": " + glb.status().ToString());
    auto layout = meshstream::ComputeStreamLayout(glb->data(), glb->size());
    if (!layout.ok() || layout->primitives.empty()) Bug("seed " + c.name + ": no layout");
    const std::string json = meshstream::StreamLayoutJson(layout.value());
    WriteSeed(dir, c.name, json, glb.value());
    if (c.name != "sphere-split") continue;
    // Near misses: the layout alone, the file alone, a truncated file, a
    // layout that belongs to another file, one whose counts are off.
    WriteSeed(dir, c.name + "-layout-only", json, {}, false);
    WriteSeed(dir, c.name + "-file-only", "", glb.value());
    std::vector<uint8_t> cut(glb->begin(), glb->begin() + static_cast<long>(glb->size() * 3 / 4));
    WriteSeed(dir, c.name + "-truncated", json, cut);
    StreamLayout shifted = layout.value();
    shifted.primitives[0].stream_blob.offset -= 1;
    WriteSeed(dir, c.name + "-shifted", meshstream::StreamLayoutJson(shifted), glb.value());
    StreamLayout recounted = layout.value();
    if (!recounted.primitives[0].datagram_counts.empty()) recounted.primitives[0].datagram_counts[0] += 1;
    WriteSeed(dir, c.name + "-recounted", meshstream::StreamLayoutJson(recounted), glb.value());
    StreamLayout fewer = layout.value();
    if (fewer.primitives[0].refinements > 0) {
      fewer.primitives[0].refinements -= 1;
      fewer.primitives[0].split_counts.pop_back();
      fewer.primitives[0].datagram_counts.pop_back();
      fewer.primitives[0].level_vertices.pop_back();
    }
    WriteSeed(dir, c.name + "-fewer-refinements", meshstream::StreamLayoutJson(fewer), glb.value());
  }
  WriteSeed(dir, "json-version-2", R"({"version":2,"file_bytes":0,"primitives":[]})", {}, false);
  WriteSeed(dir, "json-empty-layout", R"({"version":1,"file_bytes":0,"primitives":[]})", {}, false);
  WriteSeed(dir, "json-huge-range",
            R"({"version":1,"file_bytes":18446744073709551615,"primitives":[{"mesh":0,"primitive":0,"stream":0,)"
            R"("base":{"offset":18446744073709551615,"length":0},"stream_blob":{"offset":0,"length":18446744073709551615},)"
            R"("quantization":{"qp":11,"qn":8,"qt":10,"qc":8},"packing":"split","refinements":0,"split_counts":[],)"
            R"("datagram_counts":[],"level_vertices":[4],"reliable_bytes":0,"unreliable_bytes":0}]})",
            {'M', 'S', 'P', 'S', 1, 0, 0});
}

}  // namespace
