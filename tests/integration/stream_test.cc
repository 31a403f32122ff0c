// The reliable half of a streaming session against a real `meshstream
// serve`: StreamService.Open sends the session start (every primitive's
// stream header and base mesh), then per refinement its control block, its
// datagrams (over gRPC, the protocol's fallback transport) with the codec's
// END datagram and its end, then the session end. What arrives is byte for
// byte the stored artifact's streams; max_level cuts it; a client that asks
// for UDP and never sends a HELLO gets the fallback after the HELLO timeout;
// errors have their codes; a repair sends what is asked once, and refuses
// what does not fit the session.
#include <chrono>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "codec/bitstream/format.h"
#include "meshstream/v1/stream.grpc.pb.h"
#include "services/pipeline/stream_layout.h"
#include "testing/asset_calls.h"
#include "testing/serve_process.h"
#include "testing/test_util.h"

namespace meshstream {
namespace {

using test_util::ServeProcess;

struct Received {
  grpc::Status status;
  v1::SessionStart start;
  std::map<std::pair<uint32_t, uint32_t>, std::string> control;             // (stream, refinement)
  std::map<std::pair<uint32_t, uint32_t>, std::vector<std::string>> datagrams;
  std::vector<std::pair<uint32_t, uint32_t>> order;                        // refinements as they came
  std::string end_reason;
  bool ends_match = true;
  std::vector<v1::TransportChange> changes;
  size_t controls_before_change = 0;
  size_t unreliable_controls = 0;  // control blocks with `reliable` false (their datagrams go as UDP)
  double first_control_ms = -1;    // from the start of OpenSession to the first control block
};

// `after_end`, when given, writes what the client sends after SessionEnd
// (instead of done) and returns true to half-close at once; the datagrams
// that arrive after the end are kept under the key {UINT32_MAX, 0}.
Received OpenSession(const std::shared_ptr<grpc::Channel>& channel, const std::string& asset, int64_t version,
                     int32_t max_level, const std::string& token = "",
                     v1::Transport transport = v1::TRANSPORT_GRPC, bool repair = false,
                     const std::function<void(grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>*)>&
                         after_end = nullptr,
                     std::vector<v1::RepairEnd>* repair_ends = nullptr, v1::Profile profile = v1::PROFILE_AUTO) {
  auto stub = v1::StreamService::NewStub(channel);
  grpc::ClientContext context;
  if (!token.empty()) context.AddMetadata("authorization", "Bearer " + token);
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(120));
  auto stream = stub->Open(&context);
  v1::ClientMessage open;
  open.mutable_open()->set_asset(asset);
  open.mutable_open()->set_version(version);
  open.mutable_open()->set_max_level(max_level);
  open.mutable_open()->set_transport(transport);
  open.mutable_open()->set_repair(repair);
  open.mutable_open()->set_profile(profile);
  Received r;
  const auto begin = std::chrono::steady_clock::now();
  stream->Write(open);
  v1::ServerMessage m;
  std::pair<uint32_t, uint32_t> current{UINT32_MAX, UINT32_MAX};
  while (stream->Read(&m)) {
    switch (m.kind_case()) {
      case v1::ServerMessage::kSession: r.start = m.session(); break;
      case v1::ServerMessage::kTransportChange:
        r.changes.push_back(m.transport_change());
        r.controls_before_change = r.order.size();
        break;
      case v1::ServerMessage::kControl:
        current = {m.control().primitive(), m.control().refinement()};
        r.control[current] = m.control().control();
        r.unreliable_controls += !m.control().reliable();
        if (r.first_control_ms < 0) {
          r.first_control_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
        }
        r.order.push_back(current);
        break;
      case v1::ServerMessage::kDatagram: r.datagrams[current].push_back(m.datagram().payload()); break;
      case v1::ServerMessage::kRefinementEnd:
        r.ends_match = r.ends_match && m.refinement_end().primitive() == current.first &&
                       m.refinement_end().refinement() == current.second &&
                       m.refinement_end().datagrams_sent() + 1 == r.datagrams[current].size();
        break;
      case v1::ServerMessage::kEnd: {
        r.end_reason = m.end().reason();
        current = {UINT32_MAX, 0};
        if (after_end) {
          after_end(stream.get());
          break;
        }
        v1::ClientMessage done;
        done.mutable_done()->set_reason("complete");
        stream->Write(done);
        stream->WritesDone();
        break;
      }
      case v1::ServerMessage::kRepairEnd: {
        if (repair_ends) repair_ends->push_back(m.repair_end());
        v1::ClientMessage done;
        done.mutable_done()->set_reason("complete");
        stream->Write(done);
        stream->WritesDone();
        break;
      }
      default: break;
    }
  }
  r.status = stream->Finish();
  return r;
}

std::string AsString(const std::vector<uint8_t>& v) { return std::string(v.begin(), v.end()); }

TEST(StreamSession, TheSessionIsTheStoredStreamsByteForByte) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "2"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto client = test_util::NewAssetClient((*server)->address());
  for (const char* model : {"spot.obj", "gltf/2CylinderEngine.glb"}) {
    SCOPED_TRACE(model);
    v1::IngestResponse r;
    ASSERT_TRUE(test_util::Ingest(*client, "m", test_util::LoadFile(test_util::ModelPath(model), "m" + std::string(model).substr(std::string(model).rfind('.'))), &r).ok());
    v1::Job job;
    ASSERT_TRUE(test_util::Watch(*client, r.job_id(), &job).ok());
    ASSERT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();
    // The stored artifact, parsed here independently.
    const auto exported = test_util::Export(*client, "m", r.version(), v1::FORMAT_PROGRESSIVE_GLB);
    ASSERT_TRUE(exported.status.ok());
    auto layout = ComputeStreamLayout(exported.bytes.data(), exported.bytes.size());
    ASSERT_TRUE(layout.ok()) << layout.status().ToString();

    // Over the stream alone the session sends the reliable profile's
    // streams (no datagrams), or the loss-tolerant ones when asked: each
    // byte for byte as stored (docs/spec/streaming-protocol.md, "Profiles").
    for (const v1::Profile asked : {v1::PROFILE_AUTO, v1::PROFILE_LOSS_TOLERANT}) {
    SCOPED_TRACE(v1::Profile_Name(asked));
    const bool reliable = asked == v1::PROFILE_AUTO;
    const Received got = OpenSession(client->channel(), "m", 0, -1, "", v1::TRANSPORT_GRPC, false, nullptr, nullptr, asked);
    ASSERT_TRUE(got.status.ok()) << got.status.error_message();
    EXPECT_EQ(got.start.profile(), reliable ? v1::PROFILE_RELIABLE : v1::PROFILE_LOSS_TOLERANT);
    EXPECT_EQ(got.start.version(), r.version());
    EXPECT_EQ(got.start.transport(), v1::TRANSPORT_GRPC) << "the client asked for gRPC";
    EXPECT_EQ(got.start.udp_session_id(), 0u);
    EXPECT_TRUE(got.start.client_to_server_key().empty()) << "no UDP keys for a gRPC session";
    EXPECT_TRUE(got.changes.empty());
    EXPECT_EQ(got.start.session_id().size(), 32u);
    EXPECT_EQ(got.end_reason, "complete");
    EXPECT_TRUE(got.ends_match) << "every refinement's end follows its datagrams";
    ASSERT_EQ(static_cast<size_t>(got.start.primitives_size()), layout->primitives.size());
    size_t refinements = 0;
    for (int i = 0; i < got.start.primitives_size(); ++i) {
      const v1::PrimitiveStart& p = got.start.primitives(i);
      const PrimitiveLayout& entry = layout->primitives[static_cast<size_t>(i)];
      ASSERT_TRUE(entry.has_reliable()) << "the artifact carries both profiles";
      const ByteRange& blob = reliable ? entry.reliable_blob : entry.stream_blob;
      auto stream = ProgressiveStream::Parse(exported.bytes.data() + blob.offset, blob.length);
      ASSERT_TRUE(stream.ok());
      auto header = stream->ParseHeader();
      ASSERT_TRUE(header.ok());
      EXPECT_EQ(header->reliable(), reliable);
      if (reliable) {
        EXPECT_EQ(stream->datagram_count(), 0u);
      }
      EXPECT_EQ(p.primitive(), entry.stream);
      EXPECT_EQ(p.header(), AsString(stream->header));
      EXPECT_EQ(p.base_mesh(), std::string(reinterpret_cast<const char*>(exported.bytes.data() + entry.base.offset),
                                           entry.base.length));
      ASSERT_EQ(p.refinements(), stream->control.size());
      for (uint32_t k = 0; k < p.refinements(); ++k) {
        const auto key = std::make_pair(p.primitive(), k);
        ASSERT_EQ(got.control.count(key), 1u);
        EXPECT_EQ(got.control.at(key), AsString(stream->control[k]));
        const auto it = got.datagrams.find(key);
        const std::vector<std::string> none;
        const std::vector<std::string>& datagrams = it == got.datagrams.end() ? none : it->second;
        // The stored datagrams, then the END datagram the sender makes.
        ASSERT_EQ(datagrams.size(), stream->datagrams[k].size() + 1);
        for (size_t d = 0; d + 1 < datagrams.size(); ++d) EXPECT_EQ(datagrams[d], AsString(stream->datagrams[k][d]));
        EXPECT_EQ(datagrams.back(), AsString(MakeStreamEndDatagram(stream->header.data(), stream->header.size(),
                                                                   p.primitive(), k,
                                                                   static_cast<uint32_t>(stream->datagrams[k].size()))));
        ++refinements;
      }
    }
    EXPECT_EQ(got.order.size(), refinements);
    // The scene carries one-triangle stand-ins for the refined primitives, not their
    // base meshes a second time (they travel Draco-coded above): it stays
    // small beside them.
    size_t base_bytes = 0;
    for (const v1::PrimitiveStart& p : got.start.primitives()) base_bytes += p.base_mesh().size();
    EXPECT_FALSE(got.start.scene_glb().empty());
    EXPECT_LT(got.start.scene_glb().size(), base_bytes / 2 + 8192) << base_bytes << " bytes of base meshes";
    // The scene's order (docs/spec/streaming-protocol.md, "Levels of a scene"):
    // each primitive's refinements in their own order, and its count at
    // every level of the session announced.
    std::map<uint32_t, uint32_t> next;
    for (const auto& [primitive, refinement] : got.order) EXPECT_EQ(refinement, next[primitive]++);
    std::map<uint32_t, uint32_t> at_two;
    for (const v1::PrimitiveStart& p : got.start.primitives()) {
      ASSERT_FALSE(p.level_refinements().empty());
      EXPECT_EQ(p.level_refinements(p.level_refinements_size() - 1), p.refinements());
      at_two[p.primitive()] = p.level_refinements(std::min(1, p.level_refinements_size() - 1));
    }
    // max_level cuts every primitive at the scene's level.
    const Received two = OpenSession(client->channel(), "m", r.version(), 2);
    ASSERT_TRUE(two.status.ok());
    EXPECT_EQ(two.end_reason, "max_level");
    for (const v1::PrimitiveStart& p : two.start.primitives()) {
      EXPECT_EQ(p.refinements(), at_two[p.primitive()]);
      EXPECT_LE(p.level_refinements_size(), 2);
    }
    for (const auto& [key, control] : two.control) EXPECT_LT(key.second, at_two[key.first]);
    }
  }
  EXPECT_EQ((*server)->Terminate(), 0) << (*server)->log();
}

// No round trip is spent waiting for the HELLO: the refinements start on the
// stream at once, paced (0.2 Mbit/s here, so that the horse outlasts the
// HELLO timeout), and the session changes to gRPC when the wait runs out.
TEST(StreamSession, WithoutAHelloTheDatagramsFallBackToTheStream) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1", "--hello-timeout", "300",
                                     "--max-session-rate", "0.2"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto client = test_util::NewAssetClient((*server)->address());
  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*client, "m", test_util::LoadFile(test_util::ModelPath("horse.ply"), "m.ply"), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client, r.job_id(), &job).ok());
  ASSERT_EQ(job.state(), v1::JOB_STATE_SUCCEEDED) << job.message();
  const auto begin = std::chrono::steady_clock::now();
  const Received got = OpenSession(client->channel(), "m", 0, -1, "", v1::TRANSPORT_UDP);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - begin).count();
  ASSERT_TRUE(got.status.ok()) << got.status.error_message();
  // The server offered UDP with an endpoint and two distinct keys ...
  EXPECT_EQ(got.start.transport(), v1::TRANSPORT_UDP);
  EXPECT_NE(got.start.udp().port(), 0u);
  EXPECT_NE(got.start.udp_session_id(), 0u);
  EXPECT_EQ(got.start.client_to_server_key().size(), 32u);
  EXPECT_EQ(got.start.server_to_client_key().size(), 32u);
  EXPECT_NE(got.start.client_to_server_key(), got.start.server_to_client_key());
  // ... sent refinements on the stream from the start without waiting ...
  // (a refinement before the transport change: the count says so, whatever
  // the machine's speed; the time is printed for who reads the log)
  EXPECT_GE(got.first_control_ms, 0.0);
  EXPECT_GE(got.controls_before_change, 1u) << "the first refinement waited for the HELLO timeout";
  EXPECT_EQ(got.unreliable_controls, 0u) << "with no address proven every refinement is on the stream";
  // ... and, with no HELLO, changed to gRPC between two refinements.
  ASSERT_EQ(got.changes.size(), 1u);
  EXPECT_EQ(got.changes[0].transport(), v1::TRANSPORT_GRPC);
  EXPECT_NE(got.changes[0].reason().find("HELLO"), std::string::npos) << got.changes[0].reason();
  EXPECT_LT(got.controls_before_change, got.order.size()) << "the horse outlasted the wait";
  EXPECT_GE(ms, 300.0) << "the fallback comes after the HELLO timeout";
  EXPECT_EQ(got.end_reason, "complete");
  EXPECT_TRUE(got.ends_match);
  EXPECT_FALSE(got.datagrams.empty());
  EXPECT_EQ((*server)->Terminate(), 0) << (*server)->log();
}

TEST(StreamSession, ErrorsHaveTheirCodes) {
  test_util::TempDir dir;
  const std::string store = dir.File("store");
  auto server = ServeProcess::Start({"--store", store, "--auth", "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const auto made = test_util::RunCommand(test_util::Cli() + " token create --json --store " + test_util::Quote(store) +
                                          " --tenant a");
  ASSERT_EQ(made.exit_code, 0) << made.err;
  const std::string token = nlohmann::json::parse(made.out)["token"].get<std::string>();
  const auto client = test_util::NewAssetClient((*server)->address(), token);
  EXPECT_EQ(OpenSession(client->channel(), "x", 0, -1).status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_EQ(OpenSession(client->channel(), "x", 0, -1, token).status.error_code(), grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(OpenSession(client->channel(), "../x", 0, -1, token).status.error_code(),
            grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_EQ(OpenSession(client->channel(), "x", 0, -5, token).status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  const std::string junk = "not an obj\n";
  v1::IngestResponse r;
  ASSERT_TRUE(test_util::Ingest(*client, "junk", sdk::UploadFile::FromBytes("junk.obj", std::vector<uint8_t>(junk.begin(), junk.end())), &r).ok());
  v1::Job job;
  ASSERT_TRUE(test_util::Watch(*client, r.job_id(), &job).ok());
  EXPECT_EQ(OpenSession(client->channel(), "junk", 0, -1, token).status.error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ((*server)->Terminate(), 0);
}

TEST(StreamSession, RepairSendsWhatIsAskedOnceAndRefusesWhatDoesNotFit) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const Status ingested = test_util::IngestSharedModel((*server)->address(), "spot", "spot.obj");
  ASSERT_TRUE(ingested.ok()) << ingested.ToString();
  const auto client = test_util::NewAssetClient((*server)->address());

  auto ask = [](std::vector<std::pair<uint32_t, std::vector<uint32_t>>> items, int times) {
    return [items, times](grpc::ClientReaderWriter<v1::ClientMessage, v1::ServerMessage>* stream) {
      v1::ClientMessage m;
      for (const auto& [refinement, datagrams] : items) {
        v1::RepairItem& item = *m.mutable_repair()->add_items();
        item.set_primitive(0);
        item.set_refinement(refinement);
        for (uint32_t k : datagrams) item.add_datagrams(k);
      }
      for (int i = 0; i < times; ++i) stream->Write(m);
    };
  };
  // The repair asks for datagrams: the loss-tolerant profile's (the
  // reliable one, what a gRPC-only session gets by default, has none).
  constexpr v1::Profile kLossTolerant = v1::PROFILE_LOSS_TOLERANT;
  // Datagram 1 of refinement 3 and 0 of refinement 12, the first asked twice: each sent once.
  std::vector<v1::RepairEnd> ends;
  const Received repaired = OpenSession(client->channel(), "spot", 0, -1, "", v1::TRANSPORT_GRPC, true,
                                        ask({{3, {1, 1}}, {12, {0}}}, 1), &ends, kLossTolerant);
  ASSERT_TRUE(repaired.status.ok()) << repaired.status.error_message();
  ASSERT_EQ(ends.size(), 1u);
  EXPECT_EQ(ends[0].datagrams(), 2u);
  const auto& after = repaired.datagrams.at({UINT32_MAX, 0});
  ASSERT_EQ(after.size(), 2u);
  EXPECT_EQ(after[0], repaired.datagrams.at({0, 3})[1]) << "the stored datagram, byte for byte";
  EXPECT_EQ(after[1], repaired.datagrams.at({0, 12})[0]);
  EXPECT_EQ(ends[0].bytes(), after[0].size() + after[1].size());

  // What does not fit the session: INVALID_ARGUMENT, nothing sent.
  const Received beyond = OpenSession(client->channel(), "spot", 0, -1, "", v1::TRANSPORT_GRPC, true,
                                      ask({{3, {999}}}, 1), nullptr, kLossTolerant);
  EXPECT_EQ(beyond.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(beyond.status.error_message().find("datagram 999"), std::string::npos) << beyond.status.error_message();
  EXPECT_EQ(beyond.datagrams.count({UINT32_MAX, 0}), 0u);
  const Received unknown = OpenSession(client->channel(), "spot", 0, -1, "", v1::TRANSPORT_GRPC, true,
                                       ask({{200, {0}}}, 1), nullptr, kLossTolerant);
  EXPECT_EQ(unknown.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  std::vector<v1::RepairEnd> twice_ends;
  const Received twice = OpenSession(client->channel(), "spot", 0, -1, "", v1::TRANSPORT_GRPC, true,
                                     ask({{3, {0}}}, 2), &twice_ends, kLossTolerant);
  EXPECT_TRUE(twice.status.ok()) << twice.status.error_message();
  EXPECT_EQ(twice_ends.size(), 1u) << "once per session: the second request is never read";
  EXPECT_EQ(twice.datagrams.at({UINT32_MAX, 0}).size(), 1u);
  const Received unasked = OpenSession(client->channel(), "spot", 0, -1, "", v1::TRANSPORT_GRPC, false,
                                       ask({{3, {0}}}, 1), nullptr, kLossTolerant);
  EXPECT_EQ(unasked.status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << "a session opened without repair";
  EXPECT_EQ((*server)->Terminate(), 0);
}

// An error that ends a session whose writes wait for the client (it has not
// read yet) keeps its status for the client that then reads, instead of a
// cancellation.
TEST(StreamSession, AnErrorWhileTheClientIsNotReadingKeepsItsStatus) {
  test_util::TempDir dir;
  auto server = ServeProcess::Start({"--store", dir.File("store"), "--workers", "1"});
  ASSERT_TRUE(server.ok()) << server.status().ToString();
  const Status ingested = test_util::IngestSharedModel((*server)->address(), "horse", "horse.ply");
  ASSERT_TRUE(ingested.ok()) << ingested.ToString();
  // A small receive window, never grown: the server's writes wait while the
  // client does not read.
  grpc::ChannelArguments args;
  args.SetInt(GRPC_ARG_HTTP2_BDP_PROBE, 0);
  args.SetInt(GRPC_ARG_HTTP2_STREAM_LOOKAHEAD_BYTES, 16384);
  auto channel = grpc::CreateCustomChannel((*server)->address(), grpc::InsecureChannelCredentials(), args);
  auto stub = v1::StreamService::NewStub(channel);
  grpc::ClientContext context;
  context.set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  auto stream = stub->Open(&context);
  v1::ClientMessage open;
  open.mutable_open()->set_asset("horse");
  open.mutable_open()->set_max_level(-1);
  open.mutable_open()->set_transport(v1::TRANSPORT_GRPC);
  ASSERT_TRUE(stream->Write(open));
  // The session has started (its first message read) before the repair
  // arrives, however long its opening took; then the client stops reading
  // and the server's writes fill the small window.
  v1::ServerMessage first;
  ASSERT_TRUE(stream->Read(&first));
  ASSERT_TRUE(first.has_session());
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  v1::ClientMessage repair;  // a session opened without repair may not ask for one
  v1::RepairItem& item = *repair.mutable_repair()->add_items();
  item.set_primitive(0);
  item.set_refinement(0);
  item.add_datagrams(0);
  stream->Write(repair);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  v1::ServerMessage m;
  size_t read = 1;
  bool ended = false;
  while (stream->Read(&m)) {
    ++read;
    ended = ended || m.has_end();
  }
  const grpc::Status status = stream->Finish();
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("repair"), std::string::npos) << status.error_message();
  EXPECT_GT(read, 0u);
  EXPECT_FALSE(ended) << "the session ended at the error, not after its last refinement";
  EXPECT_EQ((*server)->Terminate(), 0);
}

}  // namespace
}  // namespace meshstream
