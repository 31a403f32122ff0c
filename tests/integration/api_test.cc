// The asset service end to end: a real `meshstream serve` on an embedded
// store, driven over loopback gRPC by the generated C++ client. Every shared
// model is ingested once (the fixture), then exported in every format; the
// glTF outputs pass the Khronos validator and the progressive export decodes
// on the grid of its source. Then pagination, resumable uploads, the cache,
// and every error code of docs/spec/api.md, with the server still healthy after.
#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "services/store/blob_store.h"
#include "testing/asset_calls.h"
#include "tests/common/cli_util.h"
#include "testing/grpc_probe.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ServeProcess;
using sdk::UploadFile;
namespace fs = std::filesystem;

struct Model {
  std::string asset;
  std::string path;                   // the main file
  std::vector<UploadFile> resources;  // the other files of its folder (.gltf)
  bool triangles_only = true;         // only refined triangle primitives: figures and a decode on the grid
};

std::vector<Model> SharedModels() {
  std::vector<Model> models;
  for (const char* name : {"stanford-bunny.obj", "horse.ply", "fandisk.obj", "rocker-arm.obj", "spot.obj"}) {
    std::string asset = name;
    asset = asset.substr(0, asset.find('.'));
    models.push_back({asset, test_util::ModelPath(name), {}, true});
  }
  models.push_back({"BoxTextured", test_util::ModelPath("gltf/BoxTextured.glb"), {}, true});
  // At qp 11 the engine has faces that collapse on the grid, which the
  // encoder removes (removed_faces): it is checked by the validator only.
  models.push_back({"2CylinderEngine", test_util::ModelPath("gltf/2CylinderEngine.glb"), {}, false});
  for (const char* folder : {"AnimatedMorphCube", "simple_skin", "draco-2CylinderEngine"}) {
    Model m;
    m.asset = std::string("gltf-") + folder;
    m.triangles_only = false;
    for (const auto& entry : fs::directory_iterator(test_util::ModelPath(std::string("gltf/") + folder))) {
      const std::string file = entry.path().filename().string();
      if (entry.path().extension() == ".gltf") {
        m.path = entry.path().string();
      } else {
        m.resources.push_back(test_util::LoadFile(entry.path().string(), file));
      }
    }
    models.push_back(m);
  }
  return models;
}

struct Ingested {
  Model model;
  v1::IngestResponse response;
  v1::Job job;
  v1::Version version;
};

class AssetApi : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const Status started = suite_.Start();
    ASSERT_TRUE(started.ok()) << started.ToString();
    client_ = test_util::NewAssetClient(server_->address()).release();
    // Every model is sent first, then every job followed: the pool works on
    // them in parallel while the uploads go on.
    ingested_ = new std::vector<Ingested>();
    for (const Model& m : SharedModels()) {
      Ingested in;
      in.model = m;
      const UploadFile main = test_util::LoadFile(m.path, fs::path(m.path).filename().string());
      const Status s = test_util::Ingest(*client_, m.asset, main, &in.response, m.resources);
      ASSERT_TRUE(s.ok()) << m.asset << ": " << s.ToString();
      ingested_->push_back(std::move(in));
    }
    for (Ingested& in : *ingested_) {
      ASSERT_TRUE(test_util::Watch(*client_, in.response.job_id(), &in.job).ok()) << in.model.asset;
      ASSERT_TRUE(test_util::GetVersion(*client_, in.model.asset, in.response.version(), &in.version).ok()) << in.model.asset;
    }
  }
  static void TearDownTestSuite() {
    std::string log;
    EXPECT_EQ(suite_.Stop(&log), 0) << log;
    delete client_;
    delete ingested_;
  }

  static grpc::Status Unary(std::function<grpc::Status(grpc::ClientContext*)> call) {
    grpc::ClientContext context;
    test_util::Prepare(*client_, context);
    return call(&context);
  }

  static void ExpectHealthy() {
    const auto health = test_util::CheckHealth(client_->channel());
    EXPECT_TRUE(health.status.ok()) << health.status.error_message();
    EXPECT_EQ(health.serving_status, 1) << "health is not SERVING";
  }

  static inline test_util::SuiteServer suite_;
  static inline test_util::TempDir*& dir_ = suite_.dir;
  static inline ServeProcess*& server_ = suite_.server;
  static inline sdk::AssetClient* client_ = nullptr;
  static inline std::vector<Ingested>* ingested_ = nullptr;
};

UploadFile SmallObj(const std::string& name, int variant = 0) {
  const std::string text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 " + std::to_string(1 + variant) +
                           "\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n";
  return UploadFile::FromBytes(name, std::vector<uint8_t>(text.begin(), text.end()));
}

TEST_F(AssetApi, EveryModelBecomesReadyWithItsFigures) {
  ASSERT_EQ(ingested_->size(), SharedModels().size());
  for (const Ingested& in : *ingested_) {
    SCOPED_TRACE(in.model.asset);
    EXPECT_EQ(in.response.asset(), in.model.asset);
    EXPECT_EQ(in.response.version(), 1);
    const UploadFile main = test_util::LoadFile(in.model.path, "x");
    EXPECT_EQ(in.response.sha256(), Sha256Hex(main.bytes.data(), main.bytes.size()));
    EXPECT_EQ(in.job.state(), v1::JOB_STATE_SUCCEEDED) << in.job.message();
    EXPECT_DOUBLE_EQ(in.job.progress(), 1.0);
    EXPECT_EQ(in.version.state(), v1::VERSION_STATE_READY) << in.version.error();
    EXPECT_EQ(in.version.source_sha256(), in.response.sha256());
    EXPECT_EQ(in.version.source_size(), main.bytes.size());
    EXPECT_EQ(static_cast<size_t>(in.version.resources_size()), in.model.resources.size());
    EXPECT_GT(in.version.progressive_bytes(), 0u);
    EXPECT_FALSE(in.version.encoder().empty());
    EXPECT_GT(in.version.options().qp(), 0) << "the stored options are the effective ones";
    if (in.model.triangles_only) {
      // The figures count the refined (triangle) primitives; a scene of
      // only skinned or morphed primitives has none (docs/spec/api.md).
      EXPECT_GT(in.version.vertices(), 0);
      EXPECT_GT(in.version.faces(), 0);
      ASSERT_EQ(in.version.level_vertices_size(), in.version.levels() + 1);
      if (in.version.vertices() > 1000) {  // BoxTextured's 24 vertices are their own base
        EXPECT_GE(in.version.levels(), 1);
        EXPECT_LT(in.version.level_vertices(0), in.version.vertices());
        EXPECT_GT(in.version.unreliable_bytes(), 0u);
      }
    }
  }
}

TEST_F(AssetApi, WatchJobReportsProgressUpToSucceeded) {
  // A fresh version of the bunny (another packing, so not from the cache).
  const UploadFile main = test_util::LoadFile(test_util::ModelPath("stanford-bunny.obj"), "bunny.obj");
  auto messages = test_util::UploadMessages("bunny-watch", main);
  messages[0].mutable_metadata()->mutable_options()->set_packing("bundled");
  v1::IngestResponse response;
  ASSERT_TRUE(test_util::IngestRaw(*client_, messages, &response).ok());
  v1::Job last;
  std::vector<v1::Job> all;
  ASSERT_TRUE(test_util::Watch(*client_, response.job_id(), &last, &all).ok());
  EXPECT_EQ(last.state(), v1::JOB_STATE_SUCCEEDED);
  ASSERT_GE(all.size(), 2u) << "at least one state before SUCCEEDED";
  for (size_t i = 1; i < all.size(); ++i) EXPECT_GE(all[i].progress(), all[i - 1].progress());
  v1::Job got;
  ASSERT_TRUE(Unary([&](grpc::ClientContext* c) {
                v1::GetJobRequest r;
                r.set_job_id(response.job_id());
                return client_->stub().GetJob(c, r, &got);
              }).ok());
  EXPECT_EQ(got.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_EQ(got.asset(), "bunny-watch");
  EXPECT_EQ(got.version(), 1);
  v1::Version version;
  ASSERT_TRUE(test_util::GetVersion(*client_, "bunny-watch", 1, &version).ok());
  EXPECT_EQ(version.options().packing(), "bundled");
}

TEST_F(AssetApi, ExportsEveryFormatThatValidatesAndDecodesOnTheGrid) {
  test_util::TempDir out;
  std::vector<std::string> gltf_files;
  for (const Ingested& in : *ingested_) {
    SCOPED_TRACE(in.model.asset);
    const std::map<v1::Format, std::string> formats = {{v1::FORMAT_GLB, ".plain.glb"},
                                                       {v1::FORMAT_DRACO_GLB, ".draco.glb"},
                                                       {v1::FORMAT_PROGRESSIVE_GLB, ".progressive.glb"},
                                                       {v1::FORMAT_OBJ, ".obj"},
                                                       {v1::FORMAT_PLY, ".ply"}};
    for (const auto& [format, suffix] : formats) {
      const auto e = test_util::Export(*client_, in.model.asset, 0, format);
      ASSERT_TRUE(e.status.ok()) << v1::Format_Name(format) << ": " << e.status.ToString();
      EXPECT_EQ(e.version, 1);
      EXPECT_EQ(e.sha256, Sha256Hex(e.bytes.data(), e.bytes.size())) << "the last chunk carries the digest";
      EXPECT_LE(e.largest_chunk, size_t{1} << 20);
      ASSERT_FALSE(e.bytes.empty());
      const std::string file = out.File(in.model.asset + suffix);
      ASSERT_TRUE(WriteFileBytes(file, e.bytes).ok());
      if (suffix.find(".glb") != std::string::npos) gltf_files.push_back(file);
    }
    if (!in.model.triangles_only) continue;
    // The progressive export, decoded at full detail, is the source on the grid.
    const std::string full = out.File(in.model.asset + ".full.glb");
    const auto decoded = test_util::RunCommand(test_util::Cli() + " decode " +
                                               test_util::Quote(out.File(in.model.asset + ".progressive.glb")) +
                                               " -o " + test_util::Quote(full));
    ASSERT_EQ(decoded.exit_code, 0) << decoded.err;
    const nlohmann::json c = test_util::RunCliJson("compare --json --qp " + std::to_string(in.version.options().qp()) +
                                                   " " + test_util::Quote(in.model.path) + " " + test_util::Quote(full));
    EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
  }
  for (const nlohmann::json& report : test_util::ValidateGltf(gltf_files)) {
    EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
  }
}

// A streaming session of every shared model (meshstream fetch through the
// SDK): over UDP nothing is lost on loopback and the mesh is the source on
// the grid; --tcp-only gives the same mesh vertex for vertex, from the
// reliable profile (no datagrams, fewer bytes), and --tcp-only --profile
// loss-tolerant the same stream as UDP's.
TEST_F(AssetApi, EveryModelStreamsOverUdpAndOverTcpToTheSameMesh) {
  test_util::TempDir out;
  std::vector<std::string> gltf_files;
  const std::string remote = " --server " + server_->address();
  for (const Ingested& in : *ingested_) {
    SCOPED_TRACE(in.model.asset);
    const std::string udp_file = out.File(in.model.asset + ".udp.glb");
    const std::string tcp_file = out.File(in.model.asset + ".tcp.glb");
    const nlohmann::json udp = test_util::RunCliJson("fetch --json " + in.model.asset + " -o " + test_util::Quote(udp_file) + remote);
    const nlohmann::json tcp =
        test_util::RunCliJson("fetch --json --tcp-only " + in.model.asset + " -o " + test_util::Quote(tcp_file) + remote);
    const nlohmann::json tcp_lt = test_util::RunCliJson("fetch --json --tcp-only --profile loss-tolerant " +
                                                        in.model.asset + " -o " + test_util::Quote(out.File("lt.glb")) + remote);
    EXPECT_EQ(udp["transport"], "udp") << udp.dump();
    EXPECT_EQ(tcp["transport"], "grpc") << tcp.dump();
    EXPECT_EQ(udp["profile"], "loss-tolerant") << udp.dump();
    EXPECT_EQ(tcp_lt["profile"], "loss-tolerant") << tcp_lt.dump();
    EXPECT_EQ(udp["datagrams_lost"], 0) << udp.dump();
    EXPECT_EQ(udp["datagrams_rejected"], 0) << udp.dump();
    EXPECT_EQ(udp["predicted_vertices"], 0) << udp.dump();
    EXPECT_EQ(udp["datagrams_received"], tcp_lt["datagrams_received"]);
    EXPECT_EQ(udp["unreliable_bytes"], tcp_lt["unreliable_bytes"]);
    if (udp["vertices"] != 0) {
      EXPECT_EQ(tcp["profile"], "reliable") << tcp.dump();
      EXPECT_EQ(tcp["datagrams_received"], 0) << "the reliable profile has no datagrams";
      // Smaller wherever there is something to refine; a mesh without
      // refinements (the textured box) is the same base in both profiles.
      const uint64_t reliable_total = tcp["reliable_bytes"].get<uint64_t>();
      const uint64_t udp_total = udp["reliable_bytes"].get<uint64_t>() + udp["unreliable_bytes"].get<uint64_t>();
      if (udp["datagrams_received"].get<uint64_t>() > 0) {
        EXPECT_LT(reliable_total, udp_total) << tcp.dump();
      } else {
        EXPECT_LE(reliable_total, udp_total) << tcp.dump();
      }
    }
    EXPECT_EQ(udp["vertices"], tcp["vertices"]);
    EXPECT_EQ(udp["faces"], tcp["faces"]);
    EXPECT_EQ(tcp_lt["vertices"], tcp["vertices"]);
    // The session exports the asset's scene: its structure is the source's.
    const nlohmann::json source = test_util::RunCliJson("info --json " + test_util::Quote(in.model.path));
    const nlohmann::json fetched = test_util::RunCliJson("info --json " + test_util::Quote(udp_file));
    for (const char* key : {"scenes", "nodes", "meshes", "materials", "textures", "images", "skins", "animations",
                            "carried_primitives", "primitives"}) {
      EXPECT_EQ(fetched[key], source[key]) << key << ": " << fetched.dump();
    }
    gltf_files.push_back(udp_file);
    if (udp["vertices"] == 0) continue;  // nothing refined (every primitive carried as it is)
    const nlohmann::json same = test_util::RunCliJson("compare --json " + test_util::Quote(udp_file) + " " + test_util::Quote(tcp_file));
    EXPECT_EQ(same.value("hausdorff_vertex", 1.0), 0.0) << same.dump();
    if (!in.model.triangles_only) continue;
    const nlohmann::json c = test_util::RunCliJson("compare --json --qp " + std::to_string(in.version.options().qp()) + " " +
                                                   test_util::Quote(in.model.path) + " " + test_util::Quote(udp_file));
    EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
  }
  for (const nlohmann::json& report : test_util::ValidateGltf(gltf_files)) {
    EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
  }
}

TEST_F(AssetApi, ExportAtALevelOfDetailAndInChunks) {
  const auto full = test_util::Export(*client_, "horse", 0, v1::FORMAT_GLB);
  const auto base = test_util::Export(*client_, "horse", 1, v1::FORMAT_GLB, 0);
  ASSERT_TRUE(full.status.ok() && base.status.ok()) << base.status.ToString();
  EXPECT_LT(base.bytes.size(), full.bytes.size());
  EXPECT_GT(full.chunks, 1u) << "the horse's GLB is larger than one 1 MiB chunk";
  EXPECT_LE(full.largest_chunk, size_t{1} << 20);
  const auto again = test_util::Export(*client_, "horse", 0, v1::FORMAT_GLB);
  EXPECT_EQ(again.sha256, full.sha256) << "an export is deterministic (and cached)";
  v1::Version v;
  ASSERT_TRUE(test_util::GetVersion(*client_, "horse", 1, &v).ok());
  const auto beyond = test_util::Export(*client_, "horse", 1, v1::FORMAT_GLB, v.levels() + 1);
  EXPECT_EQ(beyond.status.code(), StatusCode::kInvalidArgument);
  EXPECT_NE(beyond.status.message().find("lod"), std::string::npos) << beyond.status.ToString();
}

TEST_F(AssetApi, VersionsAreNumberedAndTheSameSourceIsEncodedOnce) {
  v1::IngestResponse first, second;
  const UploadFile spot = test_util::LoadFile(test_util::ModelPath("spot.obj"), "spot.obj");
  ASSERT_TRUE(test_util::Ingest(*client_, "spot", spot, &first).ok());
  EXPECT_EQ(first.version(), 2) << "the fixture made version 1";
  ASSERT_TRUE(test_util::Ingest(*client_, "spot", spot, &second).ok());
  EXPECT_EQ(second.version(), 3);
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client_, second.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED);
  EXPECT_NE(job.message().find("reused"), std::string::npos) << "identical source and options: " << job.message();
  const auto a = test_util::Export(*client_, "spot", 1, v1::FORMAT_PROGRESSIVE_GLB);
  const auto b = test_util::Export(*client_, "spot", 3, v1::FORMAT_PROGRESSIVE_GLB);
  EXPECT_EQ(a.sha256, b.sha256);
  v1::Version latest;
  ASSERT_TRUE(test_util::GetVersion(*client_, "spot", 0, &latest).ok());
  EXPECT_EQ(latest.version(), 3);
}

TEST_F(AssetApi, PaginationVisitsEveryVersionAndAssetOnce) {
  for (int i = 0; i < 5; ++i) {
    v1::IngestResponse r;
    ASSERT_TRUE(test_util::Ingest(*client_, "paged", SmallObj("tet.obj", i), &r).ok());
    EXPECT_EQ(r.version(), i + 1);
  }
  for (int page_size : {1, 2, 3, 100}) {
    std::vector<int64_t> seen;
    std::string token;
    int pages = 0;
    do {
      v1::ListVersionsResponse response;
      ASSERT_TRUE(Unary([&](grpc::ClientContext* c) {
                    v1::ListVersionsRequest r;
                    r.set_asset("paged");
                    r.set_page_size(page_size);
                    r.set_page_token(token);
                    return client_->stub().ListVersions(c, r, &response);
                  }).ok());
      EXPECT_LE(response.versions_size(), page_size);
      for (const auto& v : response.versions()) seen.push_back(v.version());
      token = response.next_page_token();
      ASSERT_LT(++pages, 20);
    } while (!token.empty());
    EXPECT_EQ(seen, (std::vector<int64_t>{1, 2, 3, 4, 5})) << "page_size " << page_size;
  }
  std::set<std::string> assets;
  std::string token;
  size_t listed = 0;
  do {
    v1::ListAssetsResponse response;
    ASSERT_TRUE(Unary([&](grpc::ClientContext* c) {
                  v1::ListAssetsRequest r;
                  r.set_page_size(2);
                  r.set_page_token(token);
                  return client_->stub().ListAssets(c, r, &response);
                }).ok());
    for (const auto& a : response.assets()) {
      assets.insert(a.name());
      ++listed;
      if (a.name() == "paged") {
        EXPECT_EQ(a.latest_version(), 5);
      }
    }
    token = response.next_page_token();
  } while (!token.empty());
  EXPECT_EQ(listed, assets.size()) << "no asset twice";
  for (const Ingested& in : *ingested_) EXPECT_EQ(assets.count(in.model.asset), 1u) << in.model.asset;
  // A huge page size is clamped, not refused.
  v1::ListVersionsResponse huge;
  EXPECT_TRUE(Unary([&](grpc::ClientContext* c) {
                v1::ListVersionsRequest r;
                r.set_asset("paged");
                r.set_page_size(2000000000);
                return client_->stub().ListVersions(c, r, &huge);
              }).ok());
  EXPECT_EQ(huge.versions_size(), 5);
}

TEST_F(AssetApi, AnInterruptedUploadResumesAtCommittedSize) {
  const UploadFile horse = test_util::LoadFile(test_util::ModelPath("horse.ply"), "horse.ply");
  auto messages = test_util::UploadMessages("resumed", horse, {}, 256 << 10);
  messages[0].mutable_metadata()->set_upload_id("resume-test-1");
  {
    // Half the chunks, then the client goes away.
    grpc::ClientContext context;
    test_util::Prepare(*client_, context);
    v1::IngestResponse response;
    auto writer = client_->stub().Ingest(&context, &response);
    uint64_t sent = 0;
    for (size_t i = 0; i < messages.size() / 2; ++i) {
      ASSERT_TRUE(writer->Write(messages[i]));
      sent += messages[i].chunk().size();
    }
    // Cut once the server has committed what was sent (not after a guess of how long that takes).
    ASSERT_TRUE(test_util::WaitForCommitted(*client_, "resume-test-1", sent)) << "the chunks were never committed";
    context.TryCancel();
    EXPECT_FALSE(writer->Finish().ok());
  }
  v1::UploadStatus status;
  ASSERT_TRUE(Unary([&](grpc::ClientContext* c) {
                v1::QueryUploadRequest r;
                r.set_upload_id("resume-test-1");
                return client_->stub().QueryUpload(c, r, &status);
              }).ok());
  const uint64_t committed = status.committed_size();
  EXPECT_GT(committed, 0u);
  EXPECT_LT(committed, horse.bytes.size());
  EXPECT_EQ(committed % (256 << 10), 0u) << "whole chunks only";
  // A wrong offset is refused with the committed size in the message.
  auto wrong = messages;
  wrong[0].mutable_metadata()->set_write_offset(committed + 1);
  v1::IngestResponse refused;
  const grpc::Status w = test_util::IngestRaw(*client_, {wrong[0]}, &refused);
  EXPECT_EQ(w.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(w.error_message().find(std::to_string(committed)), std::string::npos) << w.error_message();
  // The rest, from committed_size.
  std::vector<v1::IngestRequest> rest = {messages[0]};
  rest[0].mutable_metadata()->set_write_offset(committed);
  std::vector<uint8_t> tail(horse.bytes.begin() + static_cast<long>(committed), horse.bytes.end());
  test_util::AppendChunks(tail, 256 << 10, rest);
  v1::IngestResponse response;
  const grpc::Status ok = test_util::IngestRaw(*client_, rest, &response);
  ASSERT_TRUE(ok.ok()) << ok.error_message();
  EXPECT_EQ(response.sha256(), Sha256Hex(horse.bytes.data(), horse.bytes.size()));
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client_, response.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();
  // The upload is gone once it became a version.
  const grpc::Status gone = Unary([&](grpc::ClientContext* c) {
    v1::QueryUploadRequest r;
    r.set_upload_id("resume-test-1");
    return client_->stub().QueryUpload(c, r, &status);
  });
  EXPECT_EQ(gone.error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(AssetApi, ABadFileFailsItsJobAndNotTheServer) {
  const std::string junk = "this is not an OBJ\nf 1 2 3\nv nan nan\n";
  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*client_, "junk", UploadFile::FromBytes("junk.obj", std::vector<uint8_t>(junk.begin(), junk.end())), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client_, r.job_id(), &job).ok());
  EXPECT_EQ(job.state(), v1::JOB_STATE_FAILED);
  EXPECT_NE(job.message().find("junk.obj"), std::string::npos) << "the importer's message: " << job.message();
  v1::Version v;
  ASSERT_TRUE(test_util::GetVersion(*client_, "junk", r.version(), &v).ok());
  EXPECT_EQ(v.state(), v1::VERSION_STATE_FAILED);
  EXPECT_EQ(v.error(), job.message());
  const auto e = test_util::Export(*client_, "junk", r.version(), v1::FORMAT_GLB);
  EXPECT_EQ(e.status.code(), StatusCode::kFailedPrecondition);
  const auto latest = test_util::Export(*client_, "junk", 0, v1::FORMAT_GLB);
  EXPECT_EQ(latest.status.code(), StatusCode::kFailedPrecondition) << "no READY version";
  // A message quoting a huge URI is cut: the version stays readable.
  const std::string uri(3 << 20, 'x');
  const std::string gltf = "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"byteLength\":4,\"uri\":\"../" + uri + "\"}]}";
  v1::IngestResponse big;
  ASSERT_TRUE(test_util::Ingest(*client_, "long-uri", UploadFile::FromBytes("long.gltf", std::vector<uint8_t>(gltf.begin(), gltf.end())), &big).ok());
  v1::Job failed;
  ASSERT_TRUE(test_util::Watch(*client_, big.job_id(), &failed).ok());
  EXPECT_EQ(failed.state(), v1::JOB_STATE_FAILED);
  EXPECT_LE(failed.message().size(), 1024u);
  v1::Version readable;
  EXPECT_TRUE(test_util::GetVersion(*client_, "long-uri", 1, &readable).ok());
  ExpectHealthy();
}

TEST_F(AssetApi, AListVersionsPageStaysUnderTheMessageLimit) {
  // 30 versions of ~67 KB of labels each: 2 MiB in one page would not fit.
  std::map<std::string, std::string> labels;
  for (int i = 0; i < 64; ++i) labels["label-" + std::to_string(i)] = std::string(1024, 'a' + i % 26);
  for (int i = 0; i < 30; ++i) {
    auto m = test_util::UploadMessages("labelled", SmallObj("tet.obj", i % 3));
    for (const auto& [k, v] : labels) (*m[0].mutable_metadata()->mutable_labels())[k] = v;
    v1::IngestResponse r;
    ASSERT_TRUE(test_util::IngestRaw(*client_, m, &r).ok());
  }
  std::vector<int64_t> seen;
  std::string token;
  int pages = 0;
  do {
    v1::ListVersionsResponse response;
    const grpc::Status s = Unary([&](grpc::ClientContext* c) {
      v1::ListVersionsRequest q;
      q.set_asset("labelled");
      q.set_page_size(1000);
      q.set_page_token(token);
      return client_->stub().ListVersions(c, q, &response);
    });
    ASSERT_TRUE(s.ok()) << s.error_message();
    for (const auto& v : response.versions()) seen.push_back(v.version());
    token = response.next_page_token();
    ++pages;
  } while (!token.empty() && pages < 100);
  EXPECT_GT(pages, 1) << "the answer was split";
  ASSERT_EQ(seen.size(), 30u);
  for (size_t i = 0; i < seen.size(); ++i) EXPECT_EQ(seen[i], static_cast<int64_t>(i + 1));
}

// Hostile and wrong requests: each gets its code and a message naming the
// field, nothing is stored, and the server stays healthy.
TEST_F(AssetApi, EveryErrorHasItsCode) {
  const UploadFile tet = SmallObj("tet.obj");
  auto expect = [](const grpc::Status& s, grpc::StatusCode code, const std::string& words) {
    EXPECT_EQ(s.error_code(), code) << s.error_message();
    EXPECT_NE(s.error_message().find(words), std::string::npos) << "'" << words << "' in: " << s.error_message();
  };
  // The same for what the client returns.
  auto expect_status = [](const Status& s, StatusCode code, const std::string& words) {
    EXPECT_EQ(s.code(), code) << s.ToString();
    EXPECT_NE(s.message().find(words), std::string::npos) << "'" << words << "' in: " << s.ToString();
  };
  v1::IngestResponse r;
  {  // the first message is a chunk
    v1::IngestRequest chunk;
    chunk.set_chunk("v 0 0 0\n");
    expect(test_util::IngestRaw(*client_, {chunk}, &r), grpc::StatusCode::INVALID_ARGUMENT, "metadata");
  }
  expect(test_util::IngestRaw(*client_, {}, &r), grpc::StatusCode::INVALID_ARGUMENT, "metadata");
  {
    auto m = test_util::UploadMessages("../etc", tet);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "asset");
    m = test_util::UploadMessages(std::string(129, 'a'), tet);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "asset");
  }
  {
    auto m = test_util::UploadMessages("txt", UploadFile::FromBytes("notes.txt", tet.bytes));
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "filename");
  }
  {  // lying sizes and digests: DATA_LOSS and no version
    auto m = test_util::UploadMessages("liar", tet);
    m[0].mutable_metadata()->set_size(tet.bytes.size() + 10);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::DATA_LOSS, "size");
    m[0].mutable_metadata()->set_size(tet.bytes.size() - 10);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::DATA_LOSS, "size");
    m = test_util::UploadMessages("liar", tet);
    m[0].mutable_metadata()->set_sha256(std::string(64, 'a'));
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::DATA_LOSS, "SHA-256");
    m[0].mutable_metadata()->set_sha256("xyz");
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "sha256");
    v1::Version v;
    expect_status(test_util::GetVersion(*client_, "liar", 0, &v), StatusCode::kNotFound, "liar");
  }
  {  // options out of range
    auto m = test_util::UploadMessages("opts", tet);
    m[0].mutable_metadata()->mutable_options()->set_qp(99);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "qp");
    m = test_util::UploadMessages("opts", tet);
    m[0].mutable_metadata()->mutable_options()->set_packing("zip");
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "packing");
  }
  {  // resources: only for a .gltf, and only relative paths inside the upload
    const UploadFile gltf = UploadFile::FromBytes("scene.gltf", std::vector<uint8_t>{'{', '}'});
    for (const char* name : {"../secret.bin", "/etc/passwd", "a/../../b.bin", "a\\b.bin", ""}) {
      auto m = test_util::UploadMessages("traversal", gltf, {UploadFile::FromBytes(name, {1, 2, 3})});
      expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "resource");
    }
    auto m = test_util::UploadMessages("traversal", tet, {UploadFile::FromBytes("x.bin", {1, 2, 3})});
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, ".gltf");
    m = test_util::UploadMessages("collide", gltf, {UploadFile::FromBytes("scene.gltf", {1})});
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "collides");
    m = test_util::UploadMessages("collide", gltf, {UploadFile::FromBytes("a", {1}), UploadFile::FromBytes("a/b.bin", {2})});
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "collides");
  }
  {  // NUL in a comment or a label
    auto m = test_util::UploadMessages("nul", tet);
    m[0].mutable_metadata()->set_comment(std::string("a\0b", 3));
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "comment");
    m = test_util::UploadMessages("nul", tet);
    (*m[0].mutable_metadata()->mutable_labels())["k"] = std::string("a\0b", 3);
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "labels");
  }
  {  // a chunk over 1 MiB
    std::vector<uint8_t> big((1 << 20) + 1, ' ');
    auto m = test_util::UploadMessages("big", UploadFile::FromBytes("big.obj", big), {}, big.size());
    expect(test_util::IngestRaw(*client_, m, &r), grpc::StatusCode::INVALID_ARGUMENT, "chunk");
  }
  v1::Version v;
  expect_status(test_util::GetVersion(*client_, "no-such-asset", 0, &v), StatusCode::kNotFound, "no-such-asset");
  expect_status(test_util::GetVersion(*client_, "spot", 999, &v), StatusCode::kNotFound, "999");
  expect_status(test_util::GetVersion(*client_, "spot", -1, &v), StatusCode::kInvalidArgument, "version");
  expect_status(test_util::Export(*client_, "no-such-asset", 0, v1::FORMAT_GLB).status, StatusCode::kNotFound, "no-such-asset");
  expect_status(test_util::Export(*client_, "spot", 1, v1::FORMAT_UNSPECIFIED).status, StatusCode::kInvalidArgument, "format");
  expect_status(test_util::Export(*client_, "spot", 1, v1::FORMAT_PROGRESSIVE_GLB, 1).status, StatusCode::kInvalidArgument, "lod");
  v1::Job job;
  expect(Unary([&](grpc::ClientContext* c) {
           v1::GetJobRequest q;
           q.set_job_id("0123456789abcdef");
           return client_->stub().GetJob(c, q, &job);
         }),
         grpc::StatusCode::NOT_FOUND, "job");
  v1::ListAssetsResponse la;
  expect(Unary([&](grpc::ClientContext* c) {
           v1::ListAssetsRequest q;
           q.set_page_size(-1);
           return client_->stub().ListAssets(c, q, &la);
         }),
         grpc::StatusCode::INVALID_ARGUMENT, "page_size");
  expect(Unary([&](grpc::ClientContext* c) {
           v1::ListAssetsRequest q;
           q.set_page_token("not-a-token");
           return client_->stub().ListAssets(c, q, &la);
         }),
         grpc::StatusCode::INVALID_ARGUMENT, "page_token");
  v1::UploadStatus us;
  expect(Unary([&](grpc::ClientContext* c) {
           v1::QueryUploadRequest q;
           q.set_upload_id("never-started");
           return client_->stub().QueryUpload(c, q, &us);
         }),
         grpc::StatusCode::NOT_FOUND, "never-started");
  ExpectHealthy();
}

TEST_F(AssetApi, HealthAndReflectionOnLoopback) {
  ExpectHealthy();
  const auto [status, bytes] = test_util::ListServicesByReflection(client_->channel());
  EXPECT_TRUE(status.ok()) << status.error_message();
  EXPECT_NE(bytes.find("meshstream.v1.AssetService"), std::string::npos) << "reflection is on by default on loopback";
}

}  // namespace
}  // namespace meshstream
