#!/usr/bin/env python3
"""The ranged-GET benchmark's report (make bench-ranges): the generated section of
docs/results/http-ranges.md and its plot from the JSON of meshstream_bench_ranges.

usage: plot_ranges.py docs/results/bench/http-ranges.json --doc docs/results/http-ranges.md
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_common import load, output_dir, plt, save_figure, update_doc  # noqa: E402

BEGIN = "<!-- bench:http-ranges:begin -->"
END = "<!-- bench:http-ranges:end -->"


def plot(data, out):
    rows = data["rows"]
    labels = ["%s\n%s" % (r["model"], r["kind"]) for r in rows]
    xs = range(len(rows))
    fig, ax = plt.subplots(figsize=(8, 3.8))
    ax.bar([x - 0.2 for x in xs], [r["median_store_gets_per_s"] for r in rows], 0.4,
           label="from the store (read + SHA-256 per request)")
    ax.bar([x + 0.2 for x in xs], [r["median_hot_gets_per_s"] for r in rows], 0.4,
           label="from the hot artifacts (lookup + slice)")
    ax.set_yscale("log")
    ax.set_xticks(list(xs))
    ax.set_xticklabels(labels, fontsize=7)
    ax.set_ylabel("ranged GETs per second (median)")
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7)
    name = "http-ranges.png"
    save_figure(fig, os.path.join(out, name), 110)
    return name


def markdown(data, png, prefix):
    m = data["machine"]
    s = data["settings"]
    out = ["Measured %s on %s, commit %s, %s build; %d interleaved rounds of %.2g s per way and kind; "
           "load %s at start, %s at end." % (m.get("date", "?"), m.get("cpu", "?"), m.get("git_commit", "?"),
                                             m.get("build_type", "?"), s["rounds"], s["seconds"],
                                             m.get("loadavg_at_start", "?"), m.get("load_at_end", "?")),
           "",
           "| model | file bytes | request | bytes served | from the store, GETs/s | hot, GETs/s | **hot / store** "
           "| copy floor, /s | hot + copy, GETs/s | **(hot + copy) / store** |",
           "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for r in data["rows"]:
        # A request that also copies its bytes once: the two costs add.
        both = 1.0 / (1.0 / r["median_hot_gets_per_s"] + 1.0 / r["median_copy_per_s"])
        out.append("| %s | %s | %s | %s | %s | %s | **%.0f x** | %s | %s | **%.1f x** |" % (
            r["model"], "{:,}".format(r["file_bytes"]), r["range"] or "whole file", "{:,}".format(r["bytes"]),
            "{:,.0f}".format(r["median_store_gets_per_s"]), "{:,.0f}".format(r["median_hot_gets_per_s"]),
            r["median_ratio"], "{:,.0f}".format(r["median_copy_per_s"]), "{:,.0f}".format(both),
            both / r["median_store_gets_per_s"]))
    h = data.get("hot_artifacts", {})
    out += ["", "Hot artifacts over the whole run: {:,} loads, {:,} hits (one load per model). The copy floor is "
            "one memcpy of the bytes served, the least a server pays to write them; hot + copy adds the two "
            "costs, a bound on what the change gives a request that goes out over a socket.".format(
        h.get("loads", 0), h.get("hits", 0)), "", "![ranged GETs per second](%s%s)" % (prefix, png)]
    return "\n".join(out)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("json")
    ap.add_argument("--doc", required=True)
    ap.add_argument("--out", help="folder of the plot (default: the JSON's)")
    a = ap.parse_args()
    data = load(a.json)
    out = output_dir(a.out, a.json)
    png = plot(data, out)
    if not update_doc(a.doc, BEGIN, END, out, lambda prefix: markdown(data, png, prefix)):
        sys.exit("plot_ranges.py: %s has no %s ... %s markers" % (a.doc, BEGIN, END))
    print("plot_ranges.py: updated %s" % a.doc)


if __name__ == "__main__":
    main()
