#include "bench/stream/models.h"

#include <algorithm>
#include <filesystem>
#include <utility>

#include "bench/bench_util.h"
#include "bench/harness.h"

namespace meshstream::bench::stream {

namespace fs = std::filesystem;

namespace {

// The largest of SingleFileModels(dir) by file size (the first of equals);
// its path relative to dir.
std::string LargestModel(const std::string& dir) {
  std::string best;
  uintmax_t best_size = 0;
  std::error_code ec;
  for (const fs::path& p : SingleFileModels(dir)) {
    const uintmax_t size = fs::file_size(p, ec);
    if (!ec && size > best_size) {
      best_size = size;
      best = fs::relative(p, dir, ec).string();
    }
  }
  if (best.empty()) Die(dir + ": no .obj, .ply or .glb model");
  return best;
}

// The horse's file: the first "horse.*" of the folder's models.
std::string HorseModel(const std::string& dir) {
  for (const char* ext : {".ply", ".obj", ".glb"}) {
    std::error_code ec;
    if (fs::is_regular_file(fs::path(dir) / (std::string("horse") + ext), ec)) return std::string("horse") + ext;
  }
  Die(dir + ": no horse model (horse.ply, horse.obj or horse.glb)");
}

}  // namespace

std::vector<fs::path> SingleFileModels(const std::string& dir) {
  std::vector<fs::path> files;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string ext = it->path().extension().string();
    if (ext == ".obj" || ext == ".ply" || ext == ".glb") files.push_back(it->path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

Model LoadModel(const std::string& dir, const std::string& relative, std::vector<std::string> roles) {
  Model m;
  static_cast<ModelFile&>(m) = ReadModelFile(dir, relative);
  m.roles = std::move(roles);
  return m;
}

std::vector<Model> ChooseModels(const Args& args) {
  const std::vector<std::pair<std::string, std::string>> wanted = {
      {"stanford-bunny.obj", "bunny"}, {HorseModel(args.models_dir), "horse"}, {LargestModel(args.models_dir), "largest"}};
  std::vector<std::pair<std::string, std::vector<std::string>>> files;  // relative path, roles
  for (const auto& [relative, role] : wanted) {
    auto it = std::find_if(files.begin(), files.end(), [&](const auto& f) { return f.first == relative; });
    if (it != files.end()) {
      it->second.push_back(role);
    } else {
      files.push_back({relative, {role}});
    }
  }
  std::vector<Model> models;
  for (const auto& [relative, roles] : files) {
    if (!args.only_shaped && !args.only.empty() &&
        std::find(args.only.begin(), args.only.end(), Stem(relative)) == args.only.end()) {
      continue;  // the shaped part filters its own
    }
    models.push_back(LoadModel(args.models_dir, relative, roles));
  }
  if (models.empty()) Die("no model left (see --model)");
  return models;
}

bool IsLargest(const Model& m) { return std::find(m.roles.begin(), m.roles.end(), "largest") != m.roles.end(); }

void KeepOnly(const std::vector<std::string>& only, std::vector<Model>& models) {
  if (only.empty()) return;
  models.erase(std::remove_if(models.begin(), models.end(),
                              [&](const Model& m) { return std::find(only.begin(), only.end(), m.name) == only.end(); }),
               models.end());
}

void Ingest(const std::string& address, Model& m) {
  AssetApi api(address);
  m.info = Check(IngestAndWait(api, m.name, m.file, m.bytes), "ingest " + m.file);
  m.version = m.info.version();
}

}  // namespace meshstream::bench::stream
