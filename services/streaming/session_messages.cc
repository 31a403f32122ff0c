#include "services/streaming/session_messages.h"

#include <algorithm>

#include "net/packet_header.h"

namespace meshstream {

namespace {

std::string Slice(const std::vector<uint8_t>& bytes, const ByteRange& r) {
  return std::string(reinterpret_cast<const char*>(bytes.data() + r.offset), r.length);
}

}  // namespace

v1::Transport ToProto(SessionTransport t) {
  return t == SessionTransport::kUdp ? v1::TRANSPORT_UDP : v1::TRANSPORT_GRPC;
}

v1::ServerMessage SessionStartMessage(const SessionPlan& plan, const std::vector<uint8_t>& artifact,
                                      SessionTransport transport) {
  v1::ServerMessage message;
  v1::SessionStart& start = *message.mutable_session();
  start.set_transport(ToProto(transport));
  start.set_profile(plan.reliable_profile ? v1::PROFILE_RELIABLE : v1::PROFILE_LOSS_TOLERANT);
  start.set_max_datagram_bytes(static_cast<uint32_t>(kMaxDatagramBytes));
  for (const PlannedPrimitive& p : plan.primitives) {
    v1::PrimitiveStart& out = *start.add_primitives();
    out.set_primitive(p.stream);
    out.set_mesh(p.mesh);
    out.set_mesh_primitive(p.mesh_primitive);
    out.set_header(Slice(artifact, p.header));
    out.set_base_mesh(Slice(artifact, p.base));
    out.set_refinements(p.refinements);
    for (uint32_t n : p.level_refinements) out.add_level_refinements(n);
    for (const auto& [name, id] : p.draco_attributes) (*out.mutable_draco_attributes())[name] = id;
  }
  return message;
}

v1::ServerMessage TransportChangeMessage(SessionTransport transport, const std::string& reason) {
  v1::ServerMessage m;
  m.mutable_transport_change()->set_transport(ToProto(transport));
  m.mutable_transport_change()->set_reason(reason);
  return m;
}

v1::ServerMessage ControlMessage(const std::vector<uint8_t>& artifact, const SenderAction& control) {
  v1::ServerMessage m;
  v1::ControlBlock& c = *m.mutable_control();
  c.set_primitive(control.stream);
  c.set_refinement(control.refinement->refinement);
  c.set_control(Slice(artifact, control.refinement->control));
  c.set_datagrams(control.count);
  c.set_first_packet_number(control.first_packet_number);
  c.set_reliable(control.reliable);
  c.set_before_proof(control.before_proof);
  c.set_parity_follows(control.parity_follows);
  return m;
}

v1::ServerMessage DatagramMessage(const uint8_t* data, size_t size) {
  v1::ServerMessage m;
  m.mutable_datagram()->set_payload(reinterpret_cast<const char*>(data), size);
  return m;
}

v1::ServerMessage RefinementEndMessage(uint32_t stream, uint32_t refinement, uint32_t datagrams_sent,
                                       uint32_t parity_datagrams) {
  v1::ServerMessage m;
  m.mutable_refinement_end()->set_primitive(stream);
  m.mutable_refinement_end()->set_refinement(refinement);
  m.mutable_refinement_end()->set_datagrams_sent(datagrams_sent);
  if (parity_datagrams > 0) m.mutable_refinement_end()->set_parity_datagrams(parity_datagrams);
  return m;
}

v1::ServerMessage EndMessage(const std::string& reason) {
  v1::ServerMessage m;
  m.mutable_end()->set_reason(reason);
  return m;
}

v1::ServerMessage RepairEndMessage(uint32_t datagrams, uint64_t bytes) {
  v1::ServerMessage m;
  m.mutable_repair_end()->set_datagrams(datagrams);
  m.mutable_repair_end()->set_bytes(bytes);
  return m;
}

StatusOr<View> FromProto(const v1::View& view) {
  if (view.camera_position_size() != 3) {
    return InvalidArgument("view.camera_position: 3 numbers, not " + std::to_string(view.camera_position_size()));
  }
  if (view.view_projection_size() != 16) {
    return InvalidArgument("view.view_projection: 16 numbers, not " + std::to_string(view.view_projection_size()));
  }
  View v;
  for (int a = 0; a < 3; ++a) v.camera[a] = view.camera_position(a);
  for (int i = 0; i < 16; ++i) v.view_projection[i] = view.view_projection(i);
  v.viewport_width = view.viewport_width();
  v.viewport_height = view.viewport_height();
  const Status checked = CheckView(v);
  if (!checked.ok()) return InvalidArgument(checked.message());
  return v;
}

v1::ServerMessage LevelPlanMessage(const SessionPlan& plan, uint32_t first_changed_level) {
  v1::ServerMessage m;
  v1::LevelPlan* levels = m.mutable_levels();
  levels->set_first_changed_level(first_changed_level);
  for (const PlannedPrimitive& p : plan.primitives) {
    v1::PrimitiveLevels* out = levels->add_primitives();
    for (uint32_t r : p.level_refinements) out->add_level_refinements(r);
  }
  return m;
}

ClientReportInfo FromProto(const v1::ClientReport& r) {
  ClientReportInfo info;
  info.stream = r.primitive();
  info.refinement = r.refinement();
  info.received = r.datagrams_received();
  info.missing = static_cast<uint32_t>(std::min<int>(r.missing_size(), 1 << 20));
  // Runs of consecutive missing ordinals (the client lists them ascending):
  // missing / runs is the mean loss run the sender sizes parity for.
  for (int i = 0; i < r.missing_size() && i < (1 << 20); ++i) {
    if (i == 0 || r.missing(i) != r.missing(i - 1) + 1) ++info.missing_runs;
  }
  info.end_received = r.end_received();
  info.hold_us = r.hold_us();
  info.arrival_span_us = r.arrival_span_us();
  info.span_bytes = r.span_bytes();
  for (int i = 0; i < r.rtt_samples_us_size() && i < 16; ++i) info.rtt_samples_us.push_back(r.rtt_samples_us(i));
  return info;
}

std::vector<RepairItem> FromProto(const v1::RepairRequest& request) {
  std::vector<RepairItem> items;
  items.reserve(static_cast<size_t>(request.items_size()));
  for (const v1::RepairItem& item : request.items()) {
    items.push_back(RepairItem{item.primitive(), item.refinement(),
                               std::vector<uint32_t>(item.datagrams().begin(), item.datagrams().end())});
  }
  return items;
}

}  // namespace meshstream
