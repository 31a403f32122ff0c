// The client verbs of the CLI against a real server: ingest (with --wait and
// --json, a multi-file .gltf, resuming an upload the server already holds
// part of), versions, assets, export in every format, the environment
// variables, and exit code 3 when no server answers.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "services/store/blob_store.h"
#include "testing/asset_calls.h"
#include "tests/common/cli_util.h"
#include "testing/serve_process.h"
#include "testing/loopback_socket.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using nlohmann::json;
using test_util::Cli;
using test_util::ModelPath;
using test_util::Quote;
using test_util::RunCommand;
using test_util::ServeProcess;

class CliRemote : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const Status started = suite_.Start();
    ASSERT_TRUE(started.ok()) << started.ToString();
  }
  static void TearDownTestSuite() {
    std::string log;
    EXPECT_EQ(suite_.Stop(&log), 0) << log;
  }
  static std::string Remote() { return " --server " + server_->address(); }
  static inline test_util::SuiteServer suite_;
  static inline test_util::TempDir*& dir_ = suite_.dir;
  static inline ServeProcess*& server_ = suite_.server;
};

TEST_F(CliRemote, IngestWaitVersionsAndExportEveryFormat) {
  const json in = test_util::RunCliJson("ingest --json --wait --asset fandisk --comment first --label team=cad " +
                                        Quote(ModelPath("fandisk.obj")) + Remote());
  EXPECT_EQ(in["asset"], "fandisk");
  EXPECT_EQ(in["version"], 1);
  EXPECT_EQ(in["sha256"].get<std::string>().size(), 64u);
  ASSERT_TRUE(in.contains("job")) << in.dump();
  EXPECT_EQ(in["job"]["state"], "JOB_STATE_SUCCEEDED") << in.dump();

  const json versions = test_util::RunCliJson("versions --json fandisk" + Remote());
  ASSERT_EQ(versions["versions"].size(), 1u) << versions.dump();
  const json& v = versions["versions"][0];
  EXPECT_EQ(v["state"], "VERSION_STATE_READY");
  EXPECT_EQ(v["comment"], "first");
  EXPECT_EQ(v["labels"]["team"], "cad");
  EXPECT_EQ(v["vertices"], 6475);
  EXPECT_EQ(v["source_filename"], "fandisk.obj");

  test_util::TempDir out;
  for (const char* format : {"glb", "draco", "progressive", "obj", "ply"}) {
    const std::string file = out.File(std::string("fandisk.") + format + (std::string(format) == "obj"   ? ".obj"
                                                                           : std::string(format) == "ply" ? ".ply"
                                                                                                          : ".glb"));
    const json e = test_util::RunCliJson("export --json fandisk -o " + Quote(file) + " --format " + format + Remote());
    EXPECT_EQ(e["version"], 1) << format;
    const auto bytes = ReadFileBytes(file, 1 << 30);
    ASSERT_TRUE(bytes.ok()) << format;
    EXPECT_EQ(e["sha256"], Sha256Hex(bytes->data(), bytes->size())) << format;
  }
  // The OBJ export is the mesh on the grid of the stored qp.
  const json c = test_util::RunCliJson("compare --json --qp " + std::to_string(v["options"]["qp"].get<int>()) + " " +
                                       Quote(ModelPath("fandisk.obj")) + " " + Quote(out.File("fandisk.obj.obj")));
  EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
  const json assets = test_util::RunCliJson("assets --json" + Remote());
  EXPECT_EQ(assets["assets"].size(), 1u) << assets.dump();
}

TEST_F(CliRemote, FetchStreamsTheFullMeshOnTheGrid) {
  const json in = test_util::RunCliJson("ingest --json --wait --asset spot-fetch " + Quote(ModelPath("spot.obj")) + Remote());
  ASSERT_EQ(in["job"]["state"], "JOB_STATE_SUCCEEDED") << in.dump();
  test_util::TempDir out;
  const std::string file = out.File("spot.glb");
  const json f = test_util::RunCliJson("fetch --json spot-fetch -o " + Quote(file) + Remote());
  for (const char* key : {"vertices", "faces", "levels_applied", "transport", "datagrams_received", "datagrams_lost",
                          "datagrams_rejected", "predicted_vertices", "reliable_bytes", "unreliable_bytes",
                          "time_to_base_ms", "time_to_full_ms"}) {
    EXPECT_TRUE(f.contains(key)) << key << " in " << f.dump();
  }
  EXPECT_EQ(f["vertices"], 3225);
  EXPECT_EQ(f["transport"], "udp");
  EXPECT_EQ(f["datagrams_rejected"], 0);
  EXPECT_EQ(f["datagrams_lost"], 0) << "loopback, paced: nothing lost";
  EXPECT_EQ(f["predicted_vertices"], 0);
  EXPECT_GT(f["datagrams_received"].get<int>(), 0);
  const json c = test_util::RunCliJson("compare --json --qp 11 " + Quote(ModelPath("spot.obj")) + " " + Quote(file));
  EXPECT_TRUE(c.value("same_on_grid", false)) << c.dump();
  for (const json& report : test_util::ValidateGltf({file})) EXPECT_EQ(report.value("errors", -1), 0) << report.dump();
  // --tcp-only: the same mesh over the gRPC stream.
  // With --threads 2 the whole refinements decode on two threads: the same mesh.
  EXPECT_EQ(f["threads"], 1);
  EXPECT_EQ(f["parallel_splits"], 0);
  const json tcp =
      test_util::RunCliJson("fetch --json --tcp-only --threads 2 spot-fetch -o " + Quote(out.File("tcp.glb")) + Remote());
  EXPECT_EQ(tcp["transport"], "grpc");
  EXPECT_EQ(tcp["vertices"], 3225);
  EXPECT_EQ(tcp["threads"], 2);
  EXPECT_GT(tcp["parallel_splits"].get<int>(), 0);
  const json same = test_util::RunCliJson("compare --json --qp 11 " + Quote(file) + " " + Quote(out.File("tcp.glb")));
  EXPECT_EQ(same.value("hausdorff_vertex", 1.0), 0.0) << same.dump();
  // --lod stops early.
  const json base = test_util::RunCliJson("fetch --json spot-fetch --lod 0 -o " + Quote(out.File("base.glb")) + Remote());
  EXPECT_EQ(base["levels_applied"], 0);
  EXPECT_LT(base["vertices"].get<int>(), 3225);
  const auto missing = RunCommand(Cli() + " fetch no-such -o " + Quote(out.File("x.glb")) + Remote());
  EXPECT_EQ(missing.exit_code, 1) << missing.err;
  // --repair on a loss-free link: nothing to repair, the exact mesh at once.
  const json rep = test_util::RunCliJson("fetch --json --repair --expected-loss 0.3 spot-fetch -o " +
                                         Quote(out.File("rep.glb")) + Remote());
  for (const char* key : {"repair", "repaired_datagrams", "repair_bytes", "time_to_exact_ms", "repair_error",
                          "reliable_refinements", "reliable_datagram_bytes"}) {
    EXPECT_TRUE(rep.contains(key)) << key << " in " << rep.dump();
  }
  EXPECT_EQ(rep["repair"], true);
  EXPECT_EQ(rep["repaired_datagrams"], 0);
  EXPECT_EQ(rep["vertices"], 3225);
  EXPECT_GT(rep["time_to_exact_ms"].get<double>(), 0.0);
  EXPECT_GT(rep["reliable_refinements"].get<int>(), 0) << "the artifact's reliable cut";
  const auto bad = RunCommand(Cli() + " fetch --expected-loss 2 spot-fetch -o " + Quote(out.File("y.glb")) + Remote());
  EXPECT_EQ(bad.exit_code, 2) << bad.err;
}

TEST_F(CliRemote, AMultiFileGltfTravelsWithItsResources) {
  const std::string gltf = ModelPath("gltf/draco-2CylinderEngine/2CylinderEngine.gltf");
  const json in = test_util::RunCliJson("ingest --json --wait --asset engine " + Quote(gltf) + Remote());
  EXPECT_EQ(in["job"]["state"], "JOB_STATE_SUCCEEDED") << in.dump();
  const json versions = test_util::RunCliJson("versions --json engine" + Remote());
  ASSERT_EQ(versions["versions"][0]["resources"].size(), 1u) << versions.dump();
  EXPECT_EQ(versions["versions"][0]["resources"][0]["name"], "2CylinderEngine.bin");
}

TEST_F(CliRemote, IngestResumesAnUploadTheServerHoldsPartOf) {
  // What an interrupted `meshstream ingest` leaves: the first 512 KiB under
  // the CLI's upload id (docs/spec/cli.md: "cli-" + 48 hex digits of
  // SHA-256(asset + "\n" + file digest)).
  const std::vector<uint8_t> horse = ReadFileBytes(ModelPath("horse.ply"), 1 << 30).value();
  const std::string digest = Sha256Hex(horse.data(), horse.size());
  const std::string key = "horse\n" + digest;
  const std::string upload_id =
      "cli-" + Sha256Hex(reinterpret_cast<const uint8_t*>(key.data()), key.size()).substr(0, 48);
  const auto client = test_util::NewAssetClient(server_->address());
  auto messages = test_util::UploadMessages("horse", sdk::UploadFile::FromBytes("horse.ply", horse), {}, 512 << 10);
  messages.resize(2);  // metadata and the first chunk only
  messages[0].mutable_metadata()->set_upload_id(upload_id);
  {
    grpc::ClientContext context;
    test_util::Prepare(*client, context);
    v1::IngestResponse response;
    auto writer = client->stub().Ingest(&context, &response);
    ASSERT_TRUE(writer->Write(messages[0]) && writer->Write(messages[1]));
    ASSERT_TRUE(test_util::WaitForCommitted(*client, upload_id, 512 << 10)) << "the chunk was never committed";
    context.TryCancel();
    writer->Finish();
  }
  const json in = test_util::RunCliJson("ingest --json --asset horse " + Quote(ModelPath("horse.ply")) + Remote());
  EXPECT_EQ(in.value("resumed_from", 0), 512 << 10) << in.dump();
  EXPECT_EQ(in["sha256"], digest);
}

TEST_F(CliRemote, ServerAndTokenFromTheEnvironment) {
  const auto r = RunCommand("MESHSTREAM_SERVER=" + server_->address() + " " + Cli() + " assets --json");
  EXPECT_EQ(r.exit_code, 0) << r.err;
}

TEST_F(CliRemote, ExitCodesForAMissingServerAndRefusedRequests) {
  const auto unreachable = RunCommand(Cli() + " versions x --server 127.0.0.1:1 --timeout 5");
  EXPECT_EQ(unreachable.exit_code, 3) << unreachable.err;
  EXPECT_NE(unreachable.err.find("127.0.0.1:1"), std::string::npos) << unreachable.err;
  // A listener that never answers: the request's deadline (--timeout) runs
  // out, which is exit 3 like an unreachable server (docs/spec/cli.md).
  {
    test_util::LoopbackSocket listener(true);
    ASSERT_TRUE(listener.ok());
    const std::string stalled = listener.address();
    const auto late = RunCommand(Cli() + " versions x --server " + stalled + " --timeout 0.5");
    listener.Close();
    EXPECT_EQ(late.exit_code, 3) << late.err;
    EXPECT_NE(late.err.find("--timeout 0.5 s per request"), std::string::npos) << late.err;
    EXPECT_NE(late.err.find(stalled), std::string::npos) << late.err;
  }
  const auto missing = RunCommand(Cli() + " versions no-such-asset" + Remote());
  EXPECT_EQ(missing.exit_code, 1) << missing.err;
  const auto bad_name = RunCommand(Cli() + " export '../x' -o /tmp/x.glb" + Remote());
  EXPECT_EQ(bad_name.exit_code, 2) << bad_name.err;
  const auto failed = RunCommand("printf 'junk\\n' > " + Quote(dir_->File("junk.obj")) + " && " + Cli() +
                                 " ingest --wait " + Quote(dir_->File("junk.obj")) + Remote());
  EXPECT_EQ(failed.exit_code, 1) << failed.err;
  EXPECT_NE(failed.err.find("failed"), std::string::npos) << failed.err;
}

}  // namespace
}  // namespace meshstream
