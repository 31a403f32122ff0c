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
#include "codec/progressive/view_order.h"
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
  size_t visible_job = SIZE_MAX;  // the view run: what its camera sees (SIZE_MAX: none)
  double diagonal = 0;            // of the reference, for the visible distance's share
};


// The triangles of `mesh` whose centroid the view's frustum holds: what the
// camera sees (occlusion aside), measured on the surface.
Primitive Visible(const Primitive& mesh, const View& view) {
  Primitive out;
  std::vector<uint32_t> remap(mesh.positions.size(), UINT32_MAX);
  const std::array<double, 16>& m = view.view_projection;
  for (size_t f = 0; f + 2 < mesh.indices.size(); f += 3) {
    double c[3] = {0, 0, 0};
    for (int k = 0; k < 3; ++k)
      for (int a = 0; a < 3; ++a) c[a] += mesh.positions[mesh.indices[f + k]][a] / 3.0;
    double clip[4];
    for (int r = 0; r < 4; ++r) clip[r] = m[r] * c[0] + m[4 + r] * c[1] + m[8 + r] * c[2] + m[12 + r];
    if (!(clip[3] > 0) || std::abs(clip[0]) > clip[3] || std::abs(clip[1]) > clip[3] || std::abs(clip[2]) > clip[3]) continue;
    for (int k = 0; k < 3; ++k) {
      const uint32_t v = mesh.indices[f + k];
      if (remap[v] == UINT32_MAX) {
        remap[v] = static_cast<uint32_t>(out.positions.size());
        out.positions.push_back(mesh.positions[v]);
      }
      out.indices.push_back(remap[v]);
    }
  }
  return out;
}

double Diagonal(const Primitive& mesh) {
  Vec3d lo = {INFINITY, INFINITY, INFINITY}, hi = {-INFINITY, -INFINITY, -INFINITY};
  for (const Vec3f& p : mesh.positions) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], double(p[a]));
      hi[a] = std::max(hi[a], double(p[a]));
    }
  }
  return mesh.positions.empty() ? 0 : std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) +
                                                (hi[2] - lo[2]) * (hi[2] - lo[2]));
}

// The snapshots of every run, each distinct mesh measured once.
std::vector<Point> MeasureSnapshots(const ShapedMeshes& meshes, const std::vector<std::string>& snapshot_files,
                                    const json& runs, Distances& distances,
                                    std::map<std::string, std::unique_ptr<Primitive>>& visible_references) {
  std::vector<Point> points;
  std::map<std::pair<std::string, uint64_t>, size_t> job_of;
  for (size_t i = 0; i < runs.size(); ++i) {
    if (snapshot_files[i].empty()) continue;
    const std::string model = runs[i]["model"];
    std::vector<Snapshot> snaps = ReadSnapshots(snapshot_files[i]);
    const json ev = runs[i].value("snapshot_events", json::array());
    const size_t first_new = distances.size();
    // The view run: each snapshot's visible part against the reference's.
    const bool viewed = runs[i].contains("view");
    View view;
    const Primitive* visible_reference = nullptr;
    if (viewed) {
      view = Check(LookAtViewFromText(runs[i]["view"].get<std::string>()), "the view run's camera");
      std::unique_ptr<Primitive>& ref = visible_references[model + " " + runs[i]["view"].get<std::string>()];
      if (!ref) ref = std::make_unique<Primitive>(Visible(meshes.reference.at(model), view));
      visible_reference = ref.get();
    }
    for (size_t k = 0; k < snaps.size() && k < ev.size(); ++k) {
      size_t visible_job = SIZE_MAX;
      if (viewed && !visible_reference->indices.empty()) {
        Primitive seen = Visible(snaps[k].mesh, view);
        if (!seen.indices.empty()) visible_job = distances.Add(visible_reference, std::move(seen));
      }
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
      points.push_back({i, ev[k].get<size_t>(), snaps[k].level, job, visible_job, Diagonal(meshes.reference.at(model))});
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
    if (p.visible_job != SIZE_MAX) {
      const json v = distances.Json(p.visible_job);
      if (v.contains("hausdorff") && p.diagonal > 0) {
        q["visible_hausdorff"] = v["hausdorff"];
        q["visible_hausdorff_rel"] = v["hausdorff"].get<double>() / p.diagonal;  // of the whole model's diagonal
      }
    }
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
  std::map<std::string, std::unique_ptr<Primitive>> visible_references;  // outlive the jobs that point at them
  const std::vector<Point> points = MeasureSnapshots(meshes, snapshot_files, runs, distances, visible_references);
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
