// The valid progressive stream that fuzz_split_bits and fuzz_datagram mutate
// one part of: a bumpy UV sphere with normals and one texture coordinate set,
// encoded once per packing with an in-memory base coder that reverses the
// vertex order (no Draco, so the targets stay fast and deterministic), then
// written with WriteStream.
//
// Prepared() returns, per refinement r, a StreamReader that has the base and
// refinements 0..r-1 applied from the real stream, ready for
// BeginRefinement(r); a target copies it and feeds its bytes in place of one
// part of refinement r. Expected(r) is the mesh after refinement r.
//
// Seeds: when MESHSTREAM_FUZZ_SEED_DIR names a folder, the first call writes
// the real control blocks and datagrams there in each target's input format
// (tests/fuzz/make_progressive_corpus.py collects them).
#ifndef MESHSTREAM_TESTS_FUZZ_SPHERE_STREAM_H_
#define MESHSTREAM_TESTS_FUZZ_SPHERE_STREAM_H_

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "codec/mesh/mesh.h"
#include "codec/progressive/encoder.h"
#include "codec/mesh/quantized_mesh.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "codec/loss/reconstructor.h"
#include "tests/common/uv_sphere.h"

namespace meshstream::fuzz {

[[noreturn]] inline void Bug(const char* target, const std::string& what) {
  std::fprintf(stderr, "%s: %s\n", target, what.c_str());
  __builtin_trap();
}

inline Primitive BumpySphere(int rings, int segments) {
  Primitive p;
  p.texcoords.emplace_back();
  auto add = [&p](double theta, double phi) {
    const double r = 1.0 + 0.08 * std::sin(3 * phi) * std::sin(2 * theta);
    const Vec3f n = {float(std::sin(theta) * std::cos(phi)), float(std::sin(theta) * std::sin(phi)),
                     float(std::cos(theta))};
    p.positions.push_back({float(r * n[0]), float(r * n[1]), float(r * n[2])});
    p.normals.push_back(n);
    p.texcoords[0].push_back({float(phi / (2 * M_PI)), float(theta / M_PI)});
  };
  test_util::BuildUvSphere(rings, segments, &p, add);
  return p;
}

// The base as its decoder returns it, in reverse order.
inline StatusOr<EncodedBase> ReversingBaseCoder(const QuantizedMesh& base, int) {
  EncodedBase e;
  e.decoded = base;
  const size_t n = base.vertex_count();
  const size_t ch = static_cast<size_t>(base.layout.channels());
  for (size_t v = 0; v < n; ++v) {
    e.decoded.positions[v] = base.positions[n - 1 - v];
    for (size_t c = 0; c < ch; ++c) e.decoded.attributes[v * ch + c] = base.attributes[(n - 1 - v) * ch + c];
  }
  for (uint32_t& i : e.decoded.indices) i = static_cast<uint32_t>(n - 1 - i);
  e.bytes = {0};
  return e;
}

struct SphereStream {
  ProgressiveStream stream;
  QuantizedMesh base;                  // as the base decoder returned it (for SetBase)
  std::vector<StreamReader> prepared;  // [r]: ready for BeginRefinement(r)
  std::vector<QuantizedMesh> expected; // [r]: the mesh after refinement r
  std::vector<Refinement> refinements; // [r]: what refinement r carries
};

inline void CheckMesh(const char* target, const QuantizedMesh& m, size_t vertices) {
  if (m.vertex_count() != vertices)
    Bug(target, std::to_string(m.vertex_count()) + " vertices after a refinement, expected " + std::to_string(vertices));
  if (m.indices.size() % 3 != 0) Bug(target, "indices are not triangles");
  for (size_t i = 0; i < m.indices.size(); i += 3) {
    const uint32_t a = m.indices[i], b = m.indices[i + 1], c = m.indices[i + 2];
    if (a >= vertices || b >= vertices || c >= vertices) Bug(target, "a triangle refers to a missing vertex");
    if (a == b || b == c || a == c) Bug(target, "a triangle repeats a vertex");
  }
}

inline void WriteSeed(const std::string& dir, const std::string& name, const std::vector<uint8_t>& bytes) {
  const std::string path = dir + "/" + name;
  if (FILE* f = std::fopen(path.c_str(), "wb")) {
    std::fwrite(bytes.data(), 1, bytes.size(), f);
    std::fclose(f);
  }
}

inline bool SameRefinement(const Refinement& a, const Refinement& b) {
  return a.vertices_before == b.vertices_before && a.split_vertices == b.split_vertices && a.wings == b.wings &&
         a.position_delta == b.position_delta && a.attribute_delta == b.attribute_delta;
}

inline SphereStream BuildSphereStream(Packing packing) {
  const char* target = "sphere stream";
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(BumpySphere(10, 14), options, ReversingBaseCoder);
  if (!enc.ok()) Bug(target, "encode: " + enc.status().ToString());
  if (enc->mesh.refinements.size() < 3) Bug(target, "the sphere has fewer than 3 refinements");
  StreamWriteOptions write;
  write.packing = packing;
  write.packet_bytes = 64;  // the smallest: several datagrams per refinement
  auto stream = WriteStream(enc.value(), options.quantization, write);
  if (!stream.ok()) Bug(target, "write: " + stream.status().ToString());
  SphereStream s;
  s.stream = std::move(stream).value();
  s.refinements = enc->mesh.refinements;
  s.base = enc->mesh.base;
  auto reader = StreamReader::Create(s.stream.header.data(), s.stream.header.size());
  if (!reader.ok()) Bug(target, "header: " + reader.status().ToString());
  // The canonical base is what the base decoder returned.
  const Status set = reader->SetBase(enc->mesh.base);
  if (!set.ok()) Bug(target, "base: " + set.ToString());
  for (size_t r = 0; r < s.stream.control.size(); ++r) {
    s.prepared.push_back(reader.value());
    const Status begun = reader->BeginRefinement(s.stream.control[r].data(), s.stream.control[r].size());
    if (!begun.ok()) Bug(target, "begin: " + begun.ToString());
    for (const auto& d : s.stream.datagrams[r])
      if (!reader->OfferDatagram(d.data(), d.size())) Bug(target, "a real datagram was refused");
    const Status finished = reader->FinishRefinement();
    if (!finished.ok()) Bug(target, "finish: " + finished.ToString());
    // What the reader decoded is what the encoder made (CheckLevel relies on it).
    if (!SameRefinement(reader->current(), s.refinements[r])) Bug(target, "the reader decodes another refinement");
    s.expected.push_back(reader->Mesh());
  }
  return s;
}

// [0]: split packing, [1]: bundled.
// A reconstructor of `s` (stream id 0) with `options`, its base set; a Bug
// when the real stream does not take.
inline StreamReconstructor SphereReconstructor(const char* target, const SphereStream& s,
                                               const ReconstructorOptions& options) {
  auto created = StreamReconstructor::Create(s.stream.header.data(), s.stream.header.size(), 0, options);
  if (!created.ok()) Bug(target, "the real header fails: " + created.status().ToString());
  StreamReconstructor rec = std::move(created).value();
  const Status based = rec.SetBase(s.base);
  if (!based.ok()) Bug(target, "the real base fails: " + based.ToString());
  return rec;
}

inline const std::vector<SphereStream>& SphereStreams() {
  static const std::vector<SphereStream> streams = {BuildSphereStream(Packing::kSplit),
                                                    BuildSphereStream(Packing::kBundled)};
  return streams;
}

// After refinement r succeeded: the mesh is well formed, and while the reader
// has decoded exactly the real refinements (`exact`, updated here), it is the
// real mesh.
inline void CheckLevel(const char* target, const SphereStream& s, const StreamReader& reader, size_t r, bool& exact) {
  const QuantizedMesh mesh = reader.Mesh();
  CheckMesh(target, mesh, s.expected[r].vertex_count());
  exact = exact && SameRefinement(reader.current(), s.refinements[r]);
  if (exact && (mesh.positions != s.expected[r].positions || mesh.attributes != s.expected[r].attributes ||
                mesh.indices != s.expected[r].indices)) {
    Bug(target, "the real refinement " + std::to_string(r) + " decoded to a different mesh");
  }
}

// Applies up to kFollowingRefinements refinements from `from` on with the
// real data, checking every level (a few, not all: building the models of
// every refinement would dominate the run time).
constexpr size_t kFollowingRefinements = 2;
inline void FinishWithRealData(const char* target, const SphereStream& s, StreamReader& reader, size_t from,
                               bool exact) {
  const size_t end = std::min(s.stream.control.size(), from + kFollowingRefinements);
  for (size_t r = from; r < end; ++r) {
    if (!reader.BeginRefinement(s.stream.control[r].data(), s.stream.control[r].size()).ok()) return;
    for (const auto& d : s.stream.datagrams[r]) reader.OfferDatagram(d.data(), d.size());
    if (!reader.FinishRefinement().ok()) return;
    CheckLevel(target, s, reader, r, exact);
  }
}

}  // namespace meshstream::fuzz

#endif  // MESHSTREAM_TESTS_FUZZ_SPHERE_STREAM_H_
