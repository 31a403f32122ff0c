// meshstream compare A B [--qp N] [--json] [--samples N]
#include <cstdio>

#include <nlohmann/json.hpp>

#include "cli/args.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/metrics/grid_equality.h"
#include "codec/metrics/hausdorff.h"
#include "codec/metrics/laplacian.h"
#include "codec/mesh/mesh_health.h"
#include "codec/mesh/scene_flatten.h"
#include "importers/import.h"

namespace meshstream::cli {

namespace {

const char kHelp[] =
    "usage: meshstream compare A B [--qp N] [--json] [--samples N]\n"
    "\n"
    "Compares two meshes or scenes (each flattened into world space) and prints:\n"
    "  hausdorff, hausdorff_rel   symmetric point-to-surface Hausdorff distance, absolute\n"
    "                             and divided by A's bounding-box diagonal (points sampled\n"
    "                             on faces only: unreferenced vertices do not count)\n"
    "  mean_distance              mean point-to-surface distance, both directions\n"
    "  hausdorff_vertex(_rel)     vertex-to-vertex Hausdorff distance (the paper's Eq. 3)\n"
    "  laplacian                  the paper's visual distortion (Eq. 4-5), when both have\n"
    "                             the same number of referenced vertices, else null\n"
    "\n"
    "Options:\n"
    "  --qp N       also quantize both on A's N-bit grid (the brief's grid) and report\n"
    "               same_on_grid: whether both have exactly the same oriented triangles\n"
    "  --samples N  surface samples per mesh (default 200000)\n"
    "  --json       print one JSON object\n";

nlohmann::json NullableNumber(const StatusOr<double>& v) {
  return v.ok() ? nlohmann::json(v.value()) : nlohmann::json(nullptr);
}

}  // namespace

int RunCompare(const std::vector<std::string>& argv) {
  auto parsed = ParseArgs(argv, {{"qp", true}, {"json", false}, {"samples", true}});
  if (!parsed.ok()) return ReportError("compare", parsed.status());
  const ParsedArgs& args = parsed.value();
  if (args.Has("help")) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  if (args.positional.size() != 2) return ReportError("compare", InvalidArgument("expected two files A and B"));
  auto qp = args.Int("qp", 0, 1, 30);
  if (!qp.ok()) return ReportError("compare", qp.status());
  auto samples = args.Int("samples", 200000, 1000, 100000000);
  if (!samples.ok()) return ReportError("compare", samples.status());

  Primitive meshes[2];
  for (int i = 0; i < 2; ++i) {
    auto scene = ImportFile(args.positional[i]);
    if (!scene.ok()) return ReportError("compare", scene.status());
    meshes[i] = FlattenScene(scene.value());
    if (meshes[i].face_count() == 0) {
      return ReportError("compare", InvalidInput(args.positional[i] + ": has no triangle to compare"));
    }
  }
  SurfaceDistanceOptions options;
  options.samples_per_side = *samples;
  auto distance = ComputeSurfaceDistance(meshes[0], meshes[1], options);
  if (!distance.ok()) return ReportError("compare", distance.status());
  const auto laplacian = LaplacianDistortion(meshes[0], meshes[1]);

  nlohmann::json out = {
      {"a", args.positional[0]},
      {"b", args.positional[1]},
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
  if (args.Has("qp")) {
    auto grid = CompareOnGrid(meshes[0], meshes[1], *qp);
    if (!grid.ok()) return ReportError("compare", grid.status());
    out["qp"] = *qp;
    out["same_on_grid"] = grid->equal;
    out["grid_differing_faces"] = grid->differing();
  }
  if (args.Has("json")) {
    std::puts(out.dump().c_str());
    return kExitOk;
  }
  std::printf("A %s: %zu vertices, %zu faces\n", args.positional[0].c_str(), meshes[0].vertex_count(), meshes[0].face_count());
  std::printf("B %s: %zu vertices, %zu faces\n", args.positional[1].c_str(), meshes[1].vertex_count(), meshes[1].face_count());
  std::printf("hausdorff         %.6g (%.6g of A's diagonal)\n", distance->hausdorff, distance->hausdorff_rel);
  std::printf("mean distance     %.6g\n", distance->mean_distance);
  std::printf("hausdorff vertex  %.6g (%.6g of A's diagonal)\n", distance->hausdorff_vertex, distance->hausdorff_vertex_rel);
  if (laplacian.ok()) {
    std::printf("laplacian         %.6g\n", laplacian.value());
  } else {
    std::printf("laplacian         n/a (%s)\n", laplacian.status().message().c_str());
  }
  if (args.Has("qp")) {
    std::printf("same on %d-bit grid: %s (%llu differing faces)\n", *qp, out["same_on_grid"].get<bool>() ? "yes" : "no",
                static_cast<unsigned long long>(out["grid_differing_faces"].get<uint64_t>()));
  }
  return kExitOk;
}

}  // namespace meshstream::cli
