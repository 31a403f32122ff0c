#!/usr/bin/env python3
"""Plots and tables from the benchmark's JSON (bench/bench_progressive.cc).

usage: bench/plot.py [RESULTS.json] [--out DIR] [--doc docs/results/benchmarks.md]

Writes into DIR (default: the JSON's folder):
  rd-<model>-qp<N>.png  bytes received against Hausdorff distance to the full
                        mesh: meshstream level by level, gltfpack -si LODs
  rdp-<model>-qp<N>.png the same for both profiles of format version 4
                        (loss-tolerant, reliable) beside the Draco LOD chain
                        (bytes downloaded up to each step), gltfpack's LODs
                        and, where ../shared/research has them, LLD's totals
  bpv.png               bits per vertex: meshstream (base / reliable stream /
                        datagrams) beside Draco cl7 and cl10
  times.png             decode and encode times against Draco's
  results.md            the tables and the targets, as Markdown
and replaces the text between "<!-- bench:results:begin -->" and
"<!-- bench:results:end -->" in the --doc file with results.md (when the
markers are there). Works headless (Agg backend).
"""
import argparse
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_common import load, output_dir, plt, save_figure, style_axes, update_doc, write_text  # noqa: E402

BEGIN = "<!-- bench:results:begin -->"
END = "<!-- bench:results:end -->"


def runs(data):
    for m in data["models"]:
        for r in m["runs"]:
            yield m, r


def kb(b):
    return b / 1024.0


def run_label(model, run):
    """A bar's label: the model's short name over its qp."""
    return "%s\nqp%d" % (model["name"].replace("stanford-", ""), run["qp"])


# ------------------------------------------------------------------ plots

ZERO = 1e-9  # distances below this fraction of the diagonal are rounding: the mesh is the full mesh


def plot_rd(model, run, path):
    rd = run.get("rate_distortion", {})
    levels = [l for l in rd.get("levels", []) if "hausdorff_rel" in l]
    if not levels:
        return False
    packs = [g for g in rd.get("gltfpack", []) if "hausdorff_rel" in g]
    d7 = run["draco"]["cl7"]["bytes"]
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.2))
    for ax, key, title in ((axes[0], "hausdorff_rel", "Hausdorff distance (max)"),
                           (axes[1], "mean_rel", "mean surface distance")):
        values = [l[key] for l in levels] + [g[key] for g in packs]
        nonzero = [v for v in values if v > ZERO]
        floor = (min(nonzero) / 4.0) if nonzero else 1e-6
        xs = [kb(l["bytes"]) for l in levels]
        ys = [l[key] if l[key] > ZERO else floor for l in levels]
        ax.plot(xs, ys, "-o", color="C0", ms=4, label="meshstream, level by level (bytes received, split packing)")
        for l, x, y in zip(levels, xs, ys):
            if l["level"] == 0 or l is levels[-1]:
                ax.annotate("L%d: %d v" % (l["level"], l["vertices"]), (x, y), textcoords="offset points",
                            xytext=(5, 4), fontsize=8, color="C0")
        if levels[-1][key] <= ZERO:
            ax.plot([xs[-1]], [floor], "s", color="C0", ms=8, label="meshstream full mesh: distance 0 (drawn at the floor)")
        if packs:
            gx = [kb(g["bytes"]) for g in packs]
            gy = [g[key] if g[key] > ZERO else floor for g in packs]
            ax.plot(gx, gy, "^:", color="C1", ms=7, label="gltfpack -si R (.glb, KHR_mesh_quantization)")
            cx = [kb(g["bytes_cc"]) for g in packs]
            ax.plot(cx, gy, "v:", color="C2", ms=7, label="gltfpack -si R -cc (EXT_meshopt_compression)")
            seen = set()
            for g, x, y in zip(packs, cx, gy):
                if g["vertices"] in seen:
                    continue  # gltfpack stopped simplifying: same LOD as a smaller R
                seen.add(g["vertices"])
                ax.annotate("R=%g" % g["ratio"], (x, y), textcoords="offset points", xytext=(-8, -13), fontsize=7,
                            color="C2")
        ax.axvline(kb(d7), color="C3", linestyle="--", linewidth=1, label="Draco cl7, whole mesh (%s B)" % fmt_int(d7))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("bytes received (KiB, log)")
        ax.set_ylabel("%s / bbox diagonal (log)" % title)
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=3, fontsize=8, frameon=False)
    fig.suptitle("%s, qp %d: distance to the full mesh against bytes received" % (model["name"], run["qp"]))
    save_figure(fig, path, 100, rect=(0, 0.08, 1, 1))
    return True


# Lee-Lavoue-Dupont 2012 (the valence-driven progressive coder of MEPP2, commit
# d977d054), lossless on the grid: total bits per referenced vertex by model
# and position bits, from ../shared/research/codec-anchors.md ("Sizes",
# measured 2026-12-01 on the project's machine). Positions and connectivity
# only (no normals); whole streams, no per-level figures. Drawn as one point
# at distance 0: bpv x the run's vertices / 8 bytes.
LLD_BPV = {
    ("stanford-bunny", 10): 13.36, ("stanford-bunny", 11): 15.96, ("stanford-bunny", 12): 18.81,
    ("horse", 10): 11.74, ("horse", 11): 14.12, ("horse", 12): 16.78,
}
LLD_SOURCE = "../shared/research/codec-anchors.md"


def same_grid(qp):
    """The distance (share of the diagonal) below which two meshes count as the same
    mesh on the qp grid: a tenth of a grid step. The chain's last step is Draco's
    decode of the whole mesh on the stream's grid, off by float rounding only
    (1e-7 to 2e-6 of the diagonal on the shared models); drawn at the floor like
    the exact full level."""
    return 0.1 / ((1 << qp) - 1)


def plot_profiles(model, run, path):
    """Both profiles level by level, the Draco LOD chain step by step (the bytes a
    client has downloaded when it shows each step), gltfpack's LODs and LLD's
    whole stream: distance to the full mesh against bytes."""
    rd = run.get("rate_distortion", {})
    levels = [l for l in rd.get("levels", []) if "hausdorff_rel" in l]
    if not levels or "reliable" not in run["meshstream"]:
        return False
    reliable = rd.get("reliable_same_meshes") and all("reliable_profile_bytes" in l for l in levels)
    chain = [c for c in rd.get("chain", []) if "hausdorff_rel" in c]
    packs = [g for g in rd.get("gltfpack", []) if "hausdorff_rel" in g]
    lld = LLD_BPV.get((model["name"], run["qp"]))
    d7 = run["draco"]["cl7"]["bytes"]
    zero = same_grid(run["qp"])
    fig, axes = plt.subplots(1, 2, figsize=(13, 5.6))
    for ax, key, title in ((axes[0], "hausdorff_rel", "Hausdorff distance (max)"),
                           (axes[1], "mean_rel", "mean surface distance")):
        values = [l[key] for l in levels] + [c[key] for c in chain] + [g[key] for g in packs]
        nonzero = [v for v in values if v > zero]
        floor = (min(nonzero) / 4.0) if nonzero else 1e-6

        def at_floor(v):
            return v if v > zero else floor

        ys = [at_floor(l[key]) for l in levels]
        xs = [kb(l["bytes"]) for l in levels]
        ax.plot(xs, ys, "-o", color="C0", ms=3.5,
                label="meshstream, loss-tolerant profile (split packing), level by level")
        if reliable:
            xr = [kb(l["reliable_profile_bytes"]) for l in levels]
            ax.plot(xr, ys, "-s", color="C4", ms=3.5,
                    label="meshstream, reliable profile (same meshes), level by level")
        if levels[-1][key] <= zero:
            ax.plot([xs[-1]] + ([xr[-1]] if reliable else []), [floor] * (2 if reliable else 1), "D", color="k",
                    ms=5, fillstyle="none",
                    label="full mesh: distance 0 or < 0.1 grid step (drawn at the floor)")
        if chain:
            cx = [kb(c["cumulative_bytes"]) for c in chain]
            cy = [at_floor(c[key]) for c in chain]
            # A client of the chain shows step i from its download on, until
            # step i+1 has arrived: a staircase.
            ax.plot(cx, cy, "-", drawstyle="steps-post", color="C3", linewidth=1.2)
            ax.plot(cx, cy, "o", color="C3", ms=6, mfc="white", mew=1.5,
                    label="Draco LOD chain: gltfpack -si R -noq + Draco cl7 per step, then the whole mesh "
                          "(bytes up to the step)")
            for c, x, y in zip(chain, cx, cy):
                what = "full" if c["ratio"] >= 1 else "1/%g" % (1.0 / c["ratio"])
                ax.annotate(what, (x, y), textcoords="offset points", xytext=(4, 5), fontsize=7, color="C3")
        if packs:
            gx = [kb(g["bytes"]) for g in packs]
            gy = [at_floor(g[key]) for g in packs]
            ax.plot(gx, gy, "^", color="C1", ms=6, alpha=0.7,
                    label="gltfpack -si R, one LOD (.glb, KHR_mesh_quantization)")
            ax.plot([kb(g["bytes_cc"]) for g in packs], gy, "v", color="C2", ms=6, alpha=0.7,
                    label="gltfpack -si R -cc, one LOD (EXT_meshopt_compression)")
        if lld:
            ax.plot([kb(lld * run["vertices"] / 8.0)], [floor], "*", color="C6", ms=12,
                    label="LLD 2012 (MEPP2), whole stream, positions only: %.2f bpv (%s)" % (lld, LLD_SOURCE))
        ax.axvline(kb(d7), color="C3", linestyle="--", linewidth=0.8,
                   label="Draco cl7, whole mesh (%s B)" % fmt_int(d7))
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("bytes received (KiB, log)")
        ax.set_ylabel("%s / bbox diagonal (log)" % title)
        ax.set_title(title)
        ax.grid(True, which="both", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=2, fontsize=7.5, frameon=False)
    fig.suptitle("%s, qp %d: both profiles against the Draco LOD chain" % (model["name"], run["qp"]))
    save_figure(fig, path, 100, rect=(0, 0.15, 1, 1))
    return True


def plot_bpv(data, path):
    labels, base, rel, unrel, d7, d10 = [], [], [], [], [], []
    for m, r in runs(data):
        s = r["meshstream"]["split"]
        labels.append(run_label(m, r))
        base.append(s["base_bpv"])
        rel.append(s["reliable_bpv"] - s["base_bpv"])
        unrel.append(s["unreliable_bpv"])
        d7.append(r["draco"]["cl7"]["bpv"])
        d10.append(r["draco"]["cl10"]["bpv"])
    n = len(labels)
    w = 0.27
    x = list(range(n))
    fig, ax = plt.subplots(figsize=(max(8, 1.1 * n), 5))
    xm = [i - w for i in x]
    ax.bar(xm, base, w, color="C0", label="meshstream: base mesh (Draco)")
    ax.bar(xm, rel, w, bottom=base, color="C9", label="meshstream: header, split bits, models (reliable)")
    ax.bar(xm, unrel, w, bottom=[a + b for a, b in zip(base, rel)], color="C1",
           label="meshstream: datagrams (unreliable)")
    ax.bar(x, d7, w, color="C3", label="Draco cl7")
    ax.bar([i + w for i in x], d10, w, color="C5", label="Draco cl10")
    for i in range(n):
        total = base[i] + rel[i] + unrel[i]
        ax.text(xm[i], total, "%.1f" % total, ha="center", va="bottom", fontsize=7)
        ax.text(x[i], d7[i], "%.1f" % d7[i], ha="center", va="bottom", fontsize=7)
    ax.set_xticks(x)
    ax.set_xticklabels(labels, fontsize=8)
    style_axes(ax, ylabel="bits per referenced input vertex",
               title="Size: meshstream (split packing) against Draco at the same quantization", axis="y")
    save_figure(fig, path, 110)


def plot_times(data, path):
    labels, dec, dec_b, d7, enc, e7 = [], [], [], [], [], []
    for m, r in runs(data):
        s = r["meshstream"]["split"]
        labels.append(run_label(m, r))
        dec.append(s["decode_ms"])
        dec_b.append(r["meshstream"]["bundled"]["decode_ms"])
        d7.append(r["draco"]["cl7"]["decode_ms"])
        enc.append(s["encode_ms"])
        e7.append(r["draco"]["cl7"]["encode_ms"])
    n = len(labels)
    x = list(range(n))
    w = 0.27
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(14, 5))
    a1.bar([i - w for i in x], dec, w, color="C0", label="meshstream, all levels (split)")
    a1.bar(x, dec_b, w, color="C9", label="meshstream, all levels (bundled)")
    a1.bar([i + w for i in x], d7, w, color="C3", label="Draco cl7 decode")
    a1.set_ylabel("decode time, ms (median)")
    a1.set_title("Decode")
    a2.bar([i - w / 2 for i in x], enc, w, color="C0", label="meshstream encode (split)")
    a2.bar([i + w / 2 for i in x], e7, w, color="C3", label="Draco cl7 encode")
    a2.axhline(1000, color="k", linestyle="--", linewidth=0.8, label="1 s (bunny target)")
    a2.set_ylabel("encode time, ms (median)")
    a2.set_title("Encode")
    for a in (a1, a2):
        a.set_xticks(x)
        a.set_xticklabels(labels, fontsize=7)
        style_axes(a, axis="y")
    save_figure(fig, path, 110)


# ----------------------------------------------------------------- tables

def fmt_int(v):
    return "{:,}".format(int(v))


def markdown(data, plots, prefix):
    mach = data["machine"]
    st = data["settings"]
    out = []
    out.append("Measured %s on %d x %s (%s), %s build, Draco %s%s; medians of %d in-process runs. "
               "qn %d, qt %d for both codecs; datagrams of at most %d bytes; base mesh Draco cl%d."
               % (mach["date"], mach["nproc"], mach["cpu"], mach.get("kernel", ""), mach.get("build_type", ""),
                  mach["draco"], (", " + mach["gltfpack"]) if mach.get("gltfpack") else "", st["repeat"],
                  st["qn"], st["qt"], st["packet_bytes"], st["base_compression_level"]))
    if mach.get("git_commit"):
        out.append("Source: commit %s." % mach["git_commit"])
    if mach.get("loadavg_at_start"):
        out.append("Load average at start %s, at end %s (other work on the machine widens the timings; "
                   "the JSON keeps every run and the minimum)." % (mach["loadavg_at_start"],
                                                                  mach.get("loadavg_at_end", "?")))
    out.append("")
    out.append("### Sizes (bytes; bpv = bits per referenced input vertex)")
    out.append("")
    out.append("| model | qp | vertices | levels | base | reliable | unreliable | **total** | total bpv | reliable bpv "
               "| bundled total | Draco cl7 | Draco cl10 | **x cl7** | x cl10 |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m, r in runs(data):
        s, b = r["meshstream"]["split"], r["meshstream"]["bundled"]
        rt = r["ratios"]["split"]
        out.append("| %s | %d | %s | %d | %s | %s | %s | **%s** | %.2f | %.2f | %s | %s | %s | **%.2f** | %.2f |" % (
            m["name"], r["qp"], fmt_int(r["vertices"]), s["levels"], fmt_int(s["base_bytes"]),
            fmt_int(s["reliable_bytes"]), fmt_int(s["unreliable_bytes"]), fmt_int(s["total_bytes"]), s["total_bpv"],
            s["reliable_bpv"], fmt_int(b["total_bytes"]), fmt_int(r["draco"]["cl7"]["bytes"]),
            fmt_int(r["draco"]["cl10"]["bytes"]), rt["total_vs_draco_cl7"], rt["total_vs_draco_cl10"]))
    out.append("")
    out.append("`reliable` includes the base mesh (Draco bytes), the stream header, split bits and models; "
               "`unreliable` is every datagram with its header; `total` = reliable + unreliable (the .glb "
               "container adds its JSON, see `file_bytes` in the JSON). Draco: the whole Draco buffer of the "
               "same primitive at the same qp/qn/qt.")
    out.append("")
    profiles_table(data, out)
    out.append("### Times (ms, medians)")
    out.append("")
    out.append("| model | qp | encode | decode all levels (split) | decode (bundled) | decode base only | "
               "Draco cl7 encode | Draco cl7 decode | Draco cl10 decode | **decode x Draco cl7** |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m, r in runs(data):
        s, b = r["meshstream"]["split"], r["meshstream"]["bundled"]
        out.append("| %s | %d | %.0f | %.1f | %.1f | %.2f | %.1f | %.2f | %.2f | **%.2f** |" % (
            m["name"], r["qp"], s["encode_ms"], s["decode_ms"], b["decode_ms"], s.get("decode_base_ms", float("nan")),
            r["draco"]["cl7"]["encode_ms"],
            r["draco"]["cl7"]["decode_ms"], r["draco"]["cl10"]["decode_ms"],
            r["ratios"]["split"]["decode_vs_draco_cl7"]))
    out.append("")
    out.append("meshstream decode: `DecodeProgressiveGlb`, from the .glb bytes in memory to the final mesh in "
               "memory (glTF parse, Draco base, every refinement, dequantization). Draco decode: "
               "`draco::Decoder::DecodeMeshFromBuffer`, buffer to `draco::Mesh` (dequantized).")
    out.append("")
    out.append("### Levels")
    out.append("")
    out.append("| model | qp | levels | base vertices | mean growth per level | min | max | level vertices |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---|")
    for m, r in runs(data):
        s = r["meshstream"]["split"]
        g = s["growth"] or [0]
        lv = s["level_vertices"]
        out.append("| %s | %d | %d | %s | %.1f %% | %.1f %% | %.1f %% | %s |" % (
            m["name"], r["qp"], s["levels"], fmt_int(s["base_vertices"]), 100 * s["mean_growth"], 100 * min(g),
            100 * max(g), " ".join(str(v) for v in lv)))
    out.append("")
    out.append("### Where the bits go")
    out.append("")
    out.append("Measured bytes per channel against the order-0 entropy (H0) of what the refinements carry "
               "(per refinement, its own model), in bits per referenced vertex; split packing. "
               "`datagrams - H0` is what the datagrams cost beyond that bound (their headers, model "
               "precision, context-free coding).")
    out.append("")
    out.append("| model | qp | base | header + split bits + models | split bits H0 | datagrams | structure H0 | "
               "geometry H0 | attributes H0 | datagrams - H0 | struct. bits/split H0 | geom. bits/split H0 |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m, r in runs(data):
        s = r["meshstream"]["split"]
        e = r.get("entropy_order0")
        if not e:
            continue
        out.append("| %s | %d | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f |" % (
            m["name"], r["qp"], s["base_bpv"], s["reliable_bpv"] - s["base_bpv"], e["split_bits_bpv"],
            s["unreliable_bpv"], e["structure_bpv"], e["geometry_bpv"], e["attribute_bpv"],
            s["unreliable_bpv"] - e["structure_bpv"] - e["geometry_bpv"] - e["attribute_bpv"],
            e["structure_bits_per_split"], e["geometry_bits_per_split"]))
    out.append("")
    out.append("### Rate-distortion")
    out.append("")
    out.append("Bytes received up to level K (base, header, control blocks and datagrams of refinements "
               "1..K) against the symmetric Hausdorff distance between the level-K mesh and the full mesh, "
               "relative to the bounding-box diagonal (%s samples per side); beside them the LODs `gltfpack "
               "-si R` makes from the same full mesh (%s)." % (fmt_int(st["hausdorff_samples_per_side"]),
                                                             st["gltfpack_mode"]))
    out.append("")
    for p in plots["rd"]:
        out.append("![%s](%s%s)" % (p, prefix, p))
    out.append("")
    for m, r in runs(data):
        if r["qp"] != 11:
            continue
        rd = r.get("rate_distortion", {})
        lv = rd.get("levels", [])
        if not lv or "hausdorff_rel" not in lv[0]:
            continue
        cells = ["L%d %s B %.2g" % (l["level"], fmt_int(l["bytes"]), l["hausdorff_rel"]) for l in lv[::3]]
        gp = ["R%g %s B (cc %s B) %.2g" % (g["ratio"], fmt_int(g["bytes"]), fmt_int(g["bytes_cc"]),
                                            g.get("hausdorff_rel", float("nan"))) for g in rd.get("gltfpack", [])]
        out.append("- **%s qp 11**: meshstream %s; gltfpack %s." % (m["name"], "; ".join(cells), "; ".join(gp)))
    out.append("")
    chain_table(data, plots, prefix, out)
    out.append("![bits per vertex](%sbpv.png)" % prefix)
    out.append("")
    out.append("![times](%stimes.png)" % prefix)
    out.append("")
    out.append("### What each lever of codec versions 2 and 3 saved")
    out.append("")
    out.append("The split packing encoded with the tools of format versions 2 and 3 added one at a time "
               "(docs/design/codec.md; `StreamWriteOptions::tools`), each decoded once; bits per split saved = "
               "8 x bytes saved against the row above / splits. The version 3 rows are format version 3's lever "
               "table (the last row is the ring predictor's 2-ring term, which the default encoder "
               "charges 0.5 bit per split for the decoder's time; docs/design/codec.md).")
    out.append("")
    out.append("| model | qp | lever | total bytes | total bpv | bits per split saved |")
    out.append("|---|---:|---|---:|---:|---:|")
    for m, r in runs(data):
        for lv in r.get("levers", []):
            out.append("| %s | %d | %s | %s | %.2f | %.2f |" % (
                m["name"], r["qp"], lv["lever"], fmt_int(lv["total_bytes"]), lv["total_bpv"],
                lv["bits_per_split_saved"]))
    out.append("")
    out.append("### Targets of the codec (sizes, decode time, levels)")
    out.append("")
    out.append("| target | model | qp | measured (split) | measured (bundled) | limit | verdict |")
    out.append("|---|---|---:|---:|---:|---:|---|")
    for t in data["targets"]:
        if t.get("issue") == 42:
            continue
        out.append("| %s | %s | %d | %.3g | %.3g | %g | %s |" % (
            target_text(t), t["model"], t["qp"], t["value"], t["value_bundled"], t["limit"],
            "**met**" if t["met"] else "**not met**"))
    out.append("")
    issue42_targets(data, out)
    return "\n".join(out)


def target_text(t):
    """A target's words without the issue that set it ("issue 24: x" -> "x"); the JSON keeps both."""
    return re.sub(r"^issues? [0-9, and]+: ", "", t["target"])


def same_meshes_note(rows):
    """What the benchmark's check of the profiles' level meshes found (rate_distortion.reliable_same_meshes)."""
    differ = ["%s qp %d" % (m["name"], r["qp"]) for m, r in rows
              if r.get("rate_distortion", {}).get("reliable_same_meshes") is False]
    if differ:
        return " (except where the check found other meshes: %s)" % ", ".join(differ)
    return " (checked level by level)"


def profiles_table(data, out):
    """The table "Profiles": each profile's bytes and decode time against Draco cl7."""
    rows = [(m, r) for m, r in runs(data) if "reliable" in r["meshstream"]]
    if not rows:
        return
    out.append("### Profiles (format version 4)")
    out.append("")
    out.append("The loss-tolerant profile (the library default; split and bundled packings) and the reliable "
               "profile (`ProfileSet::kReliable`: no datagrams, every refinement's data in its control block; "
               "docs/spec/progressive-format.md, section 11), encoded from the same hierarchy: the same meshes at "
               "every level, other bytes%s. Total = base + header + control blocks (+ datagrams); decode = "
               "`DecodeProgressiveGlb` of all levels on one thread with default options, timed in the same "
               "interleaved rounds as Draco's." % same_meshes_note(rows))
    out.append("")
    out.append("| model | qp | loss-tolerant (split) | bundled | **reliable** | Draco cl7 | loss-tolerant x cl7 | "
               "**reliable x cl7** | reliable / loss-tolerant | decode split (ms) | decode reliable (ms) | "
               "Draco cl7 decode (ms) | split decode x cl7 | reliable decode x cl7 |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m, r in rows:
        s, b, rel = r["meshstream"]["split"], r["meshstream"]["bundled"], r["meshstream"]["reliable"]
        rs, rr = r["ratios"]["split"], r["ratios"]["reliable"]
        out.append("| %s | %d | %s | %s | **%s** | %s | %.3f | **%.3f** | %.3f | %.1f | %.1f | %.1f | %.2f | %.2f |" % (
            m["name"], r["qp"], fmt_int(s["total_bytes"]), fmt_int(b["total_bytes"]), fmt_int(rel["total_bytes"]),
            fmt_int(r["draco"]["cl7"]["bytes"]), rs["total_vs_draco_cl7"], rr["total_vs_draco_cl7"],
            rel["total_bytes"] / float(s["total_bytes"]), s["decode_ms"], rel["decode_ms"],
            r["draco"]["cl7"]["decode_ms"], rs["decode_vs_draco_cl7"], rr["decode_vs_draco_cl7"]))
    out.append("")


def step_name(ratio):
    """A step of the Draco LOD chain by its gltfpack ratio: 1/64, ..., the whole mesh."""
    return "whole mesh" if ratio >= 1 else "1/%g" % (1.0 / ratio)


def fmt_reach(e):
    """A profile's cell of the chain table: the level that reaches the step, its bytes, x the chain's."""
    if e is None:
        return "n/a"
    if e["level"] is None:
        return "not reached"
    return "L%d %s B **%.2f**" % (e["level"], fmt_int(e["bytes"]), e["vs_chain"])


def chain_table(data, plots, prefix, out):
    """The Draco LOD chain against both profiles (rate_distortion.chain and .vs_chain)."""
    rows = [(m, r) for m, r in runs(data) if r.get("rate_distortion", {}).get("vs_chain")]
    if not rows:
        return
    st = data["settings"]
    out.append("#### Against the Draco LOD chain")
    out.append("")
    ratios = ", ".join("1/%g" % (1.0 / r) for r in st.get("chain_ratios", []))
    out.append("The chain is what a glTF viewer with separate LOD files downloads (needle's gltf-progressive "
               "pattern): `gltfpack -si R -noq` of the same full mesh for R = %s, each LOD compressed by Draco "
               "cl7 at the run's qp, qn and qt (positions on the LOD's own grid), then the whole mesh in Draco "
               "cl7; the client downloads them in order, so showing a step costs the chain's bytes up to it. A "
               "step's distance is that of the mesh Draco decodes from it, against the same full mesh. For each "
               "step and profile: the first level of the stream at most as far from the full mesh (Hausdorff), "
               "its bytes, and those bytes x the chain's (below 1: the stream needs fewer bytes to look at least "
               "as good; the target is at most 0.8 at every step). The same comparison by mean distance is "
               "`by_mean` in the JSON." % ratios)
    out.append("")
    out.append("| model | qp | step | vertices | step bytes | chain bytes | Hausdorff | loss-tolerant: level, bytes, "
               "**x chain** | reliable: level, bytes, **x chain** |")
    out.append("|---|---:|---|---:|---:|---:|---:|---|---|")
    for m, r in rows:
        rd = r["rate_distortion"]
        chain = {c["step"]: c for c in rd.get("chain", [])}
        for v in rd["vs_chain"]:
            c = chain.get(v["step"], {})
            what = step_name(v["ratio"])
            out.append("| %s | %d | %s | %s | %s | %s | %.2g | %s | %s |" % (
                m["name"], r["qp"], what, fmt_int(c.get("vertices", 0)), fmt_int(c.get("bytes", 0)),
                fmt_int(v["chain_bytes"]), v["hausdorff_rel"], fmt_reach(v["loss_tolerant"]),
                fmt_reach(v["reliable"])))
    out.append("")
    for p in plots.get("rdp", []):
        out.append("![%s](%s%s)" % (p, prefix, p))
    out.append("")


def issue42_targets(data, out):
    """Issue 42's targets: each profile against Draco cl7 and the LOD chain."""
    ts = [t for t in data["targets"] if t.get("issue") == 42]
    if not ts:
        return
    out.append("### Targets of format version 4's profiles")
    out.append("")
    out.append("Loss-tolerant rows give the split packing, then the bundled one (both must meet the limit); the "
               "chain rows give the worst step of the Draco LOD chain.")
    out.append("")
    out.append("| target | model | qp | profile | measured | limit | verdict |")
    out.append("|---|---|---:|---|---:|---:|---|")
    for t in ts:
        measured = "%.3g" % t["value"]
        if t["profile"] == "loss-tolerant" and t["value_bundled"] != t["value"]:
            measured += " / %.3g" % t["value_bundled"]
        if t.get("worst_step_ratio") is not None:
            measured += " (at %s)" % step_name(t["worst_step_ratio"])
        if t.get("unreached_steps"):
            measured += ", %d steps not reached" % t["unreached_steps"]
        out.append("| %s | %s | %d | %s | %s | %g | %s |" % (
            target_text(t), t["model"], t["qp"], t["profile"], measured, t["limit"],
            "**met**" if t["met"] else "**not met**"))
    out.append("")


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?", default=os.path.join(root, "docs", "bench", "results.json"))
    ap.add_argument("--out", default=None, help="folder for the PNGs and results.md (default: the JSON's folder)")
    ap.add_argument("--doc", default=os.path.join(root, "docs", "benchmarks.md"),
                    help="Markdown file whose marked section receives the tables ('' to skip)")
    a = ap.parse_args()
    data = load(a.results)
    out = output_dir(a.out, a.results)

    plots = {"rd": [], "rdp": []}
    written = 2
    for m, r in runs(data):
        name = "rd-%s-qp%d.png" % (m["name"], r["qp"])
        if plot_rd(m, r, os.path.join(out, name)):
            written += 1
            if r["qp"] == 11:
                plots["rd"].append(name)
        name = "rdp-%s-qp%d.png" % (m["name"], r["qp"])
        if plot_profiles(m, r, os.path.join(out, name)):
            written += 1
            if r["qp"] == 11:
                plots["rdp"].append(name)
    plot_bpv(data, os.path.join(out, "bpv.png"))
    plot_times(data, os.path.join(out, "times.png"))
    write_text(os.path.join(out, "results.md"),
               "# Benchmark results\n\n(generated by bench/plot.py from results.json)\n\n" + markdown(data, plots, ""))
    if a.doc and os.path.exists(a.doc):
        if update_doc(a.doc, BEGIN, END, out, lambda prefix: markdown(data, plots, prefix)):
            print("plot.py: updated %s" % a.doc)
    print("plot.py: wrote %d plots and results.md into %s" % (written, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
