// meshstream info FILE [--json]
#include <cstdio>
#include <set>

#include <nlohmann/json.hpp>

#include "cli/json_out.h"
#include "cli/exit_codes.h"
#include "cli/verbs.h"
#include "codec/mesh/mesh_health.h"
#include "importers/import.h"

namespace meshstream::cli {

namespace {

const char kDetails[] =
    "FILE is .gltf .glb .obj .ply .off .stl. Counts, as printed:\n"
    "  vertices   the positions the file defines (for OBJ before seams are split)\n"
    "  faces      triangles (polygons, strips and fans counted as triangles)\n"
    "  bbox       of all vertices, in each mesh's own coordinates\n"
    "  health     unreferenced vertices, degenerate faces, non-manifold edges\n"
    "\n"
    "Example:\n"
    "  meshstream info --json bunny.obj";

struct InfoArgs {
  std::string file;
  bool json = false;
};

// Attribute names in a fixed order, as a union over all primitives.
std::vector<std::string> AttributeUnion(const Scene& scene) {
  std::vector<std::string> ordered;
  std::set<std::string> seen;
  for (const Mesh& m : scene.meshes)
    for (const Primitive& p : m.primitives)
      for (const std::string& name : p.AttributeNames())
        if (seen.insert(name).second) ordered.push_back(name);
  std::stable_sort(ordered.begin(), ordered.end(), [](const std::string& a, const std::string& b) {
    auto rank = [](const std::string& s) {
      if (s == "POSITION") return 0;
      if (s == "NORMAL") return 1;
      if (s.rfind("TEXCOORD_", 0) == 0) return 2;
      return 3;
    };
    return rank(a) < rank(b) || (rank(a) == rank(b) && a < b);
  });
  return ordered;
}

size_t JsonArraySize(const std::string& text) {
  nlohmann::json v = nlohmann::json::parse(text, nullptr, false);
  return v.is_array() ? v.size() : 0;
}

int RunInfo(const InfoArgs& args) {
  const std::string& path = args.file;
  auto scene_or = ImportFile(path);
  if (!scene_or.ok()) return ReportError("info", scene_or.status());
  const Scene& scene = scene_or.value();

  MeshHealth total;
  size_t carried_primitives = 0;  // kept as they are, not refined (docs/spec/gltf-support.md)
  nlohmann::json meshes = nlohmann::json::array();
  for (const Mesh& mesh : scene.meshes) {
    nlohmann::json prims = nlohmann::json::array();
    for (const Primitive& p : mesh.primitives) {
      const MeshHealth h = ComputeHealth(p);
      total.Add(h);
      prims.push_back({{"vertices", h.vertices}, {"faces", h.faces}, {"attributes", Utf8(p.AttributeNames())},
                       {"material", p.material}, {"unreferenced_vertices", h.unreferenced_vertices},
                       {"degenerate_faces", h.degenerate_faces}, {"nonmanifold_edges", h.nonmanifold_edges}});
    }
    nlohmann::json carried = nlohmann::json::array();
    for (const CarriedPrimitive& c : mesh.carried) {
      carried.push_back({{"mode", c.mode}, {"targets", c.targets.size()}, {"material", c.material}});
    }
    carried_primitives += mesh.carried.size();
    meshes.push_back({{"name", Utf8(mesh.name)}, {"primitives", prims}, {"carried_primitives", carried}});
  }
  const std::vector<std::string> attributes = AttributeUnion(scene);
  nlohmann::json out = {
      {"file", Utf8(path)},
      {"scenes", scene.scenes.size()},
      {"nodes", scene.nodes.size()},
      {"meshes", scene.meshes.size()},
      {"primitives", scene.total_primitives()},
      {"carried_primitives", carried_primitives},
      {"skins", scene.skins.size()},
      {"animations", scene.animations.size()},
      {"vertices", scene.source_vertices},
      {"primitive_vertices", total.vertices},
      {"faces", total.faces},
      {"attributes", Utf8(attributes)},
      {"bbox_min", total.bbox.min},
      {"bbox_max", total.bbox.max},
      {"unreferenced_vertices", total.unreferenced_vertices},
      {"degenerate_faces", total.degenerate_faces},
      {"nonmanifold_edges", total.nonmanifold_edges},
      {"materials", JsonArraySize(scene.materials_json)},
      {"textures", JsonArraySize(scene.textures_json)},
      {"images", scene.images.size()},
      {"warnings", Utf8(scene.warnings)},
      {"mesh_list", meshes},
  };
  if (args.json) {
    PrintJson(out);
    return kExitOk;
  }
  std::printf("%s\n", path.c_str());
  std::printf("  scenes %zu, nodes %zu, meshes %zu, primitives %zu, materials %zu, images %zu\n",
              scene.scenes.size(), scene.nodes.size(), scene.meshes.size(), scene.total_primitives(),
              JsonArraySize(scene.materials_json), scene.images.size());
  if (carried_primitives + scene.skins.size() + scene.animations.size() > 0) {
    std::printf("  carried as they are: primitives %zu, skins %zu, animations %zu\n", carried_primitives,
                scene.skins.size(), scene.animations.size());
  }
  std::printf("  vertices %llu (in primitives: %llu), faces %llu\n",
              static_cast<unsigned long long>(scene.source_vertices),
              static_cast<unsigned long long>(total.vertices), static_cast<unsigned long long>(total.faces));
  std::string names;
  for (const std::string& a : attributes) names += (names.empty() ? "" : ", ") + a;
  std::printf("  attributes %s\n", names.c_str());
  std::printf("  bbox [%g %g %g] .. [%g %g %g]\n", total.bbox.min[0], total.bbox.min[1], total.bbox.min[2],
              total.bbox.max[0], total.bbox.max[1], total.bbox.max[2]);
  std::printf("  health: %llu unreferenced vertices, %llu degenerate faces, %llu non-manifold edges\n",
              static_cast<unsigned long long>(total.unreferenced_vertices),
              static_cast<unsigned long long>(total.degenerate_faces),
              static_cast<unsigned long long>(total.nonmanifold_edges));
  for (const std::string& w : scene.warnings) std::printf("  warning: %s\n", w.c_str());
  return kExitOk;
}

}  // namespace

Verb AddInfo(CLI::App& root) {
  auto args = std::make_shared<InfoArgs>();
  CLI::App* cmd = AddVerb(root, "info", "Prints what a mesh or scene file holds (scenes, nodes, meshes, counts, attributes, bounding box) and its health.", kDetails);
  cmd->add_option("FILE", args->file, "the mesh or scene file")->required();
  cmd->add_flag("--json", args->json, "print one JSON object instead of text");
  return {cmd, [args] { return RunInfo(*args); }};
}

}  // namespace meshstream::cli
