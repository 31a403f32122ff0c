#include "bench/service/models.h"

#include <algorithm>
#include <filesystem>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "importers/import.h"

namespace meshstream::bench::service {

namespace ms = meshstream;
namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// The shared models, then a glTF binary.
std::vector<std::string> ModelFiles() {
  std::vector<std::string> files = ms::bench::kSharedModels;
  files.push_back("gltf/2CylinderEngine.glb");
  return files;
}

}  // namespace

Model LoadModel(const std::string& dir, const std::string& relative) {
  Model m;
  static_cast<ModelFile&>(m) = ReadModelFile(dir, relative);
  const ms::Scene scene = Check(ms::ImportFile(m.path), m.path);
  for (const ms::Primitive* p : ms::bench::Primitives(scene)) {
    m.has_normals = m.has_normals || !p->normals.empty();
    m.has_texcoords = m.has_texcoords || !p->texcoords.empty();
  }
  return m;
}

std::vector<uint8_t> VariantBytes(const Model& m, int k) {
  std::vector<uint8_t> b = m.bytes;
  const std::string tag = "meshstream_bench_service variant " + std::to_string(k);
  const std::string ext = fs::path(m.file).extension().string();
  if (ext == ".obj") {
    const std::string line = "\n# " + tag + "\n";
    b.insert(b.end(), line.begin(), line.end());
  } else if (ext == ".ply") {
    // After "ply" and the "format" line, where a comment may be.
    auto eol = std::find(b.begin(), b.end(), '\n');
    if (eol != b.end()) eol = std::find(eol + 1, b.end(), '\n');
    if (eol == b.end()) Die(m.path + ": not a PLY header");
    const std::string line = "comment " + tag + "\n";
    b.insert(eol + 1, line.begin(), line.end());
  } else if (ext == ".glb") {
    auto u32 = [&b](size_t at) {
      return uint32_t{b[at]} | uint32_t{b[at + 1]} << 8 | uint32_t{b[at + 2]} << 16 | uint32_t{b[at + 3]} << 24;
    };
    auto put = [&b](size_t at, uint32_t v) {
      for (int i = 0; i < 4; ++i) b[at + static_cast<size_t>(i)] = static_cast<uint8_t>(v >> (8 * i));
    };
    if (b.size() < 20 || u32(16) != 0x4E4F534Au) Die(m.path + ": not a .glb with a JSON chunk first");
    const uint32_t json_length = u32(12);
    const size_t pad = 4 * static_cast<size_t>(k + 1);  // JSON whitespace, the chunk stays 4-aligned
    b.insert(b.begin() + 20 + json_length, pad, ' ');
    put(12, json_length + static_cast<uint32_t>(pad));
    put(8, static_cast<uint32_t>(b.size()));
  } else {
    Die(m.path + ": no way to vary a " + ext + " file");
  }
  return b;
}

// The encode options of variant k: the defaults but the bits of an attribute
// the model does not have (qt 10 + k without texture coordinates, else qn
// 8 + k without normals): the stream header records them, so the artifact
// (and the export cache's key) is new too, while the encoder does the same
// work. (packet_bytes would not do: datagrams are cut evenly, and a few bytes
// more or less rarely move a cut.)
v1::EncodeOptions VariantOptions(const Model& m, int k) {
  v1::EncodeOptions o;
  if (!m.has_texcoords) {
    if (10 + k > 30) Die("too many variants for qt (at most 21)");
    o.set_qt(10 + k);
  } else if (!m.has_normals) {
    if (8 + k > 15) Die(m.file + ": too many variants for qn (at most 8)");
    o.set_qn(8 + k);
  } else {
    Die(m.file + ": has normals and texture coordinates: no option to vary without changing the work");
  }
  return o;
}

// The models of --model (all of ModelFiles() without it); spot.obj, which
// the warm-up and the latency asset use, is loaded by the caller.
std::vector<Model> LoadModels(const Args& args) {
  std::vector<Model> models;
  for (const std::string& relative : ModelFiles()) {
    const std::string stem = ms::bench::Stem(relative);
    if (!args.only.empty() && std::find(args.only.begin(), args.only.end(), stem) == args.only.end()) continue;
    models.push_back(LoadModel(args.models_dir, relative));
  }
  if (models.empty()) Die("no model left (see --model)");
  return models;
}

}  // namespace meshstream::bench::service
