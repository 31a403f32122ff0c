// The progressive encoder on the shared models, with Draco coding the base
// mesh: decoding every level without loss gives back the quantized input.
#include <chrono>

#include <gtest/gtest.h>

#include "codec/metrics/grid_equality.h"
#include "codec/progressive/encoder.h"
#include "codec/bitstream/reader.h"
#include "codec/bitstream/writer.h"
#include "importers/draco_base_coder.h"
#include "importers/import.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ModelPath;

Primitive Load(const std::string& name) {
  auto scene = ImportFile(ModelPath(name));
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  return scene.ok() ? scene->meshes[0].primitives[0] : Primitive{};
}

TEST(ProgressiveDraco, EverySharedModelIsLosslessAtQp11And14) {
  for (const char* name : {"stanford-bunny.obj", "horse.ply", "fandisk.obj", "rocker-arm.obj", "spot.obj"}) {
    const Primitive input = Load(name);
    for (int qp : {11, 14}) {
      ProgressiveEncodeOptions options;
      options.quantization.qp = qp;
      const auto start = std::chrono::steady_clock::now();
      auto enc = EncodeProgressive(input, options, DracoBaseEncoder(7));
      const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
      ASSERT_TRUE(enc.ok()) << name << " qp " << qp << ": " << enc.status().ToString();
      const auto levels = enc->mesh.level_vertices();
      RefinementState state;
      ASSERT_TRUE(state.Reset(enc->mesh.base).ok());
      for (const Refinement& r : enc->mesh.refinements) ASSERT_TRUE(state.ApplyRefinement(r).ok());
      const Primitive decoded = DequantizeMesh(state.Snapshot(enc->mesh.base), -1);
      auto same = CompareOnGrid(input, decoded, qp);
      ASSERT_TRUE(same.ok());
      EXPECT_TRUE(same->equal) << name << " qp " << qp << ": " << same->differing() << " triangles differ";
      EXPECT_EQ(decoded.vertex_count(), enc->input_vertices);
      std::printf("%s qp %d: %zu levels, base %u of %u vertices, base %zu bytes, method %d, %llu locked, %.0f ms\n",
                  name, qp, enc->mesh.refinements.size(), levels.front(), levels.back(), enc->base_bytes.size(),
                  enc->base_method, static_cast<unsigned long long>(enc->locked_vertices), ms);
    }
  }
}

// Encode, write the stream, parse it back, decode through StreamReader with
// Draco decoding the base: the quantized input comes back, on every shared
// model at qp 11 and 14, in both packings, with every coding tool of version
// 3, with each tool left out, some alone, as version 4 with every tool it
// defines, and as versions 2 and 1.
TEST(ProgressiveDraco, StreamRoundTripIsLosslessInBothPackingsWithEveryTool) {
  struct Variant {
    uint8_t version;
    ToolSet tools;
  };
  const Variant variants[] = {{3, kAllTools},
                              // Version 4 with every tool it defines (the crossings' order of ranks).
                              {4, kVersion4Tools},
                              {3, kAllTools & ~kToolGeometryPrediction},
                              {3, kAllTools & ~kToolLocalFrame},
                              {3, kAllTools & ~kToolWingRank},
                              {3, kAllTools & ~kToolAttributePrediction},
                              {3, kAllTools & ~kToolTexcoordPrediction},
                              {3, kAllTools & ~kToolSeams},
                              {3, kAllTools & ~kToolSplitContexts},
                              {3, kAllTools & ~kToolModelModes},
                              // Each tool alone too: a tool must not rely on
                              // work another one does (the ring's frame).
                              {3, kToolGeometryPrediction},
                              {3, kToolTexcoordPrediction},
                              {3, kToolAttributePrediction},
                              {3, kToolSeams},
                              {3, kToolSplitContexts},
                              {3, kToolModelModes},
                              {3, 0},
                              // Version 2 carries the tools it defines (asked for all of them).
                              {2, kAllTools},
                              {2, 0},
                              {1, 0}};
  for (const char* name : {"stanford-bunny.obj", "horse.ply", "fandisk.obj", "rocker-arm.obj", "spot.obj"}) {
    const Primitive input = Load(name);
    for (int qp : {11, 14}) {
      ProgressiveEncodeOptions options;
      options.quantization.qp = qp;
      // Two hierarchies: seams collapsed (for the variants with the seams
      // tool, as `meshstream encode` does) and kept.
      DracoAttributeIds ids[2];
      StatusOr<ProgressiveEncoded> encodings[2] = {Internal("unset"), Internal("unset")};
      for (int seams = 0; seams < 2; ++seams) {
        ProgressiveEncodeOptions o = options;
        o.simplify.collapse_seams = seams == 1;
        encodings[seams] = EncodeProgressive(input, o, [&](const QuantizedMesh& base, int method) {
          return EncodeDracoBase(base, method, 7, &ids[seams]);
        });
        ASSERT_TRUE(encodings[seams].ok()) << encodings[seams].status().ToString();
      }
      for (Packing packing : {Packing::kSplit, Packing::kBundled}) {
        for (const Variant& variant : variants) {
          const int seams = variant.version >= 2 && (variant.tools & kToolSeams) != 0 ? 1 : 0;
          const StatusOr<ProgressiveEncoded>& enc = encodings[seams];
          // The default (all tools) in both packings; the other variants in the split packing.
          if (packing == Packing::kBundled && variant.tools != kAllTools) continue;
          const std::string what = std::string(name) + " qp " + std::to_string(qp) +
                                   (packing == Packing::kSplit ? " split" : " bundled") + " version " +
                                   std::to_string(variant.version) + " tools " + std::to_string(variant.tools);
          StreamWriteOptions wo;
          wo.packing = packing;
          wo.version = variant.version;
          wo.tools = variant.tools;
          auto stream = WriteStream(enc.value(), options.quantization, wo);
          ASSERT_TRUE(stream.ok()) << what << ": " << stream.status().ToString();
          for (const auto& level : stream->datagrams)
            for (const auto& d : level) EXPECT_LE(d.size(), wo.packet_bytes) << what;
          const std::vector<uint8_t> blob = stream->Serialize();
          auto parsed = ProgressiveStream::Parse(blob.data(), blob.size());
          ASSERT_TRUE(parsed.ok()) << what << ": " << parsed.status().ToString();
          EXPECT_EQ(parsed->version, variant.version) << what;

          auto reader = StreamReader::Create(parsed->header.data(), parsed->header.size());
          ASSERT_TRUE(reader.ok()) << what << ": " << reader.status().ToString();
          // The texture coordinate tool only where there are texture coordinates or colours.
          // Seams only where the mesh has them (spot's UV seams).
          ToolSet tools = ApplicableTools(variant.tools & DefinedTools(variant.version), options.quantization,
                                          enc->mesh.base.layout);
          if (enc->mesh.base_twins.empty()) tools &= static_cast<ToolSet>(~kToolSeams);
          if (std::string(name) == "spot.obj" && seams == 1) {
            EXPECT_NE(tools & kToolSeams, 0) << what;
          }
          EXPECT_EQ(reader->header().tools, tools) << what;
          if (std::string(name) == "spot.obj" && variant.version >= 2) {
            EXPECT_EQ((tools & kToolTexcoordPrediction) != 0, (variant.tools & kToolTexcoordPrediction) != 0) << what;
          }
          auto base = DecodeDracoBase(enc->base_bytes.data(), enc->base_bytes.size(), ids[seams], reader->header().grids);
          ASSERT_TRUE(base.ok()) << base.status().ToString();
          ASSERT_TRUE(reader->SetBase(std::move(base).value()).ok());
          for (size_t i = 0; i < parsed->control.size(); ++i) {
            ASSERT_TRUE(reader->BeginRefinement(parsed->control[i].data(), parsed->control[i].size()).ok()) << what;
            // Offer the datagrams backwards and twice: order and duplicates do not matter.
            for (size_t d = parsed->datagrams[i].size(); d-- > 0;) {
              EXPECT_TRUE(reader->OfferDatagram(parsed->datagrams[i][d].data(), parsed->datagrams[i][d].size()));
              reader->OfferDatagram(parsed->datagrams[i][d].data(), parsed->datagrams[i][d].size());
            }
            auto finished = reader->FinishRefinement();
            ASSERT_TRUE(finished.ok()) << what << ": " << finished.ToString();
            // What the reader applied is the encoder's refinement (split vectors and wings as in memory).
            const Refinement& got = reader->current();
            const Refinement& want = enc->mesh.refinements[i];
            ASSERT_EQ(got.position_delta, want.position_delta) << what << " refinement " << i;
            ASSERT_EQ(got.wings, want.wings) << what << " refinement " << i;
            ASSERT_EQ(got.attribute_delta, want.attribute_delta) << what << " refinement " << i;
          }
          EXPECT_EQ(reader->stats().duplicates, stream->datagram_count()) << what;
          EXPECT_EQ(reader->recovery_stats().predicted(), 0u) << what;
          const Primitive decoded = DequantizeMesh(reader->Mesh(), -1);
          auto same = CompareOnGrid(input, decoded, qp);
          ASSERT_TRUE(same.ok());
          EXPECT_TRUE(same->equal) << what << ": " << same->differing() << " triangles differ";
          const double v = static_cast<double>(enc->input_vertices);
          std::printf("%s: base %zu B, reliable %zu B, unreliable %zu B in %zu datagrams, total %.2f bpv\n",
                      what.c_str(), enc->base_bytes.size(), stream->reliable_bytes(), stream->unreliable_bytes(),
                      stream->datagram_count(), 8.0 * (blob.size() + enc->base_bytes.size()) / v);
        }
      }
    }
  }
}

}  // namespace
}  // namespace meshstream
