#include "bench/stream/shaped_summary.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string>

#include "bench/bench_util.h"
#include "codec/loss/protection.h"

namespace meshstream::bench::stream {

using json = nlohmann::json;

namespace {

json ShapedMsSummary(std::vector<double> v) {
  json out = {{"n", v.size()}};
  if (v.empty()) return out;
  std::sort(v.begin(), v.end());
  out["median_ms"] = Median(v);
  out["min_ms"] = v.front();
  out["max_ms"] = v.back();
  out["runs_ms"] = v;
  return out;
}

// What the successful runs of one cell measured, run by run.
struct Cell {
  std::vector<double> first, full, final_h, predicted, lost, received, rate, srtt, decreases, within1, within01, visible1, visible01;
  // Where a session's time went (SessionStats): the base, the last arrival,
  // the decoding left after it, the session thread's CPU, the HELLO.
  std::vector<double> base, last_arrival, decode_after, thread_cpu, hello_rtt, connect;
  // Parity (issue 27): its bytes, what it rebuilt, what came over UDP at all.
  std::vector<double> parity_bytes, recovered, udp_received;
  uint64_t n = 0, failed = 0, fallbacks = 0;
  json errors = json::array();

  void Add(const json& r) {
    ++n;
    if (!r.value("ok", false)) {
      ++failed;
      if (errors.size() < 5) errors.push_back(r.value("error", std::string("?")));
      return;
    }
    first.push_back(r["first_ms"]);
    full.push_back(r["full_ms"]);
    AddQuality(r["quality"]);
    if (r.contains("predicted_vertices")) predicted.push_back(r["predicted_vertices"]);
    if (r.contains("connect_ms")) connect.push_back(r["connect_ms"]);
    if (r.contains("last_byte_ms")) {  // the Draco download: its last byte, then its decode
      last_arrival.push_back(r["last_byte_ms"]);
      decode_after.push_back(r.value("decode_ms", 0.0));
    }
    if (r.contains("stats")) {
      const json& st = r["stats"];
      base.push_back(st.value("time_to_base_ms", 0.0));
      last_arrival.push_back(st.value("last_arrival_ms", 0.0));
      decode_after.push_back(st.value("decode_after_last_byte_ms", 0.0));
      thread_cpu.push_back(st.value("session_thread_cpu_ms", 0.0));
      hello_rtt.push_back(st.value("hello_rtt_ms", 0.0));
      parity_bytes.push_back(st.value("parity_bytes", 0.0));
      recovered.push_back(st.value("datagrams_recovered", 0.0));
      udp_received.push_back(st.value("udp_datagrams_received", 0.0));
      lost.push_back(r["stats"]["datagrams_lost"]);
      received.push_back(r["stats"]["datagrams_received"]);
      if (!r["stats"]["fallback_reason"].get<std::string>().empty()) ++fallbacks;
    }
    if (r.contains("server")) {
      rate.push_back(r["server"]["final_rate_mbps"]);
      srtt.push_back(r["server"]["srtt_ms"]);
      decreases.push_back(r["server"]["decreases"]);
    }
  }

  // The final distance, and when the mesh shown first came within 1 % and
  // 0.1 % of the diagonal.
  void AddQuality(const json& q) {
    if (!q.empty() && q.back().contains("hausdorff_rel")) final_h.push_back(q.back()["hausdorff_rel"]);
    double t1 = -1, t01 = -1;
    for (const json& p : q) {
      if (!p.contains("hausdorff_rel") || !p.contains("t_ms")) continue;
      const double h = p["hausdorff_rel"];
      if (t1 < 0 && h <= 0.01) t1 = p["t_ms"];
      if (t01 < 0 && h <= 0.001) t01 = p["t_ms"];
    }
    if (t1 >= 0) within1.push_back(t1);
    if (t01 >= 0) within01.push_back(t01);
    // The view run: when what the camera sees came within 1 % and 0.1 %.
    double v1 = -1, v01 = -1;
    for (const json& p : q) {
      if (!p.contains("visible_hausdorff_rel") || !p.contains("t_ms")) continue;
      const double h = p["visible_hausdorff_rel"];
      if (v1 < 0 && h <= 0.01) v1 = p["t_ms"];
      if (v01 < 0 && h <= 0.001) v01 = p["t_ms"];
    }
    if (v1 >= 0) visible1.push_back(v1);
    if (v01 >= 0) visible01.push_back(v01);
  }

  json Json(int loss, const std::string& model, const std::string& kind) const {
    json s = {{"loss_percent", loss}, {"model", model}, {"kind", kind}, {"runs", n}, {"failures", failed},
              {"first_ms", ShapedMsSummary(first)}, {"full_ms", ShapedMsSummary(full)},
              {"within_1pct_ms", ShapedMsSummary(within1)}, {"within_0_1pct_ms", ShapedMsSummary(within01)},
              {"final_hausdorff_rel_median", Median(final_h)},
              {"final_hausdorff_rel_max", final_h.empty() ? 0.0 : *std::max_element(final_h.begin(), final_h.end())}};
    if (!errors.empty()) s["errors"] = errors;
    if (!visible1.empty() || !visible01.empty()) {
      s["visible_within_1pct_ms"] = ShapedMsSummary(visible1);
      s["visible_within_0_1pct_ms"] = ShapedMsSummary(visible01);
      const double f = Median(full);
      if (f > 0) {
        s["visible_vs_full"] = {{"within_1pct", Median(visible1) / f}, {"within_0_1pct", Median(visible01) / f}};
      }
    }
    if (kind != "draco_export") {
      s["predicted_vertices_median"] = Median(predicted);
      s["datagrams_lost_median"] = Median(lost);
      s["datagrams_received_median"] = Median(received);
      s["udp_datagrams_received_median"] = Median(udp_received);
      s["parity_bytes_median"] = Median(parity_bytes);
      s["datagrams_recovered_median"] = Median(recovered);
      s["fallbacks"] = fallbacks;
      s["server_final_rate_mbps_median"] = Median(rate);
      s["server_srtt_ms_median"] = Median(srtt);
      s["server_rate_decreases_median"] = Median(decreases);
      // Medians, each over the runs on its own (they need not add up).
      s["breakdown_ms"] = {{"connect", Median(connect)},
                           {"open_to_base", Median(base)},
                           {"open_to_last_arrival", Median(last_arrival)},
                           {"decode_after_last_byte", Median(decode_after)},
                           {"session_thread_cpu", Median(thread_cpu)},
                           {"hello_rtt", Median(hello_rtt)}};
    } else {
      s["breakdown_ms"] = {{"connect", Median(connect)},
                           {"open_to_last_arrival", Median(last_arrival)},
                           {"decode_after_last_byte", Median(decode_after)}};
    }
    return s;
  }
};

// Issue 27's targets on the shaped link, for the udp entry `u` against the
// udp_no_parity entry `n` of the same loss and model: the median time to
// full may exceed the one without parity by at most the median parity
// bytes at the link's rate, and the final distance stays within the loss
// targets (median 0.1 %, worst 0.25 % of the diagonal). An excess smaller
// than the runs' own spread (the larger median absolute deviation of the
// two kinds' times) is "within_noise": medians of a few runs on a shared
// machine move by that much between identical sessions. "no_parity": the
// median run sent none, so the two kinds are the same sessions.
json VsNoParity(const json& u, const json& n, double rate_mbit) {
  if (!u["full_ms"].contains("median_ms") || !n["full_ms"].contains("median_ms")) return nullptr;
  const double with = u["full_ms"]["median_ms"], without = n["full_ms"]["median_ms"];
  const double parity_ms = u.value("parity_bytes_median", 0.0) * 8 / (rate_mbit * 1e3);
  auto mad = [](const json& s) {
    std::vector<double> v = s.value("runs_ms", std::vector<double>{});
    if (v.empty()) return 0.0;
    const double m = Median(v);
    for (double& x : v) x = std::abs(x - m);
    return Median(v);
  };
  const double noise = std::max(mad(u["full_ms"]), mad(n["full_ms"]));
  const double excess = with - without - parity_ms;
  const double median = u["final_hausdorff_rel_median"], worst = u["final_hausdorff_rel_max"];
  return {{"full_ms_with", with},
          {"full_ms_without", without},
          {"full_ms_difference", with - without},
          {"parity_ms_at_link_rate", parity_ms},
          {"run_spread_ms", noise},
          {"time_verdict", u.value("parity_bytes_median", 0.0) == 0 ? "no_parity"
                           : excess <= 0                             ? "met"
                           : excess <= noise                         ? "within_noise"
                                                                     : "not_met"},
          {"final_distance_median_without", n["final_hausdorff_rel_median"]},
          {"final_distance_max_without", n["final_hausdorff_rel_max"]},
          {"distance_met", median <= kHarmTarget && worst <= kHarmWorst}};
}

}  // namespace

json ShapedSummary(const std::vector<int>& losses, const std::vector<Model>& models, const json& runs,
                   double rate_mbit) {
  json summary = json::array();
  for (int loss : losses) {
    for (const Model& m : models) {
      std::map<std::string, json> by_kind;
      for (const char* kind : kShapedKinds) {
        Cell cell;
        for (const json& r : runs) {
          if (r["loss_percent"] == loss && r["model"] == m.name && r["kind"] == kind) cell.Add(r);
        }
        by_kind[kind] = cell.Json(loss, m.name, kind);
      }
      const json& d = by_kind["draco_export"];
      for (const char* kind : {"udp", "udp_no_parity", "tcp_only"}) {
        json& s = by_kind[kind];
        if (s["first_ms"].contains("median_ms") && d["first_ms"].contains("median_ms")) {
          s["vs_draco"] = {{"first", s["first_ms"]["median_ms"].get<double>() / d["first_ms"]["median_ms"].get<double>()},
                           {"full", s["full_ms"]["median_ms"].get<double>() / d["full_ms"]["median_ms"].get<double>()}};
        }
      }
      by_kind["udp"]["vs_no_parity"] = VsNoParity(by_kind["udp"], by_kind["udp_no_parity"], rate_mbit);
      for (const char* kind : kShapedKinds) summary.push_back(by_kind[kind]);
      Cell view;
      for (const json& r : runs) {
        if (r["loss_percent"] == loss && r["model"] == m.name && r["kind"] == kShapedViewKind) view.Add(r);
      }
      if (view.n > 0) summary.push_back(view.Json(loss, m.name, kShapedViewKind));
    }
  }
  return summary;
}

}  // namespace meshstream::bench::stream
