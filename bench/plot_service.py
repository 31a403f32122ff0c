#!/usr/bin/env python3
"""Plots and tables from the service benchmark's JSON (bench/service/main.cc and its parts, bench/README.md).

usage: bench/plot_service.py [SERVICE.json] [--out DIR] [--doc docs/results/service-benchmarks.md]

Writes into DIR (default: the JSON's folder):
  service-latency.png  GetVersion, ListVersions and health p50/p99 against the
                       number of concurrent clients, per backend, beside the
                       echo floor; calls per second below
  service-ingest.png   per model and backend: Ingest MB/s (plain, resumable)
                       beside the transport and disk floors; upload + time to
                       READY beside the in-process encode
  service-export.png   export MB/s per model and backend: the stored
                       progressive .glb, .glb first call, .glb from the cache
and replaces the text between "<!-- bench:service:begin -->" and
"<!-- bench:service:end -->" in the --doc file with the tables (when the
markers are there). Works headless (Agg backend).
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_common import load, output_dir, plt, save_figure, style_axes, update_doc  # noqa: E402

BEGIN = "<!-- bench:service:begin -->"
END = "<!-- bench:service:end -->"
COLORS = {"sqlite": "C0", "postgresql": "C1"}
RPC_STYLE = {"GetVersion": ("o", "-"), "ListVersions": ("s", "-"), "health": ("^", ":")}


def short(name):
    return name.replace("stanford-", "").replace("2CylinderEngine", "2CylEngine")


def backends(data):
    return [b["name"] for b in data["backends"]]


def backend(data, name):
    return next(b for b in data["backends"] if b["name"] == name)


def latency(data, be, rpc, clients):
    for e in data["latency"]:
        if e["backend"] == be and e["rpc"] == rpc and e["clients"] == clients:
            return e
    return None


def models(data):
    """The models' asset names in the order of the run (the JSON's objects are sorted by name)."""
    first = data["backends"][0]["ingest"]
    names = [os.path.splitext(os.path.basename(f))[0] for f in data["settings"]["models"]]
    return [n for n in names if n in first]


def fmt_us(v):
    if v is None:
        return "-"
    if v < 1000:
        return "%.0f us" % v
    if v < 100000:
        return "%.2f ms" % (v / 1000.0)
    return "%.0f ms" % (v / 1000.0)


def fmt_ms(v):
    if v is None:
        return "-"
    if v < 10:
        return "%.2f" % v
    if v < 100:
        return "%.1f" % v
    return "%.0f" % v


def fmt_int(v):
    return "{:,}".format(int(v))


# ------------------------------------------------------------------ plots

def plot_latency(data, path):
    names = backends(data)
    clients = data["settings"]["clients"]
    fig, axes = plt.subplots(2, len(names), figsize=(6.5 * len(names), 8.5), squeeze=False)
    for col, be in enumerate(names):
        ax, bx = axes[0][col], axes[1][col]
        for rpc, (marker, line) in RPC_STYLE.items():
            pts = [(c, latency(data, be, rpc, c)) for c in clients]
            pts = [(c, e) for c, e in pts if e and "p50_us" in e]
            if not pts:
                continue
            xs = [c for c, _ in pts]
            color = {"GetVersion": COLORS[be], "ListVersions": "C2", "health": "C4"}[rpc]
            ax.plot(xs, [e["p50_us"] for _, e in pts], marker=marker, linestyle=line, color=color,
                    label="%s p50" % rpc)
            ax.plot(xs, [e["p99_us"] for _, e in pts], marker=marker, linestyle="--", color=color, alpha=0.55,
                    label="%s p99" % rpc)
            bx.plot(xs, [e["throughput_cps"] for _, e in pts], marker=marker, linestyle=line, color=color,
                    label=rpc)
        pts = [(c, latency(data, "echo", "echo", c)) for c in clients]
        pts = [(c, e) for c, e in pts if e and "p50_us" in e]
        if pts:
            xs = [c for c, _ in pts]
            ax.plot(xs, [e["p50_us"] for _, e in pts], "k-x", label="echo floor p50")
            ax.plot(xs, [e["p99_us"] for _, e in pts], "k--x", alpha=0.55, label="echo floor p99")
            bx.plot(xs, [e["throughput_cps"] for _, e in pts], "k-x", label="echo floor")
        for a in (ax, bx):
            a.set_xscale("log")
            a.set_yscale("log")
            a.set_xticks(clients)
            a.set_xticklabels([str(c) for c in clients])
        style_axes(ax, xlabel="concurrent clients", ylabel="latency per call, us (log)",
                   title="%s: latency" % be, legend_size=7, legend_cols=2, which="both")
        style_axes(bx, xlabel="concurrent clients", ylabel="calls per second, all clients (log)",
                   title="%s: throughput" % be, legend_size=7, which="both")
    fig.suptitle("Unary calls on 127.0.0.1, clients and server sharing %d cores" % data["machine"]["nproc"])
    save_figure(fig, path, 100, rect=(0, 0, 1, 0.97))


def plot_ingest(data, path):
    names = backends(data)
    ms = models(data)
    refs = data["references"]["models"]
    n = len(ms)
    x = list(range(n))
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(15, 5.5))
    w = 0.8 / (2 * len(names))
    for i, be in enumerate(names):
        ing = backend(data, be)["ingest"]
        plain = [ing[m]["summary"]["upload_MBps"] for m in ms]
        res = [ing[m]["summary"]["resumable_upload_MBps"] for m in ms]
        off = -0.4 + w * (2 * i) + w / 2
        a1.bar([j + off for j in x], plain, w, color=COLORS[be], label="%s Ingest" % be)
        a1.bar([j + off + w for j in x], res, w, color=COLORS[be], alpha=0.45, hatch="//",
               label="%s Ingest, resumable (upload_id)" % be)
    a1.plot(x, [refs[m]["transport_sink"]["MBps"] for m in ms], "k_", ms=22, mew=2,
            label="floor: same messages into the echo sink")
    a1.plot(x, [refs[m]["disk_write_fsync"]["MBps"] for m in ms], "r_", ms=22, mew=2,
            label="floor: write + fsync + rename the file")
    a1.set_yscale("log")
    a1.set_xticks(x)
    a1.set_xticklabels([short(m) for m in ms], fontsize=8)
    style_axes(a1, ylabel="MB/s (10^6 B/s, log)", title="Ingest throughput (upload until IngestResponse)",
               legend_size=7, axis="y", which="both")

    w = 0.8 / len(names)
    for i, be in enumerate(names):
        ing = backend(data, be)["ingest"]
        up = [ing[m]["summary"]["upload_ms"] for m in ms]
        ready = [ing[m]["summary"]["ready_server_ms"] for m in ms]
        watch = [ing[m]["summary"]["ready_watch_ms"] for m in ms]
        off = -0.4 + w * i + w / 2
        xs = [j + off for j in x]
        a2.bar(xs, up, w, color=COLORS[be], alpha=0.45, label="%s upload" % be)
        a2.bar(xs, ready, w, bottom=up, color=COLORS[be], label="%s + time to READY (store's stamps)" % be)
        a2.plot(xs, [u + r for u, r in zip(up, watch)], "v", color=COLORS[be], ms=6,
                label="%s upload + READY as WatchJob shows it" % be)
    a2.plot(x, [refs[m]["encode_inprocess"]["median_ms"] for m in ms], "k_", ms=26, mew=2,
            label="import + encode in-process (ProcessSource)")
    a2.set_xticks(x)
    a2.set_xticklabels([short(m) for m in ms], fontsize=8)
    style_axes(a2, ylabel="ms (median)", title="From the first byte sent to READY", legend_size=7, axis="y")
    save_figure(fig, path, 100)


def plot_export(data, path):
    names = backends(data)
    ms = models(data)
    x = list(range(len(ms)))
    kinds = [("progressive_glb", "FORMAT_PROGRESSIVE_GLB (blob read)", 1.0, ""),
             ("glb_first", "FORMAT_GLB, first call (decode + export + store)", 0.35, ".."),
             ("glb_cached", "FORMAT_GLB, second call (export cache)", 0.65, "//")]
    w = 0.8 / (len(names) * len(kinds))
    fig, ax = plt.subplots(figsize=(13, 5))
    k = 0
    for be in names:
        ex = backend(data, be)["export"]
        for key, label, alpha, hatch in kinds:
            off = -0.4 + w * k + w / 2
            ax.bar([j + off for j in x], [ex[m][key]["MBps"] for m in ms], w, color=COLORS[be], alpha=alpha,
                   hatch=hatch, label="%s %s" % (be, label))
            k += 1
    ax.set_yscale("log")
    ax.set_xticks(x)
    ax.set_xticklabels([short(m) for m in ms], fontsize=8)
    style_axes(ax, ylabel="MB/s of exported bytes (log)", title="Export throughput (call until the last chunk)",
               legend_size=7, legend_cols=2, axis="y", which="both")
    save_figure(fig, path, 100)


# ----------------------------------------------------------------- tables

def headline(data):
    out = []
    names = backends(data)
    clients = data["settings"]["clients"]
    out.append("| | " + " | ".join(names) + " |")
    out.append("|---|" + "---:|" * len(names))
    for m in ("stanford-bunny", "horse"):
        if m not in models(data):
            continue
        row = ["Ingest %s, MB/s (plain / resumable)" % short(m)]
        for be in names:
            s = backend(data, be)["ingest"][m]["summary"]
            row.append("%.1f / %.1f" % (s["upload_MBps"], s["resumable_upload_MBps"]))
        out.append("| " + " | ".join(row) + " |")
        row = ["time to READY %s, ms (store / WatchJob)" % short(m)]
        for be in names:
            s = backend(data, be)["ingest"][m]["summary"]
            row.append("%s / %s" % (fmt_ms(s["ready_server_ms"]), fmt_ms(s["ready_watch_ms"])))
        out.append("| " + " | ".join(row) + " |")
    for c in clients:
        e = latency(data, "echo", "echo", c)
        row = ["GetVersion p50 / p99, %d client%s (echo %s / %s)" % (
            c, "s" if c > 1 else "", fmt_us(e.get("p50_us")) if e else "-", fmt_us(e.get("p99_us")) if e else "-")]
        for be in names:
            g = latency(data, be, "GetVersion", c)
            row.append("%s / %s (x%.1f)" % (fmt_us(g.get("p50_us")), fmt_us(g.get("p99_us")),
                                           g["p50_us"] / e["p50_us"]) if g and e and "p50_us" in g else "-")
        out.append("| " + " | ".join(row) + " |")
    for m in ("stanford-bunny", "horse"):
        if m not in models(data):
            continue
        row = ["Export %s, MB/s (progressive / .glb first / .glb cached)" % short(m)]
        for be in names:
            ex = backend(data, be)["export"][m]
            row.append("%.0f / %.1f / %.0f" % (ex["progressive_glb"]["MBps"], ex["glb_first"]["MBps"],
                                               ex["glb_cached"]["MBps"]))
        out.append("| " + " | ".join(row) + " |")
    return out


def markdown(data, prefix):
    mach = data["machine"]
    st = data["settings"]
    names = backends(data)
    out = []
    pg = next((b["info"].get("postgresql") for b in data["backends"] if b["name"] == "postgresql"), None)
    out.append("Measured %s on %d x %s (%s), %s build, gRPC %s, SQLite %s, libpqxx %s%s; stores on %s (%s). "
               "Load average at start %s, at end %s; the run took %.0f s%s." % (
                   mach["date"], mach["nproc"], mach["cpu"], mach.get("kernel", ""), mach.get("build_type", ""),
                   mach["grpc"], mach["sqlite"], mach["libpqxx"],
                   (", PostgreSQL %s (fsync=%s, synchronous_commit=%s, wal_sync_method=%s)" % (
                       pg["version"].split(" on ")[0].replace("PostgreSQL ", ""), pg["fsync"],
                       pg["synchronous_commit"], pg["wal_sync_method"])) if pg else "",
                   mach["work_dir"], " ".join(mach.get("work_dir_filesystem", "").split()),
                   mach["loadavg_at_start"], mach.get("loadavg_at_end", "?"), mach.get("run_seconds", 0),
                   " (`--quick`)" if st.get("quick") else ""))
    if mach.get("git_commit"):
        out.append("Source: commit %s." % mach["git_commit"])
    f = data["failures"]
    out.append("Failed ingests or exports: %d; failed latency calls: %d (a failed call is counted, never timed)."
               % (f["ingest_and_export"], f["latency_calls"]))
    for b in data["backends"]:
        for fl in b["failures"]:
            out.append("- %s: %s: %s" % (b["name"], fl["what"], fl["error"]))
    out.append("")
    out.append("### Headline")
    out.append("")
    out.extend(headline(data))
    out.append("")
    out.append("Ratios in parentheses: GetVersion p50 / echo p50 at the same client count.")
    out.append("")

    refs = data["references"]["models"]
    out.append("### Ingest (median of %d plain and %d resumable fresh uploads per model and backend)"
               % (st["repeat"], st["resumable_repeat"]))
    out.append("")
    out.append("| model | bytes | backend | upload ms | **MB/s** | resumable ms | resumable MB/s | echo sink MB/s "
               "| write+fsync MB/s | SHA-256 MB/s | upload / sink |")
    out.append("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        r = refs[m]
        for be in names:
            s = backend(data, be)["ingest"][m]["summary"]
            sha = r.get("sha256", {}).get("MBps")
            out.append("| %s | %s | %s | %s | **%.1f** | %s | %.1f | %.0f | %.0f | %s | %.1f |" % (
                short(m), fmt_int(r["bytes"]), be, fmt_ms(s["upload_ms"]), s["upload_MBps"],
                fmt_ms(s["resumable_upload_ms"]), s["resumable_upload_MBps"], r["transport_sink"]["MBps"],
                r["disk_write_fsync"]["MBps"], "%.0f" % sha if sha else "-",
                s["upload_ms"] / r["transport_sink"]["median_ms"]))
    out.append("")
    out.append("`echo sink`: the same Ingest messages (1 MiB chunks) streamed to the trivial server, which "
               "counts and drops them: gRPC over loopback, nothing stored. `write+fsync`: the file written "
               "into a new file on the stores' file system, fsync'd, renamed, folder fsync'd: the least a "
               "durable blob costs. `SHA-256`: the file hashed once in this process (libsodium; the server hashes every "
               "upload twice: the ingest's digest check and the blob's own name). fsync of 4 KiB on that disk: p50 %s, p99 %s."
               % (fmt_us(data["references"]["fsync_4k"]["p50_us"]), fmt_us(data["references"]["fsync_4k"]["p99_us"])))
    out.append("")
    pg_rows = [(m, refs[m]["pg_bytea_insert"]) for m in models(data) if "pg_bytea_insert" in refs[m]]
    if pg_rows:
        out.append("PostgreSQL's share, measured in the same cluster: the file inserted as one `bytea` value into "
                   "a table like `blob_chunks` (storage EXTENDED, so TOAST compresses it with `pglz`) and into one "
                   "with storage EXTERNAL (no compression), timed inside the backend (the commit's WAL flush not "
                   "included); medians.")
        out.append("")
        out.append("| model | bytes | compressed insert ms | uncompressed insert ms | stored after compression "
                   "| PostgreSQL Ingest ms |")
        out.append("|---|---:|---:|---:|---:|---:|")
        for m, r in pg_rows:
            s_pg = backend(data, "postgresql")["ingest"][m]["summary"] if "postgresql" in names else None
            out.append("| %s | %s | %s | %s | %s | %s |" % (
                short(m), fmt_int(refs[m]["bytes"]), fmt_ms(r["compressed"]["median_ms"]),
                fmt_ms(r["uncompressed"]["median_ms"]),
                "%.0f %%" % (100 * r["compressed_stored_fraction"]) if "compressed_stored_fraction" in r else "-",
                fmt_ms(s_pg["upload_ms"]) if s_pg else "-"))
        out.append("")
        out.append("(100 %: pglz gave up, the value is stored as it was; the compression was tried all the same.)")
        out.append("")
    out.append("### Time to READY (median of the fresh uploads; cache hit: median of %d)" % st["cache_repeat"])
    out.append("")
    out.append("| model | vertices | backend | upload ms | READY ms (store) | READY ms (WatchJob) | encode in-process ms "
               "| encode / (upload + READY) | cache hit READY ms (store / WatchJob) |")
    out.append("|---|---:|---|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        r = refs[m]
        enc = r["encode_inprocess"]["median_ms"]
        for be in names:
            s = backend(data, be)["ingest"][m]["summary"]
            total = s["upload_ms"] + s["ready_server_ms"]
            out.append("| %s | %s | %s | %s | **%s** | %s | %s | %.0f %% | %s / %s |" % (
                short(m), fmt_int(r["figures"]["vertices"]), be, fmt_ms(s["upload_ms"]),
                fmt_ms(s["ready_server_ms"]), fmt_ms(s["ready_watch_ms"]), fmt_ms(enc),
                100.0 * enc / total if total else 0, fmt_ms(s["cache_ready_server_ms"]),
                fmt_ms(s["cache_ready_watch_ms"])))
    out.append("")
    out.append("`READY (store)`: the job's `updated - created` stamps (the store's clock, whole ms): from the "
               "version's creation inside Ingest to the job's completion. `READY (WatchJob)`: from the "
               "IngestResponse until WatchJob delivers `JOB_STATE_SUCCEEDED`; WatchJob looks at the store every "
               "100 ms, so a client sees READY up to 100 ms after it happened. `encode in-process`: "
               "`ProcessSource` (import + encode + figures, what the job runs) called directly in the "
               "benchmark's process on the original file.")
    out.append("")
    out.append("![ingest and READY](%sservice-ingest.png)" % prefix)
    out.append("")

    clients = st["clients"]
    out.append("### Latency (every call timed; p50 / p99, and calls per second of all clients)")
    out.append("")
    out.append("| backend | RPC | " + " | ".join("%d client%s p50 / p99 | calls/s | p50 / echo" % (
        c, "s" if c > 1 else "") for c in clients) + " |")
    out.append("|---|---|" + "---:|---:|---:|" * len(clients))
    rows = [("echo", "echo")] + [(be, rpc) for be in names for rpc in ("health", "GetVersion", "ListVersions")]
    for be, rpc in rows:
        cells = []
        for c in clients:
            e = latency(data, be, rpc, c)
            floor = latency(data, "echo", "echo", c)
            if not e or "p50_us" not in e:
                cells.append("- | - | -")
                continue
            ratio = e["p50_us"] / floor["p50_us"] if floor and "p50_us" in floor else float("nan")
            fail = " (%d failed)" % e["failed"] if e["failed"] else ""
            cells.append("%s / %s%s | %s | %s" % (fmt_us(e["p50_us"]), fmt_us(e["p99_us"]), fail,
                                                 fmt_int(e["throughput_cps"]),
                                                 "1" if rpc == "echo" else "%.1f" % ratio))
        name = "echo server" if be == "echo" else be
        out.append("| %s | %s | %s |" % (name, rpc, " | ".join(cells)))
    out.append("")
    out.append("CPU while the timed calls ran: the machine's busy share of its %d cores (every process: "
               "PostgreSQL's backends and other users' work too) / this process's CPU per call (clients, both "
               "meshstream servers, the echo server)." % mach["nproc"])
    out.append("")
    out.append("| backend | RPC | " + " | ".join("%d client%s" % (c, "s" if c > 1 else "") for c in clients) + " |")
    out.append("|---|---|" + "---:|" * len(clients))
    for be, rpc in rows:
        cells = []
        for c in clients:
            e = latency(data, be, rpc, c)
            cpu = e.get("cpu") if e else None
            cells.append("%.0f %% / %.0f us" % (100 * cpu["machine_busy"], cpu["process_us_per_call"]) if cpu else "-")
        out.append("| %s | %s | %s |" % ("echo server" if be == "echo" else be, rpc, " | ".join(cells)))
    out.append("")
    e1 = latency(data, "echo", "echo", clients[0])
    out.append("Calls per client: %s (in %d interleaved round%s of every row). GetVersion cycles through "
               "versions 1..%d of one asset; ListVersions alternates its two pages of 50 (of %d versions)."
               % (", ".join("%d at %d" % (latency(data, "echo", "echo", c)["calls_per_client"], c)
                            for c in clients if latency(data, "echo", "echo", c)), st["rounds"],
                  "s" if st["rounds"] > 1 else "", st["latency_versions"], st["latency_versions"]))
    if e1:
        out.append("")
    out.append("![latency](%sservice-latency.png)" % prefix)
    out.append("")

    out.append("### Export (median over the fresh versions; MB/s of the exported bytes)")
    out.append("")
    out.append("| model | backend | progressive .glb bytes | ms | **MB/s** | .glb bytes | first call ms | MB/s | "
               "cached ms | MB/s | first / cached |")
    out.append("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        for be in names:
            ex = backend(data, be)["export"][m]
            p, g1, g2 = ex["progressive_glb"], ex["glb_first"], ex["glb_cached"]
            out.append("| %s | %s | %s | %s | **%.0f** | %s | %s | %.1f | %s | %.0f | %.1f |" % (
                short(m), be, fmt_int(p["bytes"]), fmt_ms(p["median_ms"]), p["MBps"], fmt_int(g1["bytes"]),
                fmt_ms(g1["median_ms"]), g1["MBps"], fmt_ms(g2["median_ms"]), g2["MBps"],
                g1["median_ms"] / g2["median_ms"] if g2["median_ms"] else 0))
    out.append("")
    out.append("![export](%sservice-export.png)" % prefix)
    out.append("")
    for b in data["backends"]:
        bc = b["info"].get("blob_chunks")
        if bc:
            raw, stored = int(bc["raw_bytes"] or 0), int(bc["stored_bytes"] or 0)
            if raw:
                out.append("PostgreSQL `blob_chunks.data` (storage `%s`, TOAST compression %s): %s bytes stored "
                           "for %s bytes of blobs (%.0f %%)." % (
                               bc["column_storage"], b["info"]["postgresql"].get("default_toast_compression", "?"),
                               fmt_int(stored), fmt_int(raw), 100.0 * stored / raw))
                out.append("")
    return "\n".join(out)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?", default=os.path.join(root, "docs", "bench", "service.json"))
    ap.add_argument("--out", default=None, help="folder for the PNGs (default: the JSON's folder)")
    ap.add_argument("--doc", default=os.path.join(root, "docs", "service-benchmarks.md"),
                    help="Markdown file whose marked section receives the tables ('' to skip)")
    a = ap.parse_args()
    data = load(a.results)
    out = output_dir(a.out, a.results)
    plot_latency(data, os.path.join(out, "service-latency.png"))
    plot_ingest(data, os.path.join(out, "service-ingest.png"))
    plot_export(data, os.path.join(out, "service-export.png"))
    if a.doc and os.path.exists(a.doc):
        if update_doc(a.doc, BEGIN, END, out, lambda prefix: markdown(data, prefix)):
            print("plot_service.py: updated %s" % a.doc)
        else:
            print("plot_service.py: %s has no %s ... %s markers; left alone" % (a.doc, BEGIN, END))
    print("plot_service.py: wrote 3 plots into %s" % out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
