// Recovery of lost datagrams on the shared models, through StreamReader
// directly (the simulator and reconstructor have their own tests): whatever
// is lost, prediction keeps the lossless vertex and face counts and adds no
// defect; LwoP keeps fewer vertices and adds no defect; split bits decode
// bit-exactly in every case.
#include <functional>
#include <random>
#include <string>

#include <gtest/gtest.h>

#include "codec/loss/lossy_decode.h"
#include "codec/mesh/mesh_health.h"
#include "codec/progressive/encoder.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

struct Encoded {
  ProgressiveStream stream;
  std::vector<uint8_t> base_bytes;
  DracoAttributeIds ids;
};

Encoded EncodeModel(const std::string& name, Packing packing) {
  auto scene = ImportFile(test_util::ModelPath(name));
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  Encoded out;
  ProgressiveEncodeOptions options;
  auto enc = EncodeProgressive(scene->meshes[0].primitives[0], options, [&](const QuantizedMesh& base, int method) {
    return EncodeDracoBase(base, method, 7, &out.ids);
  });
  EXPECT_TRUE(enc.ok()) << enc.status().ToString();
  StreamWriteOptions wo;
  wo.packing = packing;
  auto stream = WriteStream(enc.value(), options.quantization, wo);
  EXPECT_TRUE(stream.ok()) << stream.status().ToString();
  out.stream = std::move(stream).value();
  out.base_bytes = enc->base_bytes;
  return out;
}

// A decode in which `keep(refinement, datagram)` says which datagrams arrive.
struct Decoded {
  QuantizedMesh mesh;
  std::vector<std::vector<uint32_t>> split_vertices;  // per refinement
  RecoveryStats recovery;
  uint64_t unreliable = 0;
  uint64_t lost = 0;  // datagrams that did not arrive
};

template <typename Keep>
Decoded Decode(const Encoded& e, Recovery recovery, Keep keep) {
  Decoded out;
  auto reader = StreamReader::Create(e.stream.header.data(), e.stream.header.size());
  EXPECT_TRUE(reader.ok());
  auto base = DecodeDracoBase(e.base_bytes.data(), e.base_bytes.size(), e.ids, reader->header().grids);
  EXPECT_TRUE(base.ok());
  EXPECT_TRUE(reader->SetBase(std::move(base).value()).ok());
  for (size_t i = 0; i < e.stream.control.size(); ++i) {
    EXPECT_TRUE(reader->BeginRefinement(e.stream.control[i].data(), e.stream.control[i].size()).ok());
    for (size_t d = 0; d < e.stream.datagrams[i].size(); ++d) {
      if (keep(i, d)) {
        reader->OfferDatagram(e.stream.datagrams[i][d].data(), e.stream.datagrams[i][d].size());
      } else {
        ++out.lost;
      }
    }
    out.split_vertices.push_back(reader->current().split_vertices);
    const Status finished = reader->FinishRefinement(recovery);
    EXPECT_TRUE(finished.ok()) << finished.ToString();
    if (!finished.ok()) break;
  }
  out.mesh = reader->Mesh();
  out.recovery = reader->recovery_stats();
  out.unreliable = reader->unreliable_vertices();
  return out;
}

MeshHealth Health(const QuantizedMesh& m) { return ComputeHealth(DequantizeMesh(m, -1)); }

class Recovery_ : public ::testing::TestWithParam<std::tuple<const char*, Packing>> {};

TEST_P(Recovery_, HundredsOfLossPatternsKeepCountsAndAddNoDefect) {
  const auto [name, packing] = GetParam();
  const Encoded e = EncodeModel(name, packing);
  const Decoded lossless = Decode(e, Recovery::kPredict, [](size_t, size_t) { return true; });
  EXPECT_EQ(lossless.recovery.predicted(), 0u);
  EXPECT_EQ(lossless.unreliable, 0u);
  const MeshHealth clean = Health(lossless.mesh);
  const double rates[] = {0.02, 0.12, 0.3, 0.6};
  uint64_t predicted = 0, abandoned = 0, fallbacks = 0;
  for (int seed = 0; seed < 60; ++seed) {
    const double rate = rates[seed % 4];
    for (Recovery recovery : {Recovery::kPredict, Recovery::kLwop}) {
      std::mt19937_64 rng(seed);
      const Decoded lossy = Decode(e, recovery, [&](size_t, size_t) { return double(rng() >> 11) / 9007199254740992.0 >= rate; });
      const MeshHealth h = Health(lossy.mesh);
      // Split bits are reliable: the same vertices split, whatever was lost.
      ASSERT_EQ(lossy.split_vertices, lossless.split_vertices) << name << " seed " << seed;
      EXPECT_EQ(h.unreferenced_vertices, 0u) << name << " seed " << seed;
      EXPECT_LE(h.degenerate_faces, clean.degenerate_faces) << name << " seed " << seed << " lwop " << (recovery == Recovery::kLwop);
      EXPECT_LE(h.nonmanifold_edges, clean.nonmanifold_edges) << name << " seed " << seed;
      if (recovery == Recovery::kPredict) {
        EXPECT_EQ(lossy.mesh.vertex_count(), lossless.mesh.vertex_count()) << name << " seed " << seed;
        EXPECT_EQ(lossy.mesh.face_count(), lossless.mesh.face_count()) << name << " seed " << seed;
        EXPECT_EQ(lossy.unreliable > 0, lossy.lost > 0) << name << " seed " << seed;
        EXPECT_EQ(lossy.recovery.abandoned, 0u);
        predicted += lossy.recovery.predicted();
        fallbacks += lossy.recovery.structure_fallbacks;
      } else {
        EXPECT_EQ(lossy.mesh.vertex_count() < lossless.mesh.vertex_count(), lossy.lost > 0) << name << " seed " << seed;
        EXPECT_EQ(lossy.recovery.predicted(), 0u);
        abandoned += lossy.recovery.abandoned;
      }
    }
  }
  EXPECT_GT(predicted, 0u);
  EXPECT_GT(abandoned, 0u);
  std::printf("%s %s: %llu splits predicted, %llu abandoned, %llu structures did not fit their ring\n", name,
              packing == Packing::kSplit ? "split" : "bundled", (unsigned long long)predicted,
              (unsigned long long)abandoned, (unsigned long long)fallbacks);
}

TEST_P(Recovery_, LosingEveryDatagramRefinesTheBaseByPredictionAlone) {
  const auto [name, packing] = GetParam();
  const Encoded e = EncodeModel(name, packing);
  const Decoded lossless = Decode(e, Recovery::kPredict, [](size_t, size_t) { return true; });
  const Decoded none = Decode(e, Recovery::kPredict, [](size_t, size_t) { return false; });
  EXPECT_EQ(none.mesh.vertex_count(), lossless.mesh.vertex_count());
  EXPECT_EQ(none.mesh.face_count(), lossless.mesh.face_count());
  auto header = StreamHeader::Parse(e.stream.header.data(), e.stream.header.size());
  ASSERT_TRUE(header.ok());
  EXPECT_EQ(none.recovery.exact, 0u);
  EXPECT_EQ(none.recovery.predicted_both, lossless.mesh.vertex_count() - header->base_vertices);
  const MeshHealth clean = Health(lossless.mesh), h = Health(none.mesh);
  EXPECT_EQ(h.unreferenced_vertices, 0u);
  EXPECT_LE(h.degenerate_faces, clean.degenerate_faces);
  EXPECT_LE(h.nonmanifold_edges, clean.nonmanifold_edges);
  // LwoP with nothing arriving keeps exactly the base.
  const Decoded lwop = Decode(e, Recovery::kLwop, [](size_t, size_t) { return false; });
  EXPECT_EQ(lwop.mesh.vertex_count(), header->base_vertices);
  EXPECT_EQ(lwop.mesh.face_count(), header->base_faces);
}

// The same through the whole client path (simulator, reconstructor, reader):
// loss, bursts, reordering and duplication together, both recoveries.
TEST_P(Recovery_, SimulatedNetworkPatternsKeepCountsAndSplitBits) {
  const auto [name, packing] = GetParam();
  const Encoded e = EncodeModel(name, packing);
  auto header = StreamHeader::Parse(e.stream.header.data(), e.stream.header.size());
  ASSERT_TRUE(header.ok());
  auto base_of = [&]() {
    auto base = DecodeDracoBase(e.base_bytes.data(), e.base_bytes.size(), e.ids, header->grids);
    EXPECT_TRUE(base.ok());
    return std::move(base).value();
  };
  // Per decoded level, the vertex ids in use (kept and never-created alike):
  // ids follow from the split bits alone, so they must match the lossless run.
  auto run = [&](const LossModel& model, Recovery recovery, std::vector<size_t>* ids) {
    LossyDecodeOptions options;
    options.loss = model;
    options.reconstructor.recovery = recovery;
    options.on_level = [&](size_t, const StreamReader& reader) { ids->push_back(reader.state().positions.size()); };
    LossyDecodeReport report;
    auto reader = DecodeStreamLossy(e.stream, 0, base_of(), options, &report);
    EXPECT_TRUE(reader.ok()) << reader.status().ToString();
    return reader.ok() ? reader->Mesh() : QuantizedMesh{};
  };
  std::vector<size_t> lossless_ids;
  const QuantizedMesh lossless = run(LossModel{}, Recovery::kPredict, &lossless_ids);
  ASSERT_EQ(lossless.vertex_count(), header->level_vertices().back());
  const MeshHealth clean = Health(lossless);
  for (int seed = 0; seed < 20; ++seed) {
    LossModel model;
    model.seed = 1000 + seed;
    model.loss = 0.05 * (seed % 5);
    model.burst = seed % 2 ? 3 : 0;
    model.reorder = 0.3;
    model.duplicate = 0.2;
    for (Recovery recovery : {Recovery::kPredict, Recovery::kLwop}) {
      std::vector<size_t> ids;
      const QuantizedMesh m = run(model, recovery, &ids);
      EXPECT_EQ(ids, lossless_ids) << name << " seed " << seed;
      const MeshHealth h = Health(m);
      EXPECT_EQ(h.unreferenced_vertices, 0u) << name << " seed " << seed;
      EXPECT_LE(h.degenerate_faces, clean.degenerate_faces) << name << " seed " << seed;
      EXPECT_LE(h.nonmanifold_edges, clean.nonmanifold_edges) << name << " seed " << seed;
      if (recovery == Recovery::kPredict) {
        EXPECT_EQ(m.vertex_count(), lossless.vertex_count()) << name << " seed " << seed;
        EXPECT_EQ(m.face_count(), lossless.face_count()) << name << " seed " << seed;
      }
      if (model.loss == 0) {
        // Reordering and duplicates alone lose nothing.
        EXPECT_EQ(m.positions, lossless.positions) << name << " seed " << seed;
        EXPECT_EQ(m.indices, lossless.indices) << name << " seed " << seed;
      }
    }
  }
}

// Named patterns: the first datagram, the last, a whole level (first, middle,
// last), every datagram of one kind in a level.
TEST_P(Recovery_, NamedLossPatternsKeepCountsAndAddNoDefect) {
  const auto [name, packing] = GetParam();
  const Encoded e = EncodeModel(name, packing);
  const size_t levels = e.stream.datagrams.size();
  ASSERT_GT(levels, 2u);
  const Decoded lossless = Decode(e, Recovery::kPredict, [](size_t, size_t) { return true; });
  const MeshHealth clean = Health(lossless.mesh);
  const size_t last = levels - 1, middle = levels / 2;
  const std::vector<std::pair<std::string, std::function<bool(size_t, size_t)>>> patterns = {
      {"first datagram", [](size_t i, size_t d) { return !(i == 0 && d == 0); }},
      {"last datagram", [&](size_t i, size_t d) { return !(i == last && d + 1 == e.stream.datagrams[last].size()); }},
      {"first level", [](size_t i, size_t) { return i != 0; }},
      {"middle level", [&](size_t i, size_t) { return i != middle; }},
      {"last level", [&](size_t i, size_t) { return i != last; }},
      {"even datagrams of the middle level", [&](size_t i, size_t d) { return i != middle || d % 2 == 1; }},
  };
  for (const auto& [what, keep] : patterns) {
    for (Recovery recovery : {Recovery::kPredict, Recovery::kLwop}) {
      const Decoded lossy = Decode(e, recovery, keep);
      const MeshHealth h = Health(lossy.mesh);
      EXPECT_EQ(lossy.split_vertices, lossless.split_vertices) << name << ": " << what;
      EXPECT_GT(lossy.lost, 0u) << what;
      EXPECT_EQ(h.unreferenced_vertices, 0u) << name << ": " << what;
      EXPECT_LE(h.degenerate_faces, clean.degenerate_faces) << name << ": " << what;
      EXPECT_LE(h.nonmanifold_edges, clean.nonmanifold_edges) << name << ": " << what;
      if (recovery == Recovery::kPredict) {
        EXPECT_EQ(lossy.mesh.vertex_count(), lossless.mesh.vertex_count()) << name << ": " << what;
        EXPECT_EQ(lossy.mesh.face_count(), lossless.mesh.face_count()) << name << ": " << what;
        EXPECT_GT(lossy.recovery.predicted(), 0u) << name << ": " << what;
      } else {
        EXPECT_LT(lossy.mesh.vertex_count(), lossless.mesh.vertex_count()) << name << ": " << what;
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(SharedModels, Recovery_,
                         ::testing::Values(std::make_tuple("stanford-bunny.obj", Packing::kSplit),
                                           std::make_tuple("stanford-bunny.obj", Packing::kBundled),
                                           std::make_tuple("horse.ply", Packing::kSplit),
                                           std::make_tuple("fandisk.obj", Packing::kSplit),
                                           std::make_tuple("rocker-arm.obj", Packing::kBundled),
                                           std::make_tuple("spot.obj", Packing::kSplit)));

}  // namespace
}  // namespace meshstream
