#!/usr/bin/env python3
"""Plots and tables from the loss experiments' JSON (bench/loss_experiments.cc).

usage: bench/plot_loss.py [LOSS.json] [--out DIR] [--doc docs/results/loss-results.md]

Writes into DIR (default: the JSON's folder):
  loss-levels-<model>.png  per level, Hausdorff and Laplacian distortion of the
                           predicted decode against the zero-loss decode of the
                           same level, one curve per loss ratio (paper Figs 6-9)
  loss-time.png            decoding time relative to the zero-loss decode (Fig 11)
  loss-packing.png         split against bundled packing at 12 %, per level (Figs 12-13)
  loss-lwop.png            prediction against LwoP at 12 %: Hausdorff and vertices
                           per level (Figs 14, and the vertex counts of 5.3)
  loss-final.png           final-level Hausdorff against loss, every model
  loss-cut.png             the paper's scheme against importance-ordered delivery
                           (the reliable cut): final-level Hausdorff against loss
  loss-results.md          the generated Markdown
and replaces the text between "<!-- loss:results:begin -->" and
"<!-- loss:results:end -->" in the --doc file with it. Every number of the
"Where we stand" list comes from the JSON. Works headless (Agg backend).
"""
import argparse
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_common import load, output_dir, plt, save_figure, style_axes, update_doc, write_text  # noqa: E402

BEGIN = "<!-- loss:results:begin -->"
END = "<!-- loss:results:end -->"
TARGET_TIME = 1.10
TARGET_HD = 0.005
TARGET_BETTER = 0.90
PAPER_BETTER = 0.70
PAPER_TIME = 1.10
PAPER_VERTS = (13023, 12063)  # predict, LwoP after three refinements at 12 %
MODEL_COLORS = ("C0", "C1", "C2", "C3", "C4")
# Issue 12's targets (at 12 % random loss, split packing, final level).
CUT_MEDIAN = 0.0025
CUT_WORST = 0.005
CUT_SHARE = 0.10
CUT_BETTER = 0.98
REPAIR_RATIO = 1.2


# Issue 27's targets.
TARGET_HARM = 0.001     # median Hausdorff at 12 %, share of the diagonal
TARGET_WORST = 0.0025   # the worst run
PARITY_LARGE = 0.20     # parity bytes, bunny and horse
PARITY_SMALL = 0.30     # the small models


def close(a, b):
    return abs(a - b) < 1e-9


def med(v):
    v = [x for x in v if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return statistics.median(v) if v else None


def quant(v, q):
    v = sorted(x for x in v if x is not None)
    if not v:
        return None
    return v[min(len(v) - 1, int(math.ceil(q * len(v))) - 1)]


def pct(x, digits=2):
    return "-" if x is None else "%.*f %%" % (digits, 100 * x)


def lossy(r):
    return r["datagrams_lost"] > 0


def better(r):
    """Prediction strictly closer (point-to-surface Hausdorff, final level) than LwoP."""
    p, l = r["predict"].get("hd_rel"), r["lwop"].get("hd_rel")
    return p is not None and l is not None and p < l


def cells(model):
    out = {}
    for r in model["runs"]:
        out.setdefault((r["packing"], r["pattern"], r["loss"]), []).append(r)
    order = {"split": 0, "bundled": 1, "random": 0, "bursty": 1}
    return sorted(out.items(), key=lambda kv: (order[kv[0][0]], order[kv[0][1]], kv[0][2]))


def per_level(runs, rec, key):
    """{level: median over runs} of runs that carry per-level metrics."""
    acc = {}
    for r in runs:
        for e in r[rec].get("levels", []):
            if e.get(key) is not None:
                acc.setdefault(e["level"], []).append(e[key])
    return {k: statistics.median(v) for k, v in sorted(acc.items())}


def random_runs(model, packing, loss):
    """The model's runs with random loss at this packing and loss ratio."""
    return [r for r in model["runs"] if r["packing"] == packing and r["pattern"] == "random" and close(r["loss"], loss)]


def level_runs(model, packing, loss, rec="predict"):
    return [r for r in random_runs(model, packing, loss) if "levels" in r[rec]]


def median_level_vertices(runs, rec, k):
    """Median vertex count after level k over the runs that reached it."""
    return med([r[rec]["level_vertices"][k - 1] for r in runs if len(r[rec]["level_vertices"]) >= k])


# ------------------------------------------------------------------ plots

def plot_percent(ax, by_level, style, label, **kw):
    """{level: fraction} as percentages against the level (kw: more ax.plot arguments)."""
    ax.plot(list(by_level), [100 * v for v in by_level.values()], style, ms=3, label=label, **kw)


def plot_recoveries(ax, xs, predict, lwop, color, name):
    """One model's prediction (solid) and LwoP (dashed) curves in its colour."""
    ax.plot(xs, predict, "o-", color=color, label="%s prediction" % name)
    ax.plot(xs, lwop, "s--", color=color, alpha=0.6, label="%s LwoP" % name)


def plot_levels(model, path):
    losses = sorted({r["loss"] for r in model["runs"] if "levels" in r["predict"] and r["packing"] == "split"})
    if not losses:
        return False
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
    cmap = plt.get_cmap("viridis")
    for i, loss in enumerate(losses):
        runs = level_runs(model, "split", loss)
        for ax, key in ((axes[0], "hd_rel"), (axes[1], "lap_rel")):
            plot_percent(ax, per_level(runs, "predict", key), "o-", "l = %d %%" % round(100 * loss),
                         color=cmap(i / max(1, len(losses) - 1)))
    n = len(level_runs(model, "split", losses[0]))
    axes[0].set_title("%s: Hausdorff (point-to-surface) to the zero-loss level" % model["name"])
    axes[1].set_title("%s: Laplacian distortion (Eq. 4)" % model["name"])
    for ax in axes:
        style_axes(ax, "level (refinements applied)", "% of the bbox diagonal")
    fig.suptitle("prediction, split packing, random loss, median of %d seeds" % n, fontsize=10)
    save_figure(fig, path, 90)
    return True


def plot_time(data, path):
    fig, ax = plt.subplots(figsize=(7, 4.5))
    any_ = False
    for m, c in zip(data["models"], MODEL_COLORS):
        t = m.get("timing")
        if not t:
            continue
        any_ = True
        plot_recoveries(ax, [100 * r["loss"] for r in t["rows"]], [r["predict"]["ratio"] for r in t["rows"]],
                        [r["lwop"]["ratio"] for r in t["rows"]], c, m["name"])
    ax.axhline(TARGET_TIME, color="red", lw=0.8, ls=":", label="target / paper at 12 %: 1.10")
    style_axes(ax, "loss ratio l (%)", "decode time / zero-loss decode time",
               "Decoding time relative to zero loss (median of in-process runs)")
    save_figure(fig, path, 90)
    return any_


def plot_packing(data, path):
    models = [m for m in data["models"] if level_runs(m, "bundled", 0.12)]
    if not models:
        return False
    fig, axes = plt.subplots(len(models), 2, figsize=(13, 4.2 * len(models)), squeeze=False)
    for row, m in zip(axes, models):
        for ax, key, title in ((row[0], "hd_rel", "Hausdorff"), (row[1], "lap_rel", "Laplacian")):
            for packing, style in (("split", "o-"), ("bundled", "s--")):
                plot_percent(ax, per_level(level_runs(m, packing, 0.12), "predict", key), style, packing)
            style_axes(ax, "level", "% of the bbox diagonal",
                       "%s, l = 12 %%: %s to the zero-loss level (median)" % (m["name"], title))
    save_figure(fig, path, 90)
    return True


def plot_lwop(data, path):
    models = [m for m in data["models"] if level_runs(m, "split", 0.12, "lwop")]
    if not models:
        return False
    fig, axes = plt.subplots(len(models), 2, figsize=(13, 4.2 * len(models)), squeeze=False)
    for row, m in zip(axes, models):
        runs = level_runs(m, "split", 0.12, "lwop")
        for rec, style in (("predict", "o-"), ("lwop", "s--")):
            plot_percent(row[0], per_level(runs, rec, "hd_rel"), style, rec)
        row[0].set_title("%s, l = 12 %%: Hausdorff to the zero-loss level (median of %d)" % (m["name"], len(runs)))
        row[0].set_ylabel("% of the bbox diagonal")
        allr = random_runs(m, "split", 0.12)
        lv = m["level_vertices"]
        row[1].plot(range(len(lv)), lv, "k:", label="lossless")
        for rec, style in (("predict", "o-"), ("lwop", "s--")):
            n = len(lv) - 1
            ys = [median_level_vertices(allr, rec, k) for k in range(1, n + 1)]
            row[1].plot(range(1, n + 1), ys, style, ms=3, label=rec)
        row[1].set_yscale("log")
        row[1].set_title("%s, l = 12 %%: vertices per level (median of %d)" % (m["name"], len(allr)))
        for ax in row:
            style_axes(ax, "level")
    save_figure(fig, path, 90)
    return True


def timing_at_12(model, column):
    """The model's timing row at 12 % loss when it has `column`, else None."""
    rows = [r for r in (model.get("timing") or {}).get("rows", []) if close(r["loss"], 0.12)]
    return rows[0] if rows and column in rows[0] else None


def cut_runs(model, loss=None, pattern="random"):
    return [r for r in model.get("cut_runs", []) if r["pattern"] == pattern and (loss is None or close(r["loss"], loss))]


def plot_cut(data, path):
    models = [m for m in data["models"] if m.get("cut_runs")]
    if not models:
        return False
    fig, ax = plt.subplots(figsize=(8, 4.8))
    for m, c in zip(models, MODEL_COLORS):
        losses = sorted({r["loss"] for r in cut_runs(m)})
        ax.plot([100 * l for l in losses], [100 * med([r["predict"]["hd_rel"] for r in random_runs(m, "split", l)])
                                            for l in losses], "--", color=c, marker="s", ms=3,
                label="%s, paper's scheme" % m["name"])
        ax.plot([100 * l for l in losses], [100 * med([r["predict"]["hd_rel"] for r in cut_runs(m, l)]) for l in losses],
                "-", color=c, marker="o", ms=3, label="%s, reliable cut" % m["name"])
    ax.axhline(100 * CUT_MEDIAN, color="red", lw=0.8, ls=":", label="target median 0.25 %")
    ax.set_yscale("log")
    style_axes(ax, "loss ratio l (%)", "Hausdorff, % of the bbox diagonal",
               "Final level against the zero-loss decode (median; prediction, split packing, random loss)", 7, 2)
    save_figure(fig, path, 90)
    return True


def cut_markdown(data):
    """Issue 12: the paper's scheme against importance-ordered delivery, and repair."""
    models = [m for m in data["models"] if m.get("cut_runs")]
    if not models:
        return []
    L = ["### Importance-ordered delivery and repair", ""]
    L.append("The reliable cut (docs/design/loss-tolerance.md, \"The reliable cut\") at --reliable-share %s: the refinements "
             "whose loss would displace most per byte travel with their datagrams on the reliable channel. Both "
             "schemes on the same seeds (the cut's datagrams take their draws too, so the others see the same loss). "
             "Repair bytes are what a repair puts on the gRPC stream for the run's losses (request, datagrams with "
             "their framing, RepairEnd), against the lost datagrams' bytes." % data["settings"].get("reliable_share"))
    L.append("")
    L.append("| model | cut (refinements of) | bytes moved | loss | paper hd median (worst) | cut hd median (worst) "
             "| cut LwoP hd median | prediction closer than LwoP, cut | repair / lost bytes (worst) | exact after repair |")
    L.append("|---|---|---:|---|---:|---:|---:|---:|---:|---:|")
    for m in models:
        rc = m.get("reliable_cut", {})
        for loss in (0.04, 0.12, 0.30):
            cr = cut_runs(m, loss)
            pr = random_runs(m, "split", loss)
            if not cr:
                continue
            ls = [r for r in cr if lossy(r)]
            ratios = [r["repair_bytes"] / r["lost_bytes"] for r in cr + pr if r.get("lost_bytes")]
            exact = sum(1 for r in cr + pr if r.get("repaired_identical"))
            L.append("| %s | %d of %d | %s | %d %% | %s (%s) | %s (%s) | %s | %s | %s | %d of %d |" % (
                m["name"], len(rc.get("refinements", [])), len(m["level_vertices"]) - 1, pct(rc.get("share"), 1),
                round(100 * loss), pct(med([r["predict"]["hd_rel"] for r in pr]), 3),
                pct(max(r["predict"]["hd_rel"] or 0 for r in pr), 3), pct(med([r["predict"]["hd_rel"] for r in cr]), 3),
                pct(max(r["predict"]["hd_rel"] or 0 for r in cr), 3), pct(med([r["lwop"]["hd_rel"] for r in cr]), 3),
                ("%s of %d" % (pct(sum(map(better, ls)) / len(ls), 0), len(ls))) if ls else "-",
                ("%.3f (%.3f)" % (med(ratios), max(ratios))) if ratios else "-", exact, len(cr) + len(pr)))
    L.append("")
    L.append("Median Hausdorff with the cut by loss ratio (prediction, split packing, random loss; the curve of "
             "loss-cut.png):")
    L.append("")
    losses = sorted({r["loss"] for m in models for r in cut_runs(m)})
    L.append("| model | " + " | ".join("%d %%" % round(100 * l) for l in losses) + " |")
    L.append("|---|" + "---:|" * len(losses))
    for m in models:
        L.append("| %s | %s |" % (m["name"], " | ".join(pct(med([r["predict"]["hd_rel"] for r in cut_runs(m, l)]), 3)
                                                       if cut_runs(m, l) else "-" for l in losses)))
    L.append("")

    # ---- error control: how far the error spreads level by level
    spread = [m for m in models if [r for r in cut_runs(m, 0.12) if "levels" in r["predict"]]]
    if spread:
        L.append("Error control, level by level (12 % random loss, prediction, split packing): median Hausdorff "
                 "to the zero-loss decode at the same level, the paper's scheme / the cut (the runs with "
                 "per-level metrics). Where the error falls from one level to the next, the exact later "
                 "splits pulled the surface back:")
        L.append("")
        for m in spread:
            paper = per_level(level_runs(m, "split", 0.12), "predict", "hd_rel")
            cut = per_level([r for r in cut_runs(m, 0.12) if "levels" in r["predict"]], "predict", "hd_rel")
            levels = sorted(set(paper) | set(cut))
            L.append("- %s: %s" % (m["name"], ", ".join(
                "L%d %s / %s" % (k, pct(paper.get(k), 2) if k in paper else "-", pct(cut.get(k), 2) if k in cut else "-")
                for k in levels)))
        L.append("")

    # ---- protection (issue 27): parity chosen by harm per byte
    L += protection_markdown(data, models)

    # ---- the targets, plainly
    L.append("**Targets of importance-ordered delivery and repair** (12 % random loss, split packing, final level):")
    L.append("")
    for m in models:
        cr = cut_runs(m, 0.12)
        if not cr:
            continue
        hd = [r["predict"]["hd_rel"] or 0 for r in cr]
        share = m.get("reliable_cut", {}).get("share", 0)
        L.append("- %s: median %s (target at most 0.25 %%: %s), worst %s (at most 0.5 %%: %s), with %s of the "
                 "stream's bytes moved (at most 10 %%: %s)." % (
                     m["name"], pct(med(hd), 3), verdict(med(hd) <= CUT_MEDIAN), pct(max(hd), 3),
                     verdict(max(hd) <= CUT_WORST), pct(share, 1), verdict(share <= CUT_SHARE + 1e-9)))
    cut_lossy = [r for m in models for r in m["cut_runs"] if lossy(r)]
    if cut_lossy:
        b = sum(map(better, cut_lossy)) / len(cut_lossy)
        L.append("- Prediction strictly closer than LwoP with the cut: %s of %d lossy runs (target at least 98 %%: %s; "
                 "the paper: about 70 %%)." % (pct(b, 1), len(cut_lossy), verdict(b >= CUT_BETTER)))
    for m in models:
        row = timing_at_12(m, "predict_cut")
        if row:
            x = row["predict_cut"]["ratio"]
            L.append("- Decoding at 12 %% with the cut, %s: %.2fx the zero-loss decode (%.1f ms; without the cut "
                     "%.2fx) — target at most 1.10x: %s." % (m["name"], x, row["predict_cut"]["median_ms"],
                                                          row["predict"]["ratio"], verdict(x <= TARGET_TIME)))
    for m in models:
        a, b = cut_runs(m, 0.12), cut_runs(m, 0.30)
        if a and b:
            x, y = med([r["predict"]["hd_rel"] for r in a]), med([r["predict"]["hd_rel"] for r in b])
            L.append("- Graceful to 30 %%, %s: median %s at 12 %%, %s at 30 %% (x%.2f; no cliff means at most 2x: %s)."
                     % (m["name"], pct(x, 3), pct(y, 3), y / x if x else 0, verdict(x and y / x <= 2)))
    rep = [r for m in models for r in m["runs"] + m["cut_runs"] if r.get("lost_bytes")]
    if rep:
        worst = max(r["repair_bytes"] / r["lost_bytes"] for r in rep)
        exact = all(r.get("repaired_identical") for m in models for r in m["runs"] + m["cut_runs"])
        L.append("- Repair: the decode after it is the zero-loss one in %s run; repair bytes at most %.3fx the lost "
                 "datagram bytes over %d lossy runs (target within 1.2x: %s). End to end through the relay: "
                 "tests/integration/stream_loss_test.cc, `RepairGivesTheExactMeshUnder12And30PercentLoss`."
                 % ("every" if exact else "**not every**", worst, len(rep), verdict(exact and worst <= REPAIR_RATIO)))
    L.append("")
    return L


def parity_runs(model, loss, pattern):
    return [r for r in model.get("parity_runs", []) if r["pattern"] == pattern and close(r["loss"], loss)]


def hd_cell(runs):
    if not runs:
        return "-"
    hd = [r["predict"]["hd_rel"] or 0 for r in runs]
    return "%s (%s)" % (pct(med(hd), 3), pct(max(hd), 3))


def protection_markdown(data, models):
    """Issue 27: the paper's scheme, the reliable cut, parity and repair side by side, and the targets."""
    par = [m for m in models if m.get("parity_runs")]
    if not par:
        return []
    L = ["### Protection: parity chosen by harm per byte", ""]
    L.append("docs/design/loss-protection.md has the design. Parity: Reed-Solomon datagrams over blocks of the refinements "
             "the encoder protects (the delivery record's `parity`, by each refinement's single-loss harm), sized "
             "for the run's own loss and burst length as a client's reports would show them, sent after each block "
             "and decoded by the reconstructor (an incomplete refinement whose control block announces parity is "
             "held until that parity has rebuilt it or cannot; one decoded with a prediction before a rebuilt "
             "datagram arrives is decoded again: *decoded again*, per run). All on the same seeds; prediction, split packing; Hausdorff "
             "distance to the loss-free decode, median (worst run); parity bytes as a share of the stream's bytes "
             "(base, header, control blocks, datagrams); repair: the decode after a repair of every lost datagram.")
    L.append("")
    L.append("| model | loss | pattern | paper | reliable cut | cut + parity | exact with parity | parity bytes "
             "| rebuilt / lost | decoded again | exact after repair |")
    L.append("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in par:
        total = m.get("reliable_cut", {}).get("stream_bytes") or 0
        for pattern in ("random", "bursty"):
            for loss in (0.04, 0.12, 0.30):
                qr = parity_runs(m, loss, pattern)
                if not qr:
                    continue
                pr = [r for r in m["runs"] if r["packing"] == "split" and r["pattern"] == pattern and close(r["loss"], loss)]
                cr = cut_runs(m, loss, pattern)
                lost = sum(r["datagrams_lost"] for r in qr)
                back = sum(r.get("parity_recovered", 0) for r in qr)
                exact = sum(1 for r in qr if r["predict"].get("identical"))
                repaired = sum(1 for r in cr + qr if r.get("repaired_identical"))
                pb = med([r["parity_bytes"] for r in qr]) / total if total else 0
                L.append("| %s | %d %% | %s | %s | %s | %s | %d of %d | %s | %d of %d | %s | %d of %d |" % (
                    m["name"], round(100 * loss), pattern, hd_cell(pr), hd_cell(cr), hd_cell(qr), exact, len(qr),
                    pct(pb, 1), back, lost, "%.1f" % med([r.get("redecoded", 0) for r in qr]), repaired,
                    len(cr) + len(qr)))
    L.append("")
    # The harm each refinement's loss does (the encoder's measure) and every datagram's.
    L.append("Single-loss harm (codec/loss/datagram_harm.h): the Hausdorff distance of the final mesh with one "
             "datagram lost, per refinement on UDP the range over its datagrams, and what the encoder records "
             "(one datagram per refinement, finest first, coarser ones bounded below once two in a row exceed "
             "0.25 %). Tiers: 0 nothing, 1 parity, 2 strong parity:")
    L.append("")
    for m in par:
        pr = m.get("protection")
        if not pr:
            continue
        cut = set(m.get("reliable_cut", {}).get("refinements", []))
        cells_ = []
        for i, dh in enumerate(pr.get("datagram_harm", [])):
            if i in cut or not dh:
                continue
            cells_.append("r%d %s-%s (t%d)" % (i, pct(min(dh), 2), pct(max(dh), 2), pr["tiers"][i]))
        under = sum(1 for i, dh in enumerate(pr.get("datagram_harm", [])) if i not in cut for x in dh if x <= TARGET_HARM)
        count = sum(len(dh) for i, dh in enumerate(pr.get("datagram_harm", [])) if i not in cut)
        L.append("- %s: %d of %d unreliable datagrams harm at most 0.1 %%; %s" % (m["name"], under, count,
                                                                             ", ".join(cells_)))
    L.append("")
    L.append("**Targets of protection** (12 % loss, random and in bursts of mean 4, every shared model):")
    L.append("")
    for m in par:
        total = m.get("reliable_cut", {}).get("stream_bytes") or 0
        cap = PARITY_LARGE if m["name"] in ("stanford-bunny", "horse") else PARITY_SMALL
        for pattern in ("random", "bursty"):
            qr = parity_runs(m, 0.12, pattern)
            if not qr:
                continue
            hd = [r["predict"]["hd_rel"] or 0 for r in qr]
            pb = med([r["parity_bytes"] for r in qr]) / total if total else 0
            q30 = parity_runs(m, 0.30, pattern)
            m30 = med([r["predict"]["hd_rel"] or 0 for r in q30]) if q30 else None
            graceful = m30 is not None and m30 <= 2 * med(hd) + 1e-12
            L.append("- %s, %s: median %s (at most 0.1 %%: %s), worst %s (at most 0.25 %%: %s), parity %s of the "
                     "stream's bytes (at most %d %%: %s), at 30 %% median %s (at most 2x the 12 %% median: %s)." % (
                         m["name"], pattern, pct(med(hd), 3), verdict(med(hd) <= TARGET_HARM), pct(max(hd), 3),
                         verdict(max(hd) <= TARGET_WORST), pct(pb, 1), round(100 * cap), verdict(pb <= cap),
                         pct(m30, 3) if m30 is not None else "-", verdict(graceful)))
    L.append("- No parity at a reported loss of 0: `ShapeFor` gives 0 rows at loss 0 "
             "(`ParityPlan.ShapesGrowWithLossAndBursts`), and a session whose reports show no loss sends none "
             "(`SessionSender.ParityFollowsTheReportedLoss`).")
    for m in par:
        row = timing_at_12(m, "predict_parity")
        if row:
            x = row["predict_parity"]["ratio"]
            L.append("- Decoding at 12 %% with the cut and parity, %s: %.2fx the zero-loss decode (%.1f ms) — target "
                     "at most 1.10x: %s." % (m["name"], x, row["predict_parity"]["median_ms"],
                                             verdict(x <= TARGET_TIME)))
    L.append("")
    return L


def plot_final(data, path):
    fig, ax = plt.subplots(figsize=(8, 4.8))
    for m, c in zip(data["models"], MODEL_COLORS):
        cs = [(k, v) for k, v in cells(m) if k[0] == "split" and k[1] == "random"]
        if not cs:
            continue
        plot_recoveries(ax, [100 * k[2] for k, _ in cs], [100 * med([r["predict"]["hd_rel"] for r in v]) for _, v in cs],
                        [100 * med([r["lwop"]["hd_rel"] for r in v]) for _, v in cs], c, m["name"])
    ax.axhline(100 * TARGET_HD, color="red", lw=0.8, ls=":", label="target 0.5 %")
    style_axes(ax, "loss ratio l (%)", "Hausdorff, % of the bbox diagonal",
               "Final level against the zero-loss decode (median; split packing, random loss)", 7, 2)
    save_figure(fig, path, 90)
    return True


# ------------------------------------------------------------------ markdown

def verdict(ok):
    return "**met**" if ok else "**not met**"


def markdown(data, plots, prefix):
    s = data["settings"]
    L = []
    L.append("Generated by `bench/plot_loss.py` from `docs/results/bench/loss.json` (%s run, %.0f s; machine: %s, "
             "%s cores, load at start %s; commit %s). Distances are relative to the bbox diagonal of the "
             "zero-loss decode; `samples_per_side` %s (0: every vertex, edge midpoint and face centroid)."
             % ("quick" if s.get("quick") else "full", data["runtime_s"], data["machine"].get("cpu", "?"),
                data["machine"].get("cores", "?"), data["machine"].get("loadavg_at_start", "?"),
                data["machine"].get("git_commit", "?"), s["samples_per_side"]))
    L.append("")
    if data.get("errors"):
        L.append("**%d decodes or metrics failed** (see the `error` fields of the JSON)." % data["errors"])
        L.append("")

    # ---- where we stand
    all_runs = [(m, r) for m in data["models"] for r in m["runs"]]
    lossy_runs = [(m, r) for m, r in all_runs if lossy(r)]
    n_better = sum(better(r) for _, r in lossy_runs)
    share = n_better / len(lossy_runs) if lossy_runs else None
    ties = sum(1 for _, r in lossy_runs if r["predict"].get("hd_rel") == r["lwop"].get("hd_rel"))
    L.append("### Where we stand")
    L.append("")
    times = {m["name"]: m["timing"] for m in data["models"] if m.get("timing")}
    for name, t in times.items():
        row = [r for r in t["rows"] if close(r["loss"], 0.12)]
        if row:
            x = row[0]["predict"]["ratio"]
            L.append("- Decoding time at 12 %% loss, %s: **%.2fx** the zero-loss decode (%.1f ms against %.1f ms, "
                     "medians of %d) — target at most %.2fx: %s; the paper reports about 1.10x. LwoP: %.2fx."
                     % (name, x, row[0]["predict"]["median_ms"], t["zero_loss_median_ms"], t["repeat"], TARGET_TIME,
                        verdict(x <= TARGET_TIME), row[0]["lwop"]["ratio"]))
    for name in ("stanford-bunny", "horse"):
        m = next((m for m in data["models"] if m["name"] == name), None)
        if not m:
            continue
        at12 = [r for r in m["runs"] if close(r["loss"], 0.12)]
        sr = [r for r in at12 if r["packing"] == "split" and r["pattern"] == "random"]
        hd = [r["predict"]["hd_rel"] for r in at12 if r["predict"].get("hd_rel") is not None]
        hds = [r["predict"]["hd_rel"] for r in sr if r["predict"].get("hd_rel") is not None]
        hv = [r["predict"]["hv_rel"] for r in sr if r["predict"].get("hv_rel") is not None]
        if not hd:
            continue
        L.append("- Hausdorff distance to the zero-loss decode at 12 %% loss, %s, prediction, final level: split "
                 "packing with random loss median %s, worst %s (vertex-to-vertex, Eq. 3: median %s); over all "
                 "%d runs at 12 %% (both packings and patterns) median %s, worst %s — target at most 0.5 %%: "
                 "%s for the median, %s for every run."
                 % (name, pct(med(hds), 3), pct(max(hds), 3), pct(med(hv), 3), len(hd), pct(med(hd), 3),
                    pct(max(hd), 3), verdict(med(hd) <= TARGET_HD), verdict(max(hd) <= TARGET_HD)))
    if share is not None:
        L.append("- Prediction strictly closer than LwoP (point-to-surface Hausdorff of the final level, same seed): "
                 "**%s** of the %d runs with at least one lost datagram (%d ties) — target at least 90 %%: %s; the "
                 "paper reports about 70 %%." % (pct(share, 1), len(lossy_runs), ties, verdict(share >= TARGET_BETTER)))
    if lossy_runs:
        parts = []
        for key, vals in (("packing", ("split", "bundled")), ("pattern", ("random", "bursty"))):
            for v in vals:
                rs = [r for _, r in lossy_runs if r[key] == v]
                if rs:
                    parts.append("%s %s (%d)" % (v, pct(sum(map(better, rs)) / len(rs), 1), len(rs)))
        L.append("- The same share by packing and by loss pattern: %s." % ", ".join(parts))
    for m in data["models"]:
        vals = {}
        for packing in ("split", "bundled"):
            rs = random_runs(m, packing, 0.12)
            vals[packing] = (med([r["predict"]["hd_rel"] for r in rs]), med([r["predict"].get("lap_rel") for r in rs]))
        if m["name"] in ("stanford-bunny", "horse") and None not in vals["split"] + vals["bundled"]:
            L.append("- Packing at 12 %% (random loss, final level, prediction), %s: split Hausdorff %s and Laplacian %s, "
                     "bundled %s and %s — split is %s, %s the paper (Figs 12-13: the split packing is better)."
                     % (m["name"], pct(vals["split"][0], 3), pct(vals["split"][1], 4), pct(vals["bundled"][0], 3),
                        pct(vals["bundled"][1], 4),
                        "better on both" if vals["split"][0] < vals["bundled"][0] and vals["split"][1] < vals["bundled"][1]
                        else "not better on both",
                        "as in" if vals["split"][0] < vals["bundled"][0] and vals["split"][1] < vals["bundled"][1]
                        else "unlike"))
    bunny = next((m for m in data["models"] if m["name"] == "stanford-bunny"), None)
    if bunny:
        sr = random_runs(bunny, "split", 0.12)
        if sr:
            def at(rec, k):
                return median_level_vertices(sr, rec, k)
            n = len(bunny["level_vertices"]) - 1
            L.append("- Vertex counts, bunny at 12 %% (split, random, median of %d seeds): after three refinements "
                     "prediction %d, LwoP %d (ratio %.3f; lossless %d); after all %d refinements prediction %d, LwoP "
                     "%d (ratio %.3f). The paper: %d against %d after three refinements (ratio %.3f)."
                     % (len(sr), at("predict", 3), at("lwop", 3), at("lwop", 3) / at("predict", 3),
                        bunny["level_vertices"][3], n, at("predict", n), at("lwop", n),
                        at("lwop", n) / at("predict", n), PAPER_VERTS[0], PAPER_VERTS[1],
                        PAPER_VERTS[1] / PAPER_VERTS[0]))
            lv = bunny["level_vertices"]
            k = min(range(1, n + 1), key=lambda i: abs(lv[i] - PAPER_VERTS[0]))
            L.append("- Our levels grow less per refinement than the paper's (35-40 %%), so the closer point is the "
                     "level nearest the paper's 13,023 lossless vertices: level %d (%d lossless), prediction %d, "
                     "LwoP %d (ratio %.3f)." % (k, lv[k], at("predict", k), at("lwop", k), at("lwop", k) / at("predict", k)))
    wrong = [(m["name"], r) for m, r in all_runs if not r["predict"].get("error") and r["predict"]["vertices"] != m["vertices"]]
    nolap = sum(1 for _, r in lossy_runs if r["predict"].get("lap_rel") is None)
    L.append("- Prediction keeps the lossless vertex count: %s (%d of %d runs differ); Laplacian undefined in %d "
             "lossy runs." % ("yes" if not wrong else "**no**", len(wrong), len(all_runs), nolap))
    L.append("")

    # ---- plots
    L.append("### Plots")
    L.append("")
    for title, f in plots:
        L.append("**%s**" % title)
        L.append("")
        L.append("![%s](%s%s)" % (title, prefix, f))
        L.append("")

    # ---- decode time table
    if times:
        L.append("### Decoding time (split packing, random loss)")
        L.append("")
        names = list(times)
        L.append("| loss | " + " | ".join("%s prediction | %s LwoP" % (n, n) for n in names) + " |")
        L.append("|---|" + "---:|---:|" * len(names))
        losses = [r["loss"] for r in times[names[0]]["rows"]]
        for loss in losses:
            cellsx = []
            for n in names:
                row = [r for r in times[n]["rows"] if close(r["loss"], loss)]
                if row:
                    cellsx.append("%.1f ms (%.2fx)" % (row[0]["predict"]["median_ms"], row[0]["predict"]["ratio"]))
                    cellsx.append("%.1f ms (%.2fx)" % (row[0]["lwop"]["median_ms"], row[0]["lwop"]["ratio"]))
                else:
                    cellsx += ["-", "-"]
            L.append("| %d %% | %s |" % (round(100 * loss), " | ".join(cellsx)))
        L.append("")

    # ---- share table overall per loss
    L.append("### Prediction against LwoP, by loss ratio (all models, packings, patterns)")
    L.append("")
    L.append("| loss | lossy runs | prediction strictly closer | median Hausdorff prediction | median Hausdorff LwoP |")
    L.append("|---|---:|---:|---:|---:|")
    for loss in sorted({r["loss"] for _, r in lossy_runs}):
        rs = [r for _, r in lossy_runs if close(r["loss"], loss)]
        L.append("| %d %% | %d | %s | %s | %s |" % (round(100 * loss), len(rs), pct(sum(map(better, rs)) / len(rs), 1),
                                                   pct(med([r["predict"]["hd_rel"] for r in rs]), 3),
                                                   pct(med([r["lwop"]["hd_rel"] for r in rs]), 3)))
    L.append("")

    # ---- per model tables
    L.append("### Final level against the zero-loss decode, per model")
    L.append("")
    L.append("Medians over seeds (worst in brackets). hd: point-to-surface Hausdorff; hv: vertex-to-vertex "
             "(Eq. 3); lap: Laplacian distortion (Eq. 4, prediction only); better: share of the lossy runs "
             "where prediction is strictly closer than LwoP (hd).")
    L.append("")
    for m in data["models"]:
        L.append("**%s** (%d vertices, %d levels, %s matrix, %d seeds; datagrams: split %d, bundled %d)"
                 % (m["name"], m["vertices"], len(m["level_vertices"]) - 1, m["matrix"], m["seeds"],
                    m["datagrams"]["split"], m["datagrams"]["bundled"]))
        L.append("")
        L.append("| packing | pattern | loss | lossy runs | lost datagrams | predict hd | predict hv | predict lap "
                 "| LwoP hd | LwoP vertices | better |")
        L.append("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for (packing, pattern, loss), rs in cells(m):
            ls = [r for r in rs if lossy(r)]
            hd = [r["predict"]["hd_rel"] for r in rs]
            L.append("| %s | %s | %d %% | %d/%d | %.1f | %s (%s) | %s | %s | %s | %d | %s |" % (
                packing, pattern, round(100 * loss), len(ls), len(rs), statistics.mean(r["datagrams_lost"] for r in rs),
                pct(med(hd), 3), pct(max(x for x in hd if x is not None), 3),
                pct(med([r["predict"]["hv_rel"] for r in rs]), 3), pct(med([r["predict"].get("lap_rel") for r in rs]), 4),
                pct(med([r["lwop"]["hd_rel"] for r in rs]), 3), med([r["lwop"]["vertices"] for r in rs]),
                pct(sum(map(better, ls)) / len(ls), 0) if ls else "-"))
        L.append("")

    # ---- packing table at 12 %
    L.append("### Packing at 12 % (random loss, final level, prediction)")
    L.append("")
    L.append("| model | split hd | bundled hd | split lap | bundled lap | split: predicted splits | "
             "bundled: predicted splits |")
    L.append("|---|---:|---:|---:|---:|---:|---:|")
    for m in data["models"]:
        row = []
        for key in ("hd_rel", "lap_rel"):
            for packing in ("split", "bundled"):
                rs = random_runs(m, packing, 0.12)
                row.append(pct(med([r["predict"].get(key) for r in rs]), 3 if key == "hd_rel" else 4))
        for packing in ("split", "bundled"):
            rs = random_runs(m, packing, 0.12)
            st = [r["predict"]["stats"] for r in rs]
            row.append("%d (both lost %d)" % (med([s["predicted_both"] + s["predicted_structure"] + s["predicted_geometry"]
                                                   for s in st]) or 0, med([s["predicted_both"] for s in st]) or 0))
        L.append("| %s | %s |" % (m["name"], " | ".join(row)))
    L.append("")
    L += cut_markdown(data)
    return "\n".join(L)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("json", nargs="?", default="docs/results/bench/loss.json")
    ap.add_argument("--out", default=None)
    ap.add_argument("--doc", default=None)
    a = ap.parse_args()
    data = load(a.json)
    # The paper's scheme is what every older section reads; the reliable cut's
    # runs (issue 12) have their own section.
    for m in data["models"]:
        m["cut_runs"] = [r for r in m["runs"] if r.get("delivery") == "cut"]
        m["parity_runs"] = [r for r in m["runs"] if r.get("delivery") == "cut_parity"]
        m["runs"] = [r for r in m["runs"] if r.get("delivery", "paper") == "paper"]
    out = output_dir(a.out, a.json)
    plots = []
    if plot_final(data, os.path.join(out, "loss-final.png")):
        plots.append(("Final-level Hausdorff distance against loss", "loss-final.png"))
    for m in data["models"]:
        f = "loss-levels-%s.png" % m["name"]
        if plot_levels(m, os.path.join(out, f)):
            plots.append(("%s: distortion per level (paper Figs 6-9)" % m["name"], f))
    if plot_cut(data, os.path.join(out, "loss-cut.png")):
        plots.append(("The paper's scheme against the reliable cut", "loss-cut.png"))
    if plot_time(data, os.path.join(out, "loss-time.png")):
        plots.append(("Decoding time relative to zero loss (paper Fig 11)", "loss-time.png"))
    if plot_packing(data, os.path.join(out, "loss-packing.png")):
        plots.append(("Split against bundled packing at 12 % (paper Figs 12-13)", "loss-packing.png"))
    if plot_lwop(data, os.path.join(out, "loss-lwop.png")):
        plots.append(("Prediction against LwoP at 12 % (paper Fig 14, vertex counts of 5.3)", "loss-lwop.png"))
    write_text(os.path.join(out, "loss-results.md"), "# Loss experiment results\n\n" + markdown(data, plots, "") + "\n")
    if a.doc and os.path.exists(a.doc):
        if update_doc(a.doc, BEGIN, END, out, lambda prefix: markdown(data, plots, prefix)):
            print("plot_loss.py: updated %s" % a.doc)
        else:
            print("plot_loss.py: no markers in %s, left alone" % a.doc, file=sys.stderr)
    print("plot_loss.py: wrote %d plots and loss-results.md into %s" % (len(plots), out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
