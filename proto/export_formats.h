// The export formats of a version's files: one row per format, read by every
// place that names one (the CLI's `export --format`, the gRPC Export RPC's
// `Format` enum, the HTTP file routes' `{format}` segment and content type,
// the exporter's temporary file and its cache key). Adding a format is one
// row here and its conversion in services/pipeline/export_artifact.cc.
//
// Contract: the lookups are total (an unknown name or enum value gives
// nullptr, never a default); the table is constant and thread-safe.
#ifndef MESHSTREAM_PROTO_EXPORT_FORMATS_H_
#define MESHSTREAM_PROTO_EXPORT_FORMATS_H_

#include <string>
#include <string_view>
#include <vector>

#include "meshstream/v1/asset_service.pb.h"

namespace meshstream {

enum class ExportFormat { kGlb, kDracoGlb, kProgressiveGlb, kObj, kPly };

struct ExportFormatInfo {
  ExportFormat format;
  const char* name;          // the CLI's --format, the HTTP route's segment, the cache key
  v1::Format proto;          // the Export RPC's enum value
  const char* content_type;  // HTTP Content-Type
  const char* extension;     // of a file of it, with the dot
  bool decodes;              // made by decoding the stored file (false: its bytes as stored)
};

// Every format, in the order the enum and the messages list them.
const std::vector<ExportFormatInfo>& ExportFormats();

const ExportFormatInfo& InfoOf(ExportFormat format);
// nullptr when no format has that name (case-sensitive) or enum value.
const ExportFormatInfo* ExportFormatNamed(std::string_view name);
const ExportFormatInfo* ExportFormatOf(v1::Format proto);
// The format a file's extension implies (lower case, with the dot, as
// importers' FileExtension gives it): obj, ply, else glb.
const ExportFormatInfo& ExportFormatForExtension(std::string_view extension);

// "glb, draco, progressive, obj, ply" (the names, for messages and help).
std::string ExportFormatNames();
// "FORMAT_GLB, FORMAT_DRACO_GLB, ..." (the enum values, for messages).
std::string ExportFormatProtoNames();

}  // namespace meshstream

#endif  // MESHSTREAM_PROTO_EXPORT_FORMATS_H_
