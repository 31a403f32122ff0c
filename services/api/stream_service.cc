#include "services/api/stream_service.h"

#include <chrono>
#include <string>

#include "services/api/call_auth.h"
#include "services/api/grpc_status.h"
#include "services/export/version_export.h"
#include "services/store/blob_store.h"
#include "services/streaming/session_plan.h"

namespace meshstream {

namespace {

std::string Slice(const std::vector<uint8_t>& bytes, const ByteRange& r) {
  return std::string(reinterpret_cast<const char*>(bytes.data() + r.offset), r.length);
}

}  // namespace

StreamServiceImpl::StreamServiceImpl(Store* store, const Authenticator* auth, StreamServiceOptions options,
                                     const std::atomic<bool>* draining)
    : store_(store), auth_(auth), options_(options), draining_(draining), sessions_(options.max_sessions) {}

grpc::Status StreamServiceImpl::Open(grpc::ServerContext* context,
                                     grpc::ServerReaderWriter<v1::ServerMessage, v1::ClientMessage>* stream) {
  auto principal = AuthenticateCall(*auth_, *context);
  if (!principal.ok()) return ToGrpcStatus(principal.status());
  CallLimit::Slot slot = sessions_.Acquire(std::chrono::milliseconds(0));
  if (!slot) {
    return ToGrpcStatus(ResourceExhausted("Open: " + std::to_string(sessions_.limit()) +
                                          " sessions are running on this server; retry later"));
  }
  v1::ClientMessage first;
  if (!stream->Read(&first)) return ToGrpcStatus(InvalidArgument("the first message must be open"));
  if (first.kind_case() != v1::ClientMessage::kOpen) {
    return ToGrpcStatus(InvalidArgument("the first message must be open"));
  }
  const v1::OpenRequest& open = first.open();
  Status s = CheckName("asset", open.asset());
  if (!s.ok()) return ToGrpcStatus(s);
  if (open.max_level() < -1) return ToGrpcStatus(InvalidArgument("max_level: -1 (all) or a level >= 0"));
  auto version = ResolveReadyVersion(*store_, principal->tenant, open.asset(), open.version());
  if (!version.ok()) return ToGrpcStatus(version.status());
  auto artifact = store_->GetBlob(version->artifact.artifact_sha256, options_.max_artifact_bytes);
  if (!artifact.ok()) return ToGrpcStatus(artifact.status());
  auto plan = PlanSession(artifact.value(), version->artifact.layout_json, open.max_level());
  if (!plan.ok()) return ToGrpcStatus(plan.status());
  const std::vector<uint8_t>& bytes = artifact.value();

  v1::ServerMessage message;
  v1::SessionStart& start = *message.mutable_session();
  start.set_session_id(RandomHex(16));
  start.set_asset(version->asset);
  start.set_version(version->version);
  start.set_transport(v1::TRANSPORT_GRPC);
  for (const PlannedPrimitive& p : plan->primitives) {
    v1::PrimitiveStart& out = *start.add_primitives();
    out.set_primitive(p.stream);
    out.set_mesh(p.mesh);
    out.set_mesh_primitive(p.mesh_primitive);
    out.set_header(Slice(bytes, p.header));
    out.set_base_mesh(Slice(bytes, p.base));
    out.set_refinements(p.refinements);
    for (const auto& [name, id] : p.draco_attributes) (*out.mutable_draco_attributes())[name] = id;
  }
  if (!stream->Write(message)) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
  for (const PlannedRefinement& r : plan->refinements) {
    if (context->IsCancelled()) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
    if (draining_ != nullptr && draining_->load()) {
      return ToGrpcStatus(Unavailable("the server is shutting down; open the session again"));
    }
    const uint32_t stream_id = plan->primitives[r.primitive].stream;
    v1::ServerMessage control;
    control.mutable_control()->set_primitive(stream_id);
    control.mutable_control()->set_refinement(r.refinement);
    control.mutable_control()->set_control(Slice(bytes, r.control));
    control.mutable_control()->set_datagrams(static_cast<uint32_t>(r.datagrams.size()));
    if (!stream->Write(control)) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
    for (const ByteRange& d : r.datagrams) {
      v1::ServerMessage datagram;
      datagram.mutable_datagram()->set_payload(Slice(bytes, d));
      if (!stream->Write(datagram)) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
    }
    v1::ServerMessage end;
    end.mutable_refinement_end()->set_primitive(stream_id);
    end.mutable_refinement_end()->set_refinement(r.refinement);
    end.mutable_refinement_end()->set_datagrams_sent(static_cast<uint32_t>(r.datagrams.size()));
    if (!stream->Write(end)) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
  }
  v1::ServerMessage end;
  end.mutable_end()->set_reason(open.max_level() >= 0 ? "max_level" : "complete");
  if (!stream->Write(end)) return grpc::Status(grpc::StatusCode::CANCELLED, "the client went away");
  // Over gRPC everything has been delivered once SessionEnd is written:
  // the session ends here (no report can change what was sent), so a
  // draining server never waits for a client that keeps its stream open.
  return grpc::Status::OK;
}

}  // namespace meshstream
