#include "bench/stream/shaped_distances.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <thread>
#include <utility>

#include "bench/bench_util.h"
#include "bench/stream/snapshots.h"
#include "codec/metrics/hausdorff.h"

namespace meshstream::bench::stream {

using json = nlohmann::json;

namespace {

constexpr size_t kExact = SIZE_MAX;  // a mesh equal to the reference: distance 0

// Each distinct mesh once against a reference, measured in batches on
// every core (the meshes let go once measured).
class Distances {
 public:
  explicit Distances(int64_t samples) { options_.samples_per_side = samples; }

  // `mesh` against `*reference` (its diagonal divides); returns its index.
  size_t Add(const Primitive* reference, Primitive mesh) {
    auto job = std::make_unique<Job>();
    job->a = reference;
    job->b = std::move(mesh);
    jobs_.push_back(std::move(job));
    return jobs_.size() - 1;
  }

  // Measures the jobs from `first` on.
  void MeasureFrom(size_t first) {
    std::atomic<size_t> next{first};
    std::vector<std::thread> workers;
    const unsigned n = std::max(1u, std::thread::hardware_concurrency());
    for (unsigned w = 0; w < n; ++w) {
      workers.emplace_back([&] {
        for (size_t i; (i = next++) < jobs_.size();) {
          Job& jb = *jobs_[i];
          auto d = ComputeSurfaceDistance(*jb.a, jb.b, options_);
          if (d.ok()) {
            jb.d = d.value();
            jb.ok = true;
          } else {
            jb.error = d.status().ToString();
          }
          jb.b = Primitive();
        }
      });
    }
    for (std::thread& t : workers) t.join();
  }

  json Json(size_t job) const {
    if (job == kExact) return {{"hausdorff_rel", 0.0}, {"mean_rel", 0.0}, {"exact", true}};
    const Job& jb = *jobs_[job];
    if (!jb.ok) return {{"error", jb.error}};
    const double diag = jb.d.hausdorff > 0 && jb.d.hausdorff_rel > 0 ? jb.d.hausdorff / jb.d.hausdorff_rel : 0;
    return {{"hausdorff_rel", jb.d.hausdorff_rel}, {"mean_rel", diag > 0 ? jb.d.mean_distance / diag : 0.0},
            {"hausdorff", jb.d.hausdorff}, {"mean_distance", jb.d.mean_distance}};
  }

  size_t size() const { return jobs_.size(); }

 private:
  struct Job {
    const Primitive* a = nullptr;
    Primitive b;
    SurfaceDistance d;
    bool ok = false;
    std::string error;
  };
  SurfaceDistanceOptions options_;
  std::vector<std::unique_ptr<Job>> jobs_;
};

// A snapshot: which run and event showed it, at which level, its distance.
struct Point {
  size_t run, event;
  int32_t level;
  size_t job;  // kExact: the reference itself
};

// The snapshots of every run, each distinct mesh measured once.
std::vector<Point> MeasureSnapshots(const ShapedMeshes& meshes, const std::vector<std::string>& snapshot_files,
                                    const json& runs, Distances& distances) {
  std::vector<Point> points;
  std::map<std::pair<std::string, uint64_t>, size_t> job_of;
  for (size_t i = 0; i < runs.size(); ++i) {
    if (snapshot_files[i].empty()) continue;
    const std::string model = runs[i]["model"];
    std::vector<Snapshot> snaps = ReadSnapshots(snapshot_files[i]);
    const json ev = runs[i].value("snapshot_events", json::array());
    const size_t first_new = distances.size();
    for (size_t k = 0; k < snaps.size() && k < ev.size(); ++k) {
      const uint64_t h = MeshHash(snaps[k].mesh);
      size_t job = kExact;
      if (h != meshes.reference_hash.at(model)) {
        auto it = job_of.find({model, h});
        if (it == job_of.end()) {
          it = job_of.emplace(std::make_pair(model, h), distances.Add(&meshes.reference.at(model), std::move(snaps[k].mesh)))
                   .first;
        }
        job = it->second;
      }
      points.push_back({i, ev[k].get<size_t>(), snaps[k].level, job});
    }
    snaps.clear();
    distances.MeasureFrom(first_new);
    std::error_code ec;
    std::filesystem::remove(snapshot_files[i], ec);
  }
  return points;
}

// Each run's "quality": the distance of every snapshot, with the time and
// kind of the event it was taken at.
void AddQuality(const std::vector<Point>& points, const Distances& distances, json& runs) {
  for (json& r : runs) r["quality"] = json::array();
  for (const Point& p : points) {
    json& r = runs[p.run];
    json q = distances.Json(p.job);
    q["level"] = p.level;
    const json& ev = r["events"];
    if (p.event < ev.size()) {
      q["t_ms"] = ev[p.event]["t_ms"];
      q["what"] = ev[p.event]["what"];
      if (ev[p.event].contains("predicted")) q["predicted"] = ev[p.event]["predicted"];
    }
    r["quality"].push_back(q);
  }
}

}  // namespace

DistanceCounts MeasureShapedDistances(const std::vector<Model>& models, const ShapedMeshes& meshes,
                                      const std::vector<std::string>& snapshot_files, int64_t samples, json& runs,
                                      json& model_info) {
  const auto d0 = Clock::now();
  Distances distances(samples);
  // Per model: Draco's GLB and the source file against the reference, and Draco against the source.
  std::map<std::string, std::array<size_t, 3>> model_jobs;
  for (const Model& m : models) {
    const Primitive& reference = meshes.reference.at(m.name);
    const Primitive& draco = meshes.draco.at(m.name);
    const Primitive& source = meshes.source.at(m.name);
    model_jobs[m.name] = {distances.Add(&reference, draco), distances.Add(&reference, source),
                          distances.Add(&source, draco)};
  }
  distances.MeasureFrom(0);
  const std::vector<Point> points = MeasureSnapshots(meshes, snapshot_files, runs, distances);
  DistanceCounts counts{distances.size(), points.size(), Ms(d0, Clock::now()) / 1000};
  std::fprintf(stderr, "meshstream_bench_stream: shaped link: %zu snapshots, %zu distinct meshes measured in %.0f s\n",
               counts.snapshots, counts.distinct_meshes, counts.seconds);
  AddQuality(points, distances, runs);
  for (json& m : model_info) {
    const std::array<size_t, 3>& idx = model_jobs[m["name"].get<std::string>()];
    m["draco_vs_reference"] = distances.Json(idx[0]);
    m["source_vs_reference"] = distances.Json(idx[1]);
    m["draco_vs_source"] = distances.Json(idx[2]);
  }
  return counts;
}

}  // namespace meshstream::bench::stream
