// The main of the tools that estimate codec levers on shared models
// (meshstream_codec_levers, meshstream_codec_levers_v3): --model, --qp and
// --out, one JSON object printed per model, all of them written as an array
// with --out.
#ifndef MESHSTREAM_EXPERIMENTS_ESTIMATE_MAIN_H_
#define MESHSTREAM_EXPERIMENTS_ESTIMATE_MAIN_H_

#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_util.h"
#include "bench/options.h"

namespace meshstream::bench {

// `models`: the default set; `example`: a model file named in --model's help.
inline int EstimateMain(int argc, char** argv, const std::string& program, const std::string& description,
                        std::vector<std::string> models, const std::string& example,
                        const std::function<nlohmann::json(const std::string& model, int qp)>& measure) {
  SetProgramName(program);
  int qp = 11;
  std::string out_path;
  Options o(program, description);
  o.Custom("--model", "FILE", [&models](const std::string& v) { models = {v}; },
           "only this model (file name under the shared models, e.g. " + example + ")");
  o.Int("--qp", "N", &qp, 4, 20, "position bits (default 11)");
  o.String("--out", "FILE", &out_path, "also write the JSON array here");
  o.Parse(argc, argv);
  nlohmann::json all = nlohmann::json::array();
  for (const std::string& name : models) {
    nlohmann::json j = measure(name, qp);
    std::printf("%s\n", j.dump(1).c_str());
    all.push_back(j);
  }
  if (!out_path.empty()) std::ofstream(out_path) << all.dump(1) << "\n";
  return 0;
}

}  // namespace meshstream::bench

#endif  // MESHSTREAM_EXPERIMENTS_ESTIMATE_MAIN_H_
