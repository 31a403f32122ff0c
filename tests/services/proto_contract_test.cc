// The public API's names are a contract that independent clients use
// (proto/meshstream/v1/asset_service.proto, issue 9's sketch): services, RPCs
// with their streaming kinds, and enum values, read back from the generated
// descriptors, so renaming any of them fails here.
#include <set>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "meshstream/v1/asset_service.grpc.pb.h"
#include "meshstream/v1/asset_service.pb.h"
#include "meshstream/v1/stream.grpc.pb.h"
#include "meshstream/v1/stream.pb.h"

namespace meshstream {
namespace {

namespace pb = google::protobuf;

TEST(ProtoContract, AssetServiceHasTheContractRpcs) {
  // Touching a message links the generated file, whose descriptors register in the pool.
  ASSERT_NE(meshstream::v1::IngestRequest::descriptor(), nullptr);
  const pb::ServiceDescriptor* service =
      pb::DescriptorPool::generated_pool()->FindServiceByName("meshstream.v1.AssetService");
  ASSERT_NE(service, nullptr);
  EXPECT_EQ(service->full_name(), "meshstream.v1.AssetService");
  EXPECT_STREQ(meshstream::v1::AssetService::service_full_name(), "meshstream.v1.AssetService");  // gRPC codegen
  struct Rpc {
    std::string name, input, output;
    bool client_streaming, server_streaming;
  };
  const std::vector<Rpc> expected = {
      {"Ingest", "IngestRequest", "IngestResponse", true, false},
      {"QueryUpload", "QueryUploadRequest", "UploadStatus", false, false},
      {"GetJob", "GetJobRequest", "Job", false, false},
      {"WatchJob", "GetJobRequest", "Job", false, true},
      {"ListAssets", "ListAssetsRequest", "ListAssetsResponse", false, false},
      {"ListVersions", "ListVersionsRequest", "ListVersionsResponse", false, false},
      {"GetVersion", "GetVersionRequest", "Version", false, false},
      {"Export", "ExportRequest", "ExportChunk", false, true},
  };
  for (const Rpc& rpc : expected) {
    const pb::MethodDescriptor* m = service->FindMethodByName(rpc.name);
    ASSERT_NE(m, nullptr) << rpc.name;
    EXPECT_EQ(m->input_type()->name(), rpc.input) << rpc.name;
    EXPECT_EQ(m->output_type()->name(), rpc.output) << rpc.name;
    EXPECT_EQ(m->client_streaming(), rpc.client_streaming) << rpc.name;
    EXPECT_EQ(m->server_streaming(), rpc.server_streaming) << rpc.name;
  }
}

TEST(ProtoContract, MessagesHaveTheContractFields) {
  const std::vector<std::pair<const pb::Descriptor*, std::vector<std::string>>> expected = {
      {meshstream::v1::IngestMetadata::descriptor(),
       {"asset", "filename", "size", "sha256", "options", "comment", "labels", "upload_id", "write_offset"}},
      {meshstream::v1::EncodeOptions::descriptor(), {"qp", "qn", "qt", "packing", "packet_bytes", "base_ratio"}},
      {meshstream::v1::IngestResource::descriptor(), {"name", "size", "sha256"}},
      {meshstream::v1::IngestRequest::descriptor(), {"metadata", "resource", "chunk"}},
      {meshstream::v1::IngestResponse::descriptor(), {"asset", "version", "job_id", "sha256"}},
      {meshstream::v1::UploadStatus::descriptor(), {"committed_size"}},
      {meshstream::v1::Job::descriptor(), {"id", "state", "progress", "message", "asset", "version"}},
      {meshstream::v1::ListAssetsRequest::descriptor(), {"page_size", "page_token"}},
      {meshstream::v1::ListAssetsResponse::descriptor(), {"assets", "next_page_token"}},
      {meshstream::v1::Asset::descriptor(), {"name", "latest_version", "updated"}},
      {meshstream::v1::ListVersionsRequest::descriptor(), {"asset", "page_size", "page_token"}},
      {meshstream::v1::ListVersionsResponse::descriptor(), {"versions", "next_page_token"}},
      {meshstream::v1::GetVersionRequest::descriptor(), {"asset", "version"}},
      {meshstream::v1::Version::descriptor(),
       {"asset", "version", "state", "source_sha256", "source_size", "options", "encoder", "vertices", "faces",
        "levels", "level_vertices", "progressive_bytes", "reliable_bytes", "unreliable_bytes", "created",
        "comment", "labels"}},
      {meshstream::v1::ExportRequest::descriptor(), {"asset", "version", "format", "lod"}},
      {meshstream::v1::ExportChunk::descriptor(), {"data", "sha256"}},
  };
  for (const auto& [message, fields] : expected) {
    for (const std::string& field : fields) {
      EXPECT_NE(message->FindFieldByName(field), nullptr) << message->name() << "." << field;
    }
  }
  const pb::FieldDescriptor* lod = meshstream::v1::ExportRequest::descriptor()->FindFieldByName("lod");
  ASSERT_NE(lod, nullptr);
  EXPECT_TRUE(lod->has_presence());  // optional: unset means the full mesh
  EXPECT_NE(meshstream::v1::IngestRequest::descriptor()->FindOneofByName("kind"), nullptr);
}

TEST(ProtoContract, EnumsHaveTheContractValues) {
  const std::vector<std::pair<const pb::EnumDescriptor*, std::vector<std::string>>> expected = {
      {meshstream::v1::JobState_descriptor(),
       {"JOB_STATE_PENDING", "JOB_STATE_RUNNING", "JOB_STATE_SUCCEEDED", "JOB_STATE_FAILED"}},
      {meshstream::v1::VersionState_descriptor(),
       {"VERSION_STATE_PROCESSING", "VERSION_STATE_READY", "VERSION_STATE_FAILED"}},
      {meshstream::v1::Format_descriptor(),
       {"FORMAT_GLB", "FORMAT_DRACO_GLB", "FORMAT_PROGRESSIVE_GLB", "FORMAT_OBJ", "FORMAT_PLY"}},
  };
  for (const auto& [e, values] : expected) {
    for (const std::string& v : values) EXPECT_NE(e->FindValueByName(v), nullptr) << e->name() << "." << v;
  }
}

}  // namespace
}  // namespace meshstream

namespace meshstream {
namespace {

// The streaming issue's contract: StreamService.Open, a stream both ways of
// ClientMessage and ServerMessage (proto/meshstream/v1/stream.proto).
TEST(ProtoContract, StreamServiceOpensOneBidirectionalStream) {
  ASSERT_NE(meshstream::v1::ClientMessage::descriptor(), nullptr);
  const pb::ServiceDescriptor* service =
      pb::DescriptorPool::generated_pool()->FindServiceByName("meshstream.v1.StreamService");
  ASSERT_NE(service, nullptr);
  EXPECT_STREQ(meshstream::v1::StreamService::service_full_name(), "meshstream.v1.StreamService");
  const pb::MethodDescriptor* open = service->FindMethodByName("Open");
  ASSERT_NE(open, nullptr);
  EXPECT_EQ(open->input_type()->full_name(), "meshstream.v1.ClientMessage");
  EXPECT_EQ(open->output_type()->full_name(), "meshstream.v1.ServerMessage");
  EXPECT_TRUE(open->client_streaming());
  EXPECT_TRUE(open->server_streaming());
  // The client names asset, version, max level and transport; the server
  // answers with the session (id, headers, base meshes, UDP endpoint, keys).
  for (const char* field : {"asset", "version", "max_level", "transport"}) {
    EXPECT_NE(meshstream::v1::OpenRequest::descriptor()->FindFieldByName(field), nullptr) << field;
  }
  for (const char* field : {"session_id", "primitives", "udp", "udp_session_id", "client_to_server_key",
                            "server_to_client_key"}) {
    EXPECT_NE(meshstream::v1::SessionStart::descriptor()->FindFieldByName(field), nullptr) << field;
  }
  for (const char* field : {"session", "control", "refinement_end", "datagram", "end"}) {
    EXPECT_NE(meshstream::v1::ServerMessage::descriptor()->FindFieldByName(field), nullptr) << field;
  }
  for (const char* field : {"open", "report", "done"}) {
    EXPECT_NE(meshstream::v1::ClientMessage::descriptor()->FindFieldByName(field), nullptr) << field;
  }
}

}  // namespace
}  // namespace meshstream
