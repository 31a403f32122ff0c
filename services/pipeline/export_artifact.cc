#include "services/pipeline/export_artifact.h"

#include <exception>
#include <new>

#include "importers/gltf_export.h"
#include "importers/import.h"
#include "importers/mesh_writer.h"
#include "importers/progressive_glb.h"
#include "services/pipeline/materialize.h"
#include "services/pipeline/stream_layout.h"

namespace meshstream {

namespace {

StatusOr<std::vector<uint8_t>> ExportChecked(const std::vector<uint8_t>& glb, ExportFormat format,
                                             std::optional<int> lod, const std::string& temp_parent) {
  if (format == ExportFormat::kProgressiveGlb) {
    if (lod.has_value()) return InvalidArgument("lod: not supported for the progressive format (it holds every level)");
    return glb;
  }
  // The layout gives the level count (and the quantization) without decoding.
  MS_ASSIGN_OR_RETURN(StreamLayout layout, ComputeStreamLayout(glb.data(), glb.size()));
  const uint32_t levels = layout.levels();
  if (lod.has_value() && (*lod < 0 || static_cast<uint64_t>(*lod) > levels)) {
    return InvalidArgument("lod: " + std::to_string(*lod) + " is outside [0, " + std::to_string(levels) + "]");
  }
  ProgressiveDecodeOptions decode;
  decode.lod = lod.value_or(-1);
  ProgressiveDecodeReport report;
  MS_ASSIGN_OR_RETURN(Scene scene, DecodeProgressiveGlb(glb, decode, &report));

  switch (format) {
    case ExportFormat::kGlb:
      return ExportGlb(scene, ExportOptions{});
    case ExportFormat::kDracoGlb: {
      ExportOptions options;
      options.draco = true;
      QuantizationParams q = ProgressiveGlbOptions{}.encode.quantization;
      if (!layout.primitives.empty()) q = layout.primitives.front().quantization;
      options.draco_options.qp = q.qp;
      options.draco_options.qn = q.qn;
      options.draco_options.qt = q.qt;
      options.draco_options.qc = q.qc;
      options.draco_options.compression_level = ProgressiveGlbOptions{}.draco_compression_level;
      return ExportGlb(scene, options);
    }
    case ExportFormat::kObj:
    case ExportFormat::kPly: {
      MS_ASSIGN_OR_RETURN(WorkFolder folder, WorkFolder::Create(temp_parent));
      const std::string path = folder.path() + "/export" + InfoOf(format).extension;
      MS_RETURN_IF_ERROR(WriteMeshFile(scene, path));
      return ReadFileBytes(path, UINT64_MAX);
    }
    case ExportFormat::kProgressiveGlb:
      break;
  }
  return InvalidArgument("format: not an export format");
}

}  // namespace

StatusOr<std::vector<uint8_t>> ExportArtifact(const std::vector<uint8_t>& progressive_glb, ExportFormat format,
                                              std::optional<int> lod, const std::string& temp_parent) {
  try {
    return ExportChecked(progressive_glb, format, lod, temp_parent);
  } catch (const std::bad_alloc&) {
    return ResourceExhausted("export: out of memory");
  } catch (const std::exception& e) {
    return Internal(std::string("export: ") + e.what());
  } catch (...) {
    return Internal("export: unknown exception");
  }
}

}  // namespace meshstream
