// The pipeline on the shared models: ProcessSource gives the figures the
// encoder reports (as `meshstream encode --json` prints them), a layout
// whose spans are the stream's own blocks, and artifacts that export in
// every format; a file that is not a mesh fails with the importer's message.
#include "services/pipeline/process_source.h"

#include <algorithm>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "codec/bitstream/format.h"
#include "codec/metrics/grid_equality.h"
#include "importers/import.h"
#include "importers/progressive_glb.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/export_artifact.h"
#include "services/pipeline/stream_layout.h"
#include "services/store/blob_store.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ModelPath;
using test_util::TempDir;

EncodeSettings Resolved(EncodeSettings s = {}) {
  auto r = ResolveSettings(s);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? r.value() : DefaultSettings();
}

struct Processed {
  ProcessResult result;
  std::vector<std::pair<double, std::string>> progress;
};

Processed MustProcess(const std::string& path, const EncodeSettings& settings) {
  Processed p;
  auto r = ProcessSource(path, settings, [&](double v, const std::string& stage) { p.progress.emplace_back(v, stage); });
  EXPECT_TRUE(r.ok()) << path << ": " << r.status().ToString();
  if (r.ok()) p.result = std::move(r).value();
  return p;
}

// What `meshstream encode --json` computes: the encoder run directly.
struct Direct {
  std::vector<uint8_t> glb;
  ProgressiveGlbReport report;
};

Direct EncodeDirectly(const std::string& path, const EncodeSettings& settings) {
  Direct d;
  auto scene = ImportFile(path);
  EXPECT_TRUE(scene.ok()) << scene.status().ToString();
  if (!scene.ok()) return d;
  auto glb = EncodeProgressiveGlb(scene.value(), ToGlbOptions(settings), &d.report);
  EXPECT_TRUE(glb.ok()) << glb.status().ToString();
  if (glb.ok()) d.glb = std::move(glb).value();
  return d;
}

StatusOr<Scene> ImportBytes(const std::vector<uint8_t>& bytes, const std::string& ext) {
  TempDir dir;
  const std::string path = dir.File("export" + ext);
  MS_RETURN_IF_ERROR(WriteFileBytes(path, bytes));
  return ImportFile(path);
}

TEST(PipelineProcess, FiguresAreWhatTheEncoderReports) {
  for (const EncodeSettings& requested : {EncodeSettings{}, EncodeSettings{13, 9, 11, "bundled", 400, 0.05}}) {
    const EncodeSettings settings = Resolved(requested);
    const std::string path = ModelPath("spot.obj");
    const Processed p = MustProcess(path, settings);
    const Direct d = EncodeDirectly(path, settings);
    const ArtifactSummary& s = p.result.summary;
    const PrimitiveStreamReport total = d.report.Total();
    // The numbers of cmd_encode's JSON.
    EXPECT_EQ(s.vertices, static_cast<int64_t>(total.vertices));
    EXPECT_EQ(s.faces, static_cast<int64_t>(total.faces));
    EXPECT_EQ(s.levels, static_cast<int32_t>(total.level_vertices.size() - 1));
    EXPECT_EQ(s.level_vertices, std::vector<int64_t>(total.level_vertices.begin(), total.level_vertices.end()));
    EXPECT_EQ(s.reliable_bytes, total.base_bytes + total.reliable_bytes);
    EXPECT_EQ(s.unreliable_bytes, total.unreliable_bytes);
    EXPECT_EQ(s.progressive_bytes, d.report.file_bytes);
    EXPECT_EQ(s.progressive_bytes, p.result.glb.size());
    EXPECT_GT(s.levels, 0);
    EXPECT_EQ(s.level_vertices.back(), s.vertices);
    // The same bytes as the encoder alone, named by their digest.
    EXPECT_EQ(p.result.glb, d.glb);
    EXPECT_EQ(s.artifact_sha256, Sha256Hex(p.result.glb.data(), p.result.glb.size()));
    EXPECT_EQ(s.encoder, EncoderId());
    const nlohmann::json warnings = nlohmann::json::parse(s.warnings_json);
    EXPECT_TRUE(warnings.is_array());
    EXPECT_FALSE(s.layout_json.empty());

    // Progress: monotone, from 0 to 0.95, through the encoder's range.
    ASSERT_GE(p.progress.size(), 4u);
    EXPECT_EQ(p.progress.front().first, 0.0);
    EXPECT_EQ(p.progress.front().second, "importing");
    EXPECT_EQ(p.progress.back().first, 0.95);
    size_t encoding = 0;
    for (size_t i = 1; i < p.progress.size(); ++i) {
      EXPECT_GE(p.progress[i].first, p.progress[i - 1].first) << p.progress[i].second;
      if (p.progress[i].first > 0.1 && p.progress[i].first < 0.95) ++encoding;
    }
    EXPECT_GT(encoding, 2u);
  }
}

// The reference: `meshstream encode --json` with the same flags and both
// profiles, as the server stores them (services_tests depends on the CLI's
// target, so it is always built).
TEST(PipelineProcess, FiguresEqualTheCliJson) {
  ASSERT_TRUE(std::filesystem::exists(MESHSTREAM_CLI)) << "no CLI at " << MESHSTREAM_CLI;
  TempDir dir;
  const EncodeSettings settings = Resolved(EncodeSettings{13, 9, 11, "bundled", 400, 0.05});
  for (const std::string name : {"spot.obj", "gltf/2CylinderEngine.glb"}) {
    const std::string out = dir.File("cli.glb");
    const auto run = test_util::RunCommand(
        "env -u MESHSTREAM_LEVELS -u MESHSTREAM_QC -u MESHSTREAM_CL " + test_util::Cli() + " encode --json --qp 13 --qn 9 --qt 11 " +
        "--packing bundled --packet-bytes 400 --base-ratio 0.05 --profile both " + test_util::Quote(ModelPath(name)) + " -o " +
        test_util::Quote(out));
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const nlohmann::json j = nlohmann::json::parse(run.out);
    const Processed p = MustProcess(ModelPath(name), settings);
    const ArtifactSummary& s = p.result.summary;
    EXPECT_EQ(s.vertices, j["vertices"].get<int64_t>()) << name;
    EXPECT_EQ(s.faces, j["faces"].get<int64_t>()) << name;
    EXPECT_EQ(s.levels, j["levels"].get<int32_t>()) << name;
    EXPECT_EQ(s.level_vertices, j["level_vertices"].get<std::vector<int64_t>>()) << name;
    EXPECT_EQ(s.reliable_bytes, j["reliable_bytes"].get<uint64_t>()) << name;
    EXPECT_EQ(s.unreliable_bytes, j["unreliable_bytes"].get<uint64_t>()) << name;
    EXPECT_EQ(s.progressive_bytes, j["file_bytes"].get<uint64_t>()) << name;
    auto cli_glb = ReadFileBytes(out, uint64_t{1} << 30);
    ASSERT_TRUE(cli_glb.ok());
    EXPECT_EQ(cli_glb.value(), p.result.glb) << name;
  }
}

TEST(PipelineProcess, LayoutSpansAreTheStreamsBlocks) {
  const EncodeSettings settings = Resolved();
  for (const std::string name : {"spot.obj", "gltf/BoxTextured.glb", "gltf/2CylinderEngine.glb"}) {
    const Processed p = MustProcess(ModelPath(name), settings);
    const std::vector<uint8_t>& glb = p.result.glb;
    const ProgressiveGlbReport& report = p.result.report;
    auto parsed = ParseStreamLayout(p.result.summary.layout_json);
    ASSERT_TRUE(parsed.ok()) << parsed.status().ToString();
    auto computed = ComputeStreamLayout(glb.data(), glb.size());
    ASSERT_TRUE(computed.ok()) << computed.status().ToString();
    EXPECT_EQ(StreamLayoutJson(parsed.value()), p.result.summary.layout_json);
    EXPECT_EQ(StreamLayoutJson(computed.value()), p.result.summary.layout_json);
    const StreamLayout& layout = parsed.value();
    EXPECT_EQ(layout.file_bytes, glb.size());
    ASSERT_EQ(layout.primitives.size(), report.primitives.size()) << name;
    EXPECT_EQ(static_cast<int32_t>(layout.levels()), p.result.summary.levels);
    uint64_t base = 0, reliable = 0, unreliable = 0;
    for (size_t i = 0; i < layout.primitives.size(); ++i) {
      const PrimitiveLayout& e = layout.primitives[i];
      const PrimitiveStreamReport& r = report.primitives[i];
      EXPECT_EQ(e.stream, i);
      EXPECT_EQ(e.base.length, r.base_bytes);
      EXPECT_EQ(e.reliable_bytes, r.reliable_bytes);
      EXPECT_EQ(e.unreliable_bytes, r.unreliable_bytes);
      EXPECT_EQ(e.level_vertices, r.level_vertices);
      EXPECT_EQ(e.residual_error, r.residual_error) << "the scene's errors reach the layout";
      EXPECT_EQ(e.residual_error.size(), e.refinements + 1);
      EXPECT_EQ(e.quantization.qp, settings.qp);
      EXPECT_EQ(e.packing, Packing::kSplit);
      base += e.base.length;
      reliable += e.reliable_bytes;
      unreliable += e.unreliable_bytes;

      auto blocks = LocateStreamBlocks(glb.data(), glb.size(), e);
      ASSERT_TRUE(blocks.ok()) << blocks.status().ToString();
      auto stream = ProgressiveStream::Parse(glb.data() + e.stream_blob.offset, e.stream_blob.length);
      ASSERT_TRUE(stream.ok()) << stream.status().ToString();
      auto bytes = [&](const ByteRange& range) {
        return std::vector<uint8_t>(glb.begin() + range.offset, glb.begin() + range.offset + range.length);
      };
      EXPECT_EQ(blocks->base, e.base);
      // The base span starts with Draco's magic.
      EXPECT_EQ(std::string(reinterpret_cast<const char*>(glb.data() + e.base.offset), 5), "DRACO");
      EXPECT_EQ(bytes(blocks->header), stream->header);
      ASSERT_EQ(blocks->control.size(), stream->control.size());
      ASSERT_EQ(blocks->datagrams.size(), stream->datagrams.size());
      EXPECT_EQ(blocks->control.size(), e.refinements);
      for (size_t k = 0; k < stream->control.size(); ++k) {
        EXPECT_EQ(bytes(blocks->control[k]), stream->control[k]);
        ASSERT_EQ(blocks->datagrams[k].size(), stream->datagrams[k].size());
        EXPECT_EQ(e.datagram_counts[k], stream->datagrams[k].size());
        for (size_t d = 0; d < stream->datagrams[k].size(); ++d) {
          EXPECT_EQ(bytes(blocks->datagrams[k][d]), stream->datagrams[k][d]);
        }
      }
      auto header = StreamHeader::Parse(stream->header.data(), stream->header.size());
      ASSERT_TRUE(header.ok());
      EXPECT_EQ(e.split_counts, header->split_counts);
    }
    EXPECT_EQ(base + reliable, p.result.summary.reliable_bytes);
    EXPECT_EQ(unreliable, p.result.summary.unreliable_bytes);

    // A layout of another artifact is noticed; ranges outside the file too.
    if (!layout.primitives.empty() && layout.primitives[0].refinements > 0) {
      PrimitiveLayout other = layout.primitives[0];
      other.datagram_counts[0] += 1;
      auto wrong = LocateStreamBlocks(glb.data(), glb.size(), other);
      EXPECT_EQ(wrong.status().code(), StatusCode::kDataLoss) << wrong.status().ToString();
      other = layout.primitives[0];
      other.stream_blob.offset = glb.size() - 2;
      EXPECT_EQ(LocateStreamBlocks(glb.data(), glb.size(), other).status().code(), StatusCode::kInvalidInput);
      other = layout.primitives[0];
      other.stream_blob.offset += 1;
      other.stream_blob.length -= 1;
      EXPECT_FALSE(LocateStreamBlocks(glb.data(), glb.size(), other).ok());
    }
  }
}

TEST(PipelineProcess, StreamLayoutJsonIsCheckedWhenRead) {
  const Processed p = MustProcess(ModelPath("spot.obj"), Resolved());
  const nlohmann::json good = nlohmann::json::parse(p.result.summary.layout_json);
  auto refused = [](const nlohmann::json& j) {
    auto r = ParseStreamLayout(j.dump());
    EXPECT_FALSE(r.ok()) << j.dump().substr(0, 200);
    return r.ok() ? std::string() : r.status().message();
  };
  EXPECT_FALSE(ParseStreamLayout("not json").ok());
  EXPECT_FALSE(ParseStreamLayout("[]").ok());
  nlohmann::json j = good;
  j["version"] = 2;
  EXPECT_NE(refused(j).find("version 2"), std::string::npos);
  j = good;
  j["primitives"][0].erase("stream_blob");
  EXPECT_NE(refused(j).find("primitives[0].stream_blob"), std::string::npos);
  j = good;
  j["primitives"][0]["base"]["offset"] = -1;
  EXPECT_NE(refused(j).find("primitives[0].base.offset"), std::string::npos);
  j = good;
  j["primitives"][0]["base"]["length"] = good["file_bytes"].get<uint64_t>() + 1;
  EXPECT_NE(refused(j).find("primitives[0].base.length"), std::string::npos);
  j = good;
  j["primitives"][0]["split_counts"].push_back(1);
  EXPECT_NE(refused(j).find("split_counts"), std::string::npos);
  j = good;
  j["primitives"][0]["packing"] = "other";
  EXPECT_NE(refused(j).find("packing"), std::string::npos);
  j = good;
  j["primitives"][0]["quantization"]["qp"] = 31;
  EXPECT_NE(refused(j).find("quantization.qp"), std::string::npos);
  // The residual errors: optional (layouts stored before them have none), but
  // checked where present.
  ASSERT_TRUE(good["primitives"][0].contains("residual_error"));
  j = good;
  j["primitives"][0].erase("residual_error");
  auto old = ParseStreamLayout(j.dump());
  ASSERT_TRUE(old.ok()) << old.status().ToString();
  EXPECT_TRUE(old->primitives[0].residual_error.empty());
  j = good;
  j["primitives"][0]["residual_error"].push_back(0);
  EXPECT_NE(refused(j).find("residual_error has"), std::string::npos);
  j = good;
  j["primitives"][0]["residual_error"][1] = 1e9;
  EXPECT_NE(refused(j).find("residual_error[1]"), std::string::npos) << "larger than the entry before";
  j = good;
  j["primitives"][0]["residual_error"][0] = -1;
  EXPECT_NE(refused(j).find("residual_error[0]"), std::string::npos);
  j = good;
  j["primitives"][0]["residual_error"][0] = "x";
  EXPECT_NE(refused(j).find("not a number"), std::string::npos);
}

TEST(PipelineProcess, ExportsInEveryFormatDecode) {
  const EncodeSettings settings = Resolved(EncodeSettings{12, 0, 0, "", 0, 0});
  const std::string source_path = ModelPath("spot.obj");
  const Processed p = MustProcess(source_path, settings);
  const std::vector<uint8_t>& artifact = p.result.glb;
  const ArtifactSummary& s = p.result.summary;
  ASSERT_GT(s.levels, 1);

  auto progressive = ExportArtifact(artifact, ExportFormat::kProgressiveGlb, std::nullopt);
  ASSERT_TRUE(progressive.ok());
  EXPECT_EQ(progressive.value(), artifact);
  auto progressive_lod = ExportArtifact(artifact, ExportFormat::kProgressiveGlb, 1);
  EXPECT_EQ(progressive_lod.status().code(), StatusCode::kInvalidArgument);
  EXPECT_EQ(progressive_lod.status().message(), "lod: not supported for the progressive format (it holds every level)");

  // glb at full lod: every vertex of the source, as the decoder gives them.
  ProgressiveDecodeReport report;
  auto decoded = DecodeProgressiveGlb(artifact, {}, &report);
  ASSERT_TRUE(decoded.ok());
  auto glb = ExportArtifact(artifact, ExportFormat::kGlb, std::nullopt);
  ASSERT_TRUE(glb.ok()) << glb.status().ToString();
  auto glb_scene = ImportBytes(glb.value(), ".glb");
  ASSERT_TRUE(glb_scene.ok()) << glb_scene.status().ToString();
  EXPECT_EQ(glb_scene->total_vertices(), decoded->total_vertices());
  EXPECT_EQ(static_cast<int64_t>(glb_scene->total_vertices()), s.vertices);
  EXPECT_EQ(static_cast<int64_t>(glb_scene->total_faces()), s.faces);
  auto full = ExportArtifact(artifact, ExportFormat::kGlb, s.levels);
  ASSERT_TRUE(full.ok());
  EXPECT_EQ(full.value(), glb.value());

  // Each level has its own vertex count.
  for (int lod : {0, 1, s.levels / 2}) {
    auto level = ExportArtifact(artifact, ExportFormat::kGlb, lod);
    ASSERT_TRUE(level.ok()) << level.status().ToString();
    auto scene = ImportBytes(level.value(), ".glb");
    ASSERT_TRUE(scene.ok()) << scene.status().ToString();
    EXPECT_EQ(static_cast<int64_t>(scene->total_vertices()), s.level_vertices[lod]) << "lod " << lod;
  }

  // Draco at the artifact's qp: the same triangles as the source on its grid.
  auto draco = ExportArtifact(artifact, ExportFormat::kDracoGlb, std::nullopt);
  ASSERT_TRUE(draco.ok()) << draco.status().ToString();
  EXPECT_NE(std::string(draco->begin(), draco->end()).find("KHR_draco_mesh_compression"), std::string::npos);
  EXPECT_LT(draco->size(), glb->size());
  auto draco_scene = ImportBytes(draco.value(), ".glb");
  ASSERT_TRUE(draco_scene.ok()) << draco_scene.status().ToString();
  auto source = ImportFile(source_path);
  ASSERT_TRUE(source.ok());
  auto same = CompareOnGrid(source->meshes[0].primitives[0], draco_scene->meshes[0].primitives[0], settings.qp);
  ASSERT_TRUE(same.ok()) << same.status().ToString();
  EXPECT_TRUE(same->equal) << same->differing() << " triangles differ";

  // OBJ and PLY: one mesh, every face.
  for (ExportFormat format : {ExportFormat::kObj, ExportFormat::kPly}) {
    const std::string ext = InfoOf(format).extension;
    auto bytes = ExportArtifact(artifact, format, std::nullopt);
    ASSERT_TRUE(bytes.ok()) << ext << ": " << bytes.status().ToString();
    auto scene = ImportBytes(bytes.value(), ext);
    ASSERT_TRUE(scene.ok()) << ext << ": " << scene.status().ToString();
    EXPECT_EQ(static_cast<int64_t>(scene->total_faces()), s.faces) << ext;
    EXPECT_EQ(scene->total_primitives(), 1u) << ext;
    auto on_grid = CompareOnGrid(source->meshes[0].primitives[0], scene->meshes[0].primitives[0], settings.qp);
    ASSERT_TRUE(on_grid.ok());
    EXPECT_TRUE(on_grid->equal) << ext << ": " << on_grid->differing() << " triangles differ";
    auto base = ExportArtifact(artifact, format, 0);
    ASSERT_TRUE(base.ok());
    EXPECT_LT(base->size(), bytes->size()) << ext;
  }

  // Levels outside [0, levels].
  for (int lod : {-1, s.levels + 1, 1000}) {
    for (ExportFormat format : {ExportFormat::kGlb, ExportFormat::kDracoGlb, ExportFormat::kObj, ExportFormat::kPly}) {
      auto refused = ExportArtifact(artifact, format, lod);
      EXPECT_EQ(refused.status().code(), StatusCode::kInvalidArgument);
      EXPECT_EQ(refused.status().message(),
                "lod: " + std::to_string(lod) + " is outside [0, " + std::to_string(s.levels) + "]");
    }
  }
  // Bytes that are not an artifact.
  const std::vector<uint8_t> junk = {'g', 'l', 'T', 'F', 2, 0, 0, 0, 1, 2, 3};
  EXPECT_FALSE(ExportArtifact(junk, ExportFormat::kGlb, std::nullopt).ok());
  EXPECT_FALSE(ExportArtifact(std::vector<uint8_t>(), ExportFormat::kObj, std::nullopt).ok());
}

TEST(PipelineProcess, AGltfWithExternalFilesAndNoRefinedPrimitiveProcesses) {
  // Morphed triangles are carried, not refined: no stream, an empty layout.
  const Processed p = MustProcess(ModelPath("gltf/AnimatedMorphCube/AnimatedMorphCube.gltf"), Resolved());
  auto layout = ParseStreamLayout(p.result.summary.layout_json);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  EXPECT_TRUE(layout->primitives.empty());
  EXPECT_EQ(p.result.summary.levels, 0);
  auto glb = ExportArtifact(p.result.glb, ExportFormat::kGlb, 0);
  EXPECT_TRUE(glb.ok()) << glb.status().ToString();
  EXPECT_EQ(ExportArtifact(p.result.glb, ExportFormat::kGlb, 1).status().message(), "lod: 1 is outside [0, 0]");
}

TEST(PipelineProcess, AFileThatIsNotAMeshFailsWithTheImportersMessage) {
  TempDir dir;
  std::mt19937 random(7);
  std::string garbage(4096, '\0');
  for (char& c : garbage) c = static_cast<char>(random());
  for (const std::string name : {"garbage.obj", "garbage.glb", "garbage.gltf", "garbage.ply", "garbage.stl"}) {
    test_util::WriteText(dir.File(name), garbage);
    auto r = ProcessSource(dir.File(name), Resolved(), nullptr);
    ASSERT_FALSE(r.ok()) << name;
    const std::string& m = r.status().message();
    EXPECT_EQ(m.rfind(name, 0), 0u) << m;  // named as uploaded
    EXPECT_EQ(m.find(dir.path()), std::string::npos) << m;  // not by the work folder
    EXPECT_NE(r.status().code(), StatusCode::kOk);
  }
  // The importer's own words, for a file that is missing.
  auto missing = ProcessSource(dir.File("absent.obj"), Resolved(), nullptr);
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.status().message().rfind("absent.obj", 0), 0u) << missing.status().message();
  // A mesh with no faces.
  test_util::WriteText(dir.File("empty.obj"), "v 0 0 0\nv 1 0 0\n");
  auto empty = ProcessSource(dir.File("empty.obj"), Resolved(), nullptr);
  if (!empty.ok()) {
    EXPECT_EQ(empty.status().message().rfind("empty.obj", 0), 0u) << empty.status().message();
  }
}

TEST(PipelineProcess, CancellingStopsAtTheNextProgressPoint) {
  int calls = 0;
  ProcessOptions options;
  bool cancel = false;
  options.cancelled = [&] { return cancel; };
  auto r = ProcessSource(ModelPath("spot.obj"), Resolved(), [&](double v, const std::string&) {
    ++calls;
    if (v > 0.1) cancel = true;
  }, options);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status().code(), StatusCode::kAborted) << r.status().ToString();
  EXPECT_LT(calls, 10);
  // A callback that throws becomes a Status, never an exception.
  auto thrown = ProcessSource(ModelPath("spot.obj"), Resolved(), [](double v, const std::string&) {
    if (v > 0.1) throw std::runtime_error("callback failed");
  });
  ASSERT_FALSE(thrown.ok());
  EXPECT_NE(thrown.status().message().find("callback failed"), std::string::npos) << thrown.status().ToString();
}

}  // namespace
}  // namespace meshstream
