// Batch sizes under the strict rule of the brief (split vertices pairwise
// non-adjacent) and under the paper's minimum (collapsed edges share no
// vertex), on the shared models at qp 11: levels, growth per level, and the
// order-0 entropy of the split bits each rule implies. The codec accepts only
// the strict rule (docs/design/codec.md); this measures what the other would give.
// Usage: meshstream_rule_comparison [--out FILE.json]
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/options.h"
#include "codec/progressive/batch_simplifier.h"
#include "codec/mesh/quantized_mesh.h"
#include "importers/import.h"

namespace {

double Entropy(double p) {
  if (p <= 0 || p >= 1) return 0;
  return -(p * std::log2(p) + (1 - p) * std::log2(1 - p));
}

}  // namespace

int main(int argc, char** argv) {
  meshstream::bench::SetProgramName("meshstream_rule_comparison");
  std::string out_path;
  meshstream::bench::Options o("meshstream_rule_comparison",
                               "Batch sizes, growth per level and split-bit entropy under the strict rule and the\n"
                               "paper's minimum, on the shared models at qp 11; prints a table.\n");
  o.String("--out", "FILE", &out_path, "also write the rows as JSON");
  o.Parse(argc, argv);
  nlohmann::json results = nlohmann::json::array();
  std::printf("%-20s %-7s %7s %8s %12s %16s\n", "model", "rule", "levels", "base", "growth_mean", "split_bits_bpv");
  for (const std::string& name : meshstream::bench::kSharedModels) {
    auto scene = meshstream::ImportFile(std::string(MESHSTREAM_MODELS_DIR) + "/" + name);
    if (!scene.ok()) {
      std::fprintf(stderr, "%s\n", scene.status().ToString().c_str());
      return 1;
    }
    auto q = meshstream::QuantizePrimitive(scene->meshes[0].primitives[0], {});
    if (!q.ok()) return 1;
    for (auto rule : {meshstream::BatchRule::kStrict, meshstream::BatchRule::kPaper}) {
      meshstream::SimplifyOptions options;
      options.rule = rule;
      auto h = meshstream::SimplifyInBatches(q.value(), options);
      if (!h.ok()) return 1;
      // Vertex counts per level, fine to coarse, then reversed.
      std::vector<double> sizes = {static_cast<double>(q->vertex_count())};
      for (const auto& b : h->batches) sizes.push_back(sizes.back() - b.collapses.size());
      double bits = 0, growth = 0;
      for (size_t i = 0; i + 1 < sizes.size(); ++i) {
        const double coarse = sizes[i + 1], splits = sizes[i] - sizes[i + 1];
        bits += coarse * Entropy(splits / coarse);
        growth += splits / coarse;
      }
      const size_t levels = h->batches.size();
      const char* rule_name = rule == meshstream::BatchRule::kStrict ? "strict" : "paper";
      const double v = static_cast<double>(q->vertex_count());
      std::printf("%-20s %-7s %7zu %8.0f %12.3f %16.2f\n", name.c_str(), rule_name, levels, sizes.back(),
                  levels ? growth / levels : 0.0, bits / v);
      results.push_back({{"model", name}, {"rule", rule_name}, {"levels", levels}, {"base_vertices", sizes.back()},
                         {"growth_mean", levels ? growth / levels : 0.0}, {"split_bits_order0_bpv", bits / v}});
    }
  }
  if (!out_path.empty()) std::ofstream(out_path) << results.dump(2) << "\n";
  return 0;
}
