// meshstream compare A B [--qp N] [--json] [--samples N]
#include <cstdio>
#include <memory>

#include <nlohmann/json.hpp>

#include "cli/json_out.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/metrics/grid_equality.h"
#include "codec/metrics/hausdorff.h"
#include "codec/metrics/laplacian.h"
#include "codec/mesh/mesh_health.h"
#include "codec/mesh/quantization.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "A and B are any supported mesh or scene files, each flattened into world space. Prints:\n"
    "  hausdorff, hausdorff_rel   symmetric point-to-surface Hausdorff distance, absolute\n"
    "                             and divided by A's bounding-box diagonal (points sampled\n"
    "                             on faces only: unreferenced vertices do not count)\n"
    "  mean_distance              mean point-to-surface distance, both directions\n"
    "  hausdorff_vertex(_rel)     vertex-to-vertex Hausdorff distance (the paper's Eq. 3)\n"
    "  laplacian                  the paper's visual distortion (Eq. 4-5), when both have\n"
    "                             the same number of referenced vertices, else null\n"
    "  same_on_grid               with --qp N: whether both quantized on A's N-bit grid\n"
    "                             (the brief's grid) have exactly the same oriented triangles\n"
    "\n"
    "Example:\n"
    "  meshstream compare --json --qp 11 bunny.obj decoded.glb";

struct CompareArgs {
  std::string files[2];
  int qp = 0;
  CLI::Option* qp_option = nullptr;
  int samples = 200000;
  bool json = false;
};

nlohmann::json NullableNumber(const StatusOr<double>& v) {
  return v.ok() ? nlohmann::json(v.value()) : nlohmann::json(nullptr);
}

int RunCompare(const CompareArgs& args) {
  const bool with_grid = args.qp_option->count() > 0;

  Primitive meshes[2];
  for (int i = 0; i < 2; ++i) {
    auto scene = ImportFile(args.files[i]);
    if (!scene.ok()) return ReportError("compare", scene.status());
    meshes[i] = FlattenScene(scene.value());
    if (meshes[i].face_count() == 0) {
      return ReportError("compare", InvalidInput(args.files[i] + ": has no triangle to compare"));
    }
  }
  SurfaceDistanceOptions options;
  options.samples_per_side = args.samples;
  auto distance = ComputeSurfaceDistance(meshes[0], meshes[1], options);
  if (!distance.ok()) return ReportError("compare", distance.status());
  const auto laplacian = LaplacianDistortion(meshes[0], meshes[1]);

  nlohmann::json out = {
      {"a", Utf8(args.files[0])},
      {"b", Utf8(args.files[1])},
      {"vertices_a", meshes[0].vertex_count()},
      {"vertices_b", meshes[1].vertex_count()},
      {"faces_a", meshes[0].face_count()},
      {"faces_b", meshes[1].face_count()},
      {"hausdorff", distance->hausdorff},
      {"hausdorff_rel", distance->hausdorff_rel},
      {"mean_distance", distance->mean_distance},
      {"hausdorff_vertex", distance->hausdorff_vertex},
      {"hausdorff_vertex_rel", distance->hausdorff_vertex_rel},
      {"laplacian", NullableNumber(laplacian)},
  };
  if (with_grid) {
    auto grid = CompareOnGrid(meshes[0], meshes[1], args.qp);
    if (!grid.ok()) return ReportError("compare", grid.status());
    out["qp"] = args.qp;
    out["same_on_grid"] = grid->equal;
    out["grid_differing_faces"] = grid->differing();
  }
  if (args.json) {
    PrintJson(out);
    return kExitOk;
  }
  std::printf("A %s: %zu vertices, %zu faces\n", args.files[0].c_str(), meshes[0].vertex_count(), meshes[0].face_count());
  std::printf("B %s: %zu vertices, %zu faces\n", args.files[1].c_str(), meshes[1].vertex_count(), meshes[1].face_count());
  std::printf("hausdorff         %.6g (%.6g of A's diagonal)\n", distance->hausdorff, distance->hausdorff_rel);
  std::printf("mean distance     %.6g\n", distance->mean_distance);
  std::printf("hausdorff vertex  %.6g (%.6g of A's diagonal)\n", distance->hausdorff_vertex, distance->hausdorff_vertex_rel);
  if (laplacian.ok()) {
    std::printf("laplacian         %.6g\n", laplacian.value());
  } else {
    std::printf("laplacian         n/a (%s)\n", laplacian.status().message().c_str());
  }
  if (with_grid) {
    std::printf("same on %d-bit grid: %s (%llu differing faces)\n", args.qp, out["same_on_grid"].get<bool>() ? "yes" : "no",
                static_cast<unsigned long long>(out["grid_differing_faces"].get<uint64_t>()));
  }
  return kExitOk;
}

}  // namespace

Verb AddCompare(CLI::App& root) {
  auto args = std::make_shared<CompareArgs>();
  CLI::App* cmd = AddVerb(root, "compare", "Measures the distances between two meshes (Hausdorff, mean, Laplacian).", kDetails);
  cmd->add_option("A", args->files[0], "the reference mesh")->required();
  cmd->add_option("B", args->files[1], "the mesh compared with A")->required();
  args->qp_option = cmd->add_option("--qp", args->qp, "also compare both on A's N-bit grid (same_on_grid)")
                        ->check(CLI::Range(kMinQuantizationBits, kMaxQuantizationBits));
  cmd->add_option("--samples", args->samples, "surface samples per mesh")->check(CLI::Range(1000, 100000000))
      ->capture_default_str();
  cmd->add_flag("--json", args->json, "print one JSON object");
  return {cmd, [args] { return RunCompare(*args); }};
}

}  // namespace meshstream::cli
