#include "proto/export_formats.h"

namespace meshstream {

const std::vector<ExportFormatInfo>& ExportFormats() {
  static const std::vector<ExportFormatInfo> kTable = {
      {ExportFormat::kGlb, "glb", v1::FORMAT_GLB, "model/gltf-binary", ".glb", true},
      {ExportFormat::kDracoGlb, "draco", v1::FORMAT_DRACO_GLB, "model/gltf-binary", ".glb", true},
      {ExportFormat::kProgressiveGlb, "progressive", v1::FORMAT_PROGRESSIVE_GLB, "model/gltf-binary", ".glb", false},
      {ExportFormat::kObj, "obj", v1::FORMAT_OBJ, "model/obj", ".obj", true},
      {ExportFormat::kPly, "ply", v1::FORMAT_PLY, "application/octet-stream", ".ply", true},
  };
  return kTable;
}

const ExportFormatInfo& InfoOf(ExportFormat format) {
  for (const ExportFormatInfo& info : ExportFormats())
    if (info.format == format) return info;
  return ExportFormats().front();  // unreachable: every enumerator has a row (tests/services)
}

const ExportFormatInfo* ExportFormatNamed(std::string_view name) {
  for (const ExportFormatInfo& info : ExportFormats())
    if (name == info.name) return &info;
  return nullptr;
}

const ExportFormatInfo* ExportFormatOf(v1::Format proto) {
  for (const ExportFormatInfo& info : ExportFormats())
    if (info.proto == proto) return &info;
  return nullptr;
}

const ExportFormatInfo& ExportFormatForExtension(std::string_view extension) {
  for (const ExportFormatInfo& info : ExportFormats())
    if (info.decodes && extension == info.extension) return info;  // .glb: glb, the first row
  return InfoOf(ExportFormat::kGlb);
}

std::string ExportFormatNames() {
  std::string out;
  for (const ExportFormatInfo& info : ExportFormats()) out += (out.empty() ? "" : ", ") + std::string(info.name);
  return out;
}

std::string ExportFormatProtoNames() {
  std::string out;
  for (const ExportFormatInfo& info : ExportFormats())
    out += (out.empty() ? "" : ", ") + v1::Format_Name(info.proto);
  return out;
}

}  // namespace meshstream
