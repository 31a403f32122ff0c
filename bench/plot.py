#!/usr/bin/env python3
"""Plots and tables from the benchmark's JSON (bench/bench_progressive.cc).

usage: bench/plot.py [RESULTS.json] [--out DIR] [--doc docs/benchmarks.md]

Writes into DIR (default: the JSON's folder):
  rd-<model>-qp<N>.png  bytes received against Hausdorff distance to the full
                        mesh: meshstream level by level, gltfpack -si LODs
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
    out.append("![bits per vertex](%sbpv.png)" % prefix)
    out.append("")
    out.append("![times](%stimes.png)" % prefix)
    out.append("")
    out.append("### What each lever of codec versions 2 and 3 saved")
    out.append("")
    out.append("The split packing encoded with the tools of format versions 2 and 3 added one at a time "
               "(docs/codec.md; `StreamWriteOptions::tools`), each decoded once; bits per split saved = "
               "8 x bytes saved against the row above / splits. The version 3 rows are issue 24's lever "
               "table (the last row is the ring predictor's 2-ring term, which the default encoder "
               "charges 0.5 bit per split for the decoder's time; docs/codec.md).")
    out.append("")
    out.append("| model | qp | lever | total bytes | total bpv | bits per split saved |")
    out.append("|---|---:|---|---:|---:|---:|")
    for m, r in runs(data):
        for lv in r.get("levers", []):
            out.append("| %s | %d | %s | %s | %.2f | %.2f |" % (
                m["name"], r["qp"], lv["lever"], fmt_int(lv["total_bytes"]), lv["total_bpv"],
                lv["bits_per_split_saved"]))
    out.append("")
    out.append("### Targets of issues 11, 24 and 25")
    out.append("")
    out.append("| target | model | qp | measured (split) | measured (bundled) | limit | verdict |")
    out.append("|---|---|---:|---:|---:|---:|---|")
    for t in data["targets"]:
        out.append("| %s | %s | %d | %.3g | %.3g | %g | %s |" % (
            t["target"], t["model"], t["qp"], t["value"], t["value_bundled"], t["limit"],
            "**met**" if t["met"] else "**not met**"))
    out.append("")
    return "\n".join(out)


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

    plots = {"rd": []}
    written = 2
    for m, r in runs(data):
        name = "rd-%s-qp%d.png" % (m["name"], r["qp"])
        if plot_rd(m, r, os.path.join(out, name)):
            written += 1
            if r["qp"] == 11:
                plots["rd"].append(name)
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
