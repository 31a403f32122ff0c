// Between the protobuf messages of proto/meshstream/v1 and the library's
// records. Pure translation: no validation beyond what a type change needs
// (the library validates).
#ifndef MESHSTREAM_SERVICES_GRPC_PROTO_CONVERT_H_
#define MESHSTREAM_SERVICES_GRPC_PROTO_CONVERT_H_

#include <vector>

#include "meshstream/v1/asset_service.pb.h"
#include "services/ingest/ingest_upload.h"
#include "services/pipeline/encode_options.h"
#include "services/pipeline/export_artifact.h"
#include "services/store/store.h"

namespace meshstream {

EncodeSettings FromProto(const v1::EncodeOptions& options);
IngestMeta FromProto(const v1::IngestMetadata& metadata);
ResourceMeta FromProto(const v1::IngestResource& resource);
StatusOr<ExportFormat> FromProto(v1::Format format);

v1::EncodeOptions ToProto(const EncodeSettings& settings);
v1::Asset ToProto(const AssetRecord& asset);
v1::Version ToProto(const VersionRecord& version);
v1::Job ToProto(const JobRecord& job);

}  // namespace meshstream

#endif  // MESHSTREAM_SERVICES_GRPC_PROTO_CONVERT_H_
