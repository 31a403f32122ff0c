#!/usr/bin/env python3
"""The viewer benchmark's plot and table (docs/results/viewer-benchmarks.md)
from the JSON of bench/viewer/run.sh.
usage: plot_viewer.py viewer.json [--out DIR] [--doc docs/results/viewer-benchmarks.md]"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plot_common  # noqa: E402
from plot_common import plt  # noqa: E402

BEGIN = "<!-- viewer-table:begin (bench/plot_viewer.py) -->"
END = "<!-- viewer-table:end -->"


def label(r):
    return "%s\n%s" % (r["asset"], "every level" if r["min_update_ms"] == 0 else "<= %d/s" % (1000 // r["min_update_ms"]))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("json")
    p.add_argument("--out")
    p.add_argument("--doc")
    a = p.parse_args()
    d = plot_common.load(a.json)
    out = plot_common.output_dir(a.out, a.json)
    rows = d["results"]
    t = d["targets"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    x = range(len(rows))
    ax = axes[0]
    ax.bar([i - 0.3 for i in x], [r["same_frame_ratio_median"] for r in rows], 0.2, label="same frame w/o stream step: median")
    ax.bar([i - 0.1 for i in x], [r["same_frame_ratio_p99"] for r in rows], 0.2, label="same frame: p99")
    ax.bar([i + 0.1 for i in x], [r["frame_ratio_median"] for r in rows], 0.2, label="vs idle: median")
    ax.bar([i + 0.3 for i in x], [r["frame_ratio_p99"] for r in rows], 0.2, label="vs idle: p99")
    ax.axhline(t["frame_ratio_median"], color="C0", ls="--", lw=1)
    ax.axhline(t["frame_ratio_p99"], color="C1", ls="--", lw=1)
    ax.set_xticks(list(x))
    ax.set_xticklabels([label(r) for r in rows], fontsize=8)
    plot_common.style_axes(ax, ylabel="frame time ratio", title="frames while refining", legend_size=6)
    ax = axes[1]
    ax.bar([i - 0.2 for i in x], [r["upload_ratio_median"] for r in rows], 0.4, label="by changed ranges")
    ax.bar([i + 0.2 for i in x], [r["reupload_ratio_median"] for r in rows], 0.4, label="every level whole")
    ax.axhline(t["upload_ratio"], color="k", ls="--", lw=1)
    ax.set_xticks(list(x))
    ax.set_xticklabels([label(r) for r in rows], fontsize=8)
    ax.set_yscale("log")
    plot_common.style_axes(ax, ylabel="bytes uploaded / final buffers", title="GPU uploads over a session")
    plot_common.save_figure(fig, os.path.join(out, "viewer.png"), 110)

    def render(prefix):
        lines = [
            "Measured %s on %d cores, %s, %s pixels, each session's UDP at %.0f Mbit/s; %d runs pooled."
            % (d["date"][:10], d["machine"]["cpus"], d["machine"]["renderer"], d["size"], d["session_rate_mbit"],
               rows[0]["runs"]),
            "",
            "| model | levels shown | frames refining | the same frame with / without its stream step: median, p99 "
            "| frame median refining / idle | p99 refining / idle median "
            "| stream step p99 (budget) | uploaded / final buffers | every level whole / final |",
            "|---|---|---|---|---|---|---|---|---|",
        ]
        for r in rows:
            lines.append(
                "| %s, %s | %g of %d | %d | %.3f x, %.3f x | %.1f / %.1f ms = %.2f x | %.1f / %.1f ms = %.2f x | %.2f ms (%.1f) | %.2f x | %.2f x |"
                % (r["asset"], "every level" if r["min_update_ms"] == 0 else "<= %d updates/s" % (1000 // r["min_update_ms"]),
                   r["levels_shown_median"], r["levels"] + 1, r["refining_frames"], r["same_frame_ratio_median"],
                   r["same_frame_ratio_p99"], r["refining_frame_ms_median"],
                   r["idle_frame_ms_median"], r["frame_ratio_median"], r["refining_frame_ms_p99"],
                   r["idle_frame_ms_median"], r["frame_ratio_p99"], r["stream_us_p99"] / 1000.0,
                   r["budget_us"] / 1000.0, r["upload_ratio_median"], r["reupload_ratio_median"]))
        lines += ["", "![frame times and uploads](%sviewer.png)" % prefix]
        return "\n".join(lines)

    if a.doc and not plot_common.update_doc(a.doc, BEGIN, END, out, render):
        raise SystemExit(f"{a.doc}: the markers {BEGIN} ... {END} are missing")


if __name__ == "__main__":
    main()
