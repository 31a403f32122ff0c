#include "services/grpc/proto_convert.h"

#include <algorithm>

#include <google/protobuf/util/time_util.h>

#include "proto/export_formats.h"

namespace meshstream {

namespace {

google::protobuf::Timestamp Timestamp(int64_t unix_ms) {
  return google::protobuf::util::TimeUtil::MillisecondsToTimestamp(unix_ms);
}

v1::VersionState ToProto(VersionState state) {
  switch (state) {
    case VersionState::kProcessing: return v1::VERSION_STATE_PROCESSING;
    case VersionState::kReady: return v1::VERSION_STATE_READY;
    case VersionState::kFailed: return v1::VERSION_STATE_FAILED;
  }
  return v1::VERSION_STATE_UNSPECIFIED;
}

v1::JobState ToProto(JobState state) {
  switch (state) {
    case JobState::kPending: return v1::JOB_STATE_PENDING;
    case JobState::kRunning: return v1::JOB_STATE_RUNNING;
    case JobState::kSucceeded: return v1::JOB_STATE_SUCCEEDED;
    case JobState::kFailed: return v1::JOB_STATE_FAILED;
  }
  return v1::JOB_STATE_UNSPECIFIED;
}

}  // namespace

EncodeSettings FromProto(const v1::EncodeOptions& options) {
  EncodeSettings s;
  s.qp = options.qp();
  s.qn = options.qn();
  s.qt = options.qt();
  s.packing = options.packing();
  s.packet_bytes = options.packet_bytes();
  s.base_ratio = options.base_ratio();
  return s;
}

IngestMeta FromProto(const v1::IngestMetadata& m) {
  IngestMeta meta;
  meta.asset = m.asset();
  meta.filename = m.filename();
  meta.size = m.size();
  meta.sha256 = m.sha256();
  meta.options = FromProto(m.options());
  meta.comment = m.comment();
  meta.labels = std::map<std::string, std::string>(m.labels().begin(), m.labels().end());
  meta.upload_id = m.upload_id();
  meta.write_offset = m.write_offset();
  return meta;
}

ResourceMeta FromProto(const v1::IngestResource& r) { return ResourceMeta{r.name(), r.size(), r.sha256()}; }

StatusOr<ExportFormat> FromProto(v1::Format format) {
  if (const ExportFormatInfo* info = ExportFormatOf(format)) return info->format;
  return InvalidArgument("format: " + std::to_string(static_cast<int>(format)) + " is not one of " +
                         ExportFormatProtoNames());
}

v1::EncodeOptions ToProto(const EncodeSettings& s) {
  v1::EncodeOptions o;
  o.set_qp(s.qp);
  o.set_qn(s.qn);
  o.set_qt(s.qt);
  o.set_packing(s.packing);
  o.set_packet_bytes(s.packet_bytes);
  o.set_base_ratio(s.base_ratio);
  return o;
}

v1::Asset ToProto(const AssetRecord& a) {
  v1::Asset out;
  out.set_name(a.name);
  out.set_latest_version(a.latest_version);
  *out.mutable_updated() = Timestamp(a.updated_ms);
  return out;
}

v1::Version ToProto(const VersionRecord& v) {
  v1::Version out;
  out.set_asset(v.asset);
  out.set_version(v.version);
  out.set_state(ToProto(v.state));
  out.set_source_sha256(v.source.sha256);
  out.set_source_size(v.source.size);
  auto settings = ParseSettingsJson(v.options_json);
  if (settings.ok()) *out.mutable_options() = ToProto(settings.value());
  const ArtifactSummary& a = v.artifact;
  out.set_encoder(a.encoder);
  out.set_vertices(a.vertices);
  out.set_faces(a.faces);
  out.set_levels(a.levels);
  for (int64_t n : a.level_vertices) out.add_level_vertices(n);
  out.set_progressive_bytes(a.progressive_bytes);
  out.set_reliable_bytes(a.reliable_bytes);
  out.set_unreliable_bytes(a.unreliable_bytes);
  *out.mutable_created() = Timestamp(v.created_ms);
  out.set_comment(v.comment);
  for (const auto& [key, value] : v.labels) (*out.mutable_labels())[key] = value;
  out.set_source_filename(v.source.name);
  out.set_job_id(v.job_id);
  out.set_error(v.error);
  out.set_artifact_sha256(a.artifact_sha256);
  for (const SourceFile& r : v.resources) {
    v1::IngestResource* res = out.add_resources();
    res->set_name(r.name);
    res->set_size(r.size);
    res->set_sha256(r.sha256);
  }
  return out;
}

v1::Job ToProto(const JobRecord& j) {
  v1::Job out;
  out.set_id(j.id);
  out.set_state(ToProto(j.state));
  out.set_progress(j.progress);
  out.set_message(j.message);
  out.set_asset(j.asset);
  out.set_version(j.version);
  out.set_attempts(j.attempts);
  *out.mutable_created() = Timestamp(j.created_ms);
  *out.mutable_updated() = Timestamp(j.updated_ms);
  return out;
}

}  // namespace meshstream
