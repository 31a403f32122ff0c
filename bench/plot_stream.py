#!/usr/bin/env python3
"""Plots and tables from the streaming benchmark's JSON (bench/stream/main.cc and its parts, bench/README.md).

usage: bench/plot_stream.py [STREAM.json] [--out DIR] [--doc docs/results/stream-benchmarks.md]

Writes into DIR (default: the JSON's folder):
  stream-time.png       per model: time to the full mesh (above) and to the
                        base mesh (below), p50 and p99, against the number of
                        concurrent sessions, over UDP and over gRPC (tcp_only),
                        beside the Draco GLB export of the same server (time to
                        the last byte)
  stream-datagrams.png  the server's DATA datagrams per second (wall, per
                        CPU-second of the process, and without the sessions'
                        decoding threads) beside the sendmmsg loopback limit
  stream-shaped-quality.png  the shaped link ("shaped" in the JSON): per model,
                        at the first and the last loss level, the Hausdorff
                        distance of what is shown to the full lossless mesh
                        against time, every run, over UDP, TCP only and the
                        Draco GLB
  stream-shaped-times.png  the shaped link: time to the first visible mesh and
                        to full quality against loss (median, min-max)
and replaces the text between "<!-- bench:stream:begin -->" and
"<!-- bench:stream:end -->" in the --doc file with the tables, and the text
between "<!-- bench:stream-shaped:begin -->" and
"<!-- bench:stream-shaped:end -->" with the shaped link's (when the markers
are there; a JSON of --only-shaped refreshes only the latter). Works
headless (Agg backend).
"""
import argparse
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from plot_common import load, output_dir, plt, save_figure, style_axes, update_doc  # noqa: E402

BEGIN = "<!-- bench:stream:begin -->"
END = "<!-- bench:stream:end -->"
KINDS = [("udp", "UDP", "C0", "o"), ("tcp_only", "TCP only (gRPC stream)", "C1", "s"),
         ("draco_export", "Draco GLB export (last byte)", "k", "x")]


def short(name):
    return name.replace("stanford-", "")


def models(data):
    return [m["name"] for m in data["settings"]["models"]]


def model_info(data, name):
    return next(m for m in data["settings"]["models"] if m["name"] == name)


def row(data, model, transport, concurrency):
    for r in data["sessions"]:
        if r["model"] == model and r["transport"] == transport and r["concurrency"] == concurrency:
            return r
    return None


def times(r, what):
    """The summary of `what` ("full" or "base") of a row; the export's time to the last byte for both."""
    if r is None:
        return None
    if r["transport"] == "draco_export":
        s = r.get("time_to_last_byte_ms")
    else:
        s = r.get("time_to_full_ms" if what == "full" else "time_to_base_ms")
    return s if s and "p50_ms" in s else None


def fmt_ms(v):
    if v is None:
        return "-"
    if v < 10:
        return "%.2f" % v
    if v < 100:
        return "%.1f" % v
    return "%.0f" % v


def fmt_int(v):
    return "{:,}".format(int(round(v)))


def fmt_ratio(v):
    if v is None:
        return "-"
    if v < 10:
        return "%.2f" % v
    return "%.0f" % v


def fmt_rate(v):
    if v >= 1e6:
        return "%.2f M" % (v / 1e6)
    if v >= 1e3:
        return "%.1f k" % (v / 1e3)
    return "%.0f" % v


# ------------------------------------------------------------------ plots

def plot_times(data, path):
    ms = models(data)
    conc = data["settings"]["concurrency"]
    fig, axes = plt.subplots(2, len(ms), figsize=(6.5 * len(ms), 9), squeeze=False)
    for col, m in enumerate(ms):
        for line, what in enumerate(("full", "base")):
            ax = axes[line][col]
            for kind, label, color, marker in KINDS:
                pts = [(c, times(row(data, m, kind, c), what)) for c in conc]
                pts = [(c, s) for c, s in pts if s]
                if not pts:
                    continue
                xs = [c for c, _ in pts]
                ax.plot(xs, [s["p50_ms"] for _, s in pts], marker=marker, color=color, linestyle="-",
                        label="%s p50" % label)
                ax.plot(xs, [s["p99_ms"] for _, s in pts], marker=marker, color=color, linestyle="--", alpha=0.55,
                        label="%s p99" % label)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xticks(conc)
            ax.set_xticklabels([str(c) for c in conc])
            title = "%s: time to the %s mesh" % (short(m), "full" if what == "full" else "base")
            style_axes(ax, xlabel="concurrent sessions (threads of one process)",
                       ylabel="ms from Open (log)", title=title, legend_size=7, which="both")
    fig.suptitle("Sessions on 127.0.0.1, server and clients in one process on %d cores; the Draco reference "
                 "does not decode" % data["machine"]["nproc"])
    save_figure(fig, path, 100, rect=(0, 0, 1, 0.97))


def plot_datagrams(data, path):
    dr = data["datagram_rate"]
    m = dr["meshstream"]
    lb = dr["loopback_sendmmsg"]
    groups = ["per second of wall time",
              "per CPU-second of the sender\n(server process / the loop's sending thread)",
              "per CPU-second of both ends\n(server + client processes / the loop's process)"]
    bars = [
        ("meshstream: DATA the server sent, %d UDP sessions at a time (%s)" % (m["concurrent_sessions"],
                                                                              short(m["model"])), "C0",
         [m["datagrams_per_s_wall"], m["datagrams_per_server_cpu_s"], m["datagrams_per_cpu_s_both"]]),
        ("sendmmsg loop on 127.0.0.1: 1200 B x 64 per call, recvmmsg receiver (mean of 2 runs)", "0.35",
         [lb["datagrams_per_s_wall"], lb["sent_per_sender_cpu_s"], lb["datagrams_per_cpu_s"]]),
    ]
    fig, ax = plt.subplots(figsize=(12, 5.5))
    w = 0.8 / len(bars)
    top = 0
    for i, (label, color, vals) in enumerate(bars):
        xs = [j - 0.4 + w * i + w / 2 for j in range(len(groups))]
        ax.bar(xs, vals, w, color=color, label=label)
        for x, v in zip(xs, vals):
            ax.text(x, v * 1.1, fmt_rate(v), ha="center", fontsize=8)
        top = max(top, max(vals))
    ax.set_yscale("log")
    ax.set_ylim(top=top * 12)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels(groups, fontsize=8)
    style_axes(ax, ylabel="datagrams (log)", title="Datagrams per second: the server beside the loopback's limit",
               legend_size=8, axis="y", which="both")
    save_figure(fig, path, 100)


# ----------------------------------------------------------------- tables

def ratio(r, key):
    v = r.get("vs_draco_export") if r else None
    return v.get(key) if v else None


def headline(data):
    out = []
    conc = data["settings"]["concurrency"]
    out.append("| model | sessions | UDP full p50 / p99 ms | TCP-only full p50 / p99 ms | Draco export p50 / p99 ms "
               "| UDP full / Draco (p50, p99) | UDP base / Draco (p50, p99) | datagrams lost per UDP session "
               "(mean, max) |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        for c in conc:
            u, t, d = row(data, m, "udp", c), row(data, m, "tcp_only", c), row(data, m, "draco_export", c)
            fu, ft, fd = times(u, "full"), times(t, "full"), times(d, "full")
            if not (fu or ft or fd):
                continue

            def pp(s):
                return "%s / %s" % (fmt_ms(s["p50_ms"]), fmt_ms(s["p99_ms"])) if s else "-"

            lost = u["datagrams"] if u else None
            out.append("| %s | %d | %s | %s | %s | %s, %s | %s, %s | %s |" % (
                short(m), c, pp(fu), pp(ft), pp(fd), fmt_ratio(ratio(u, "full_p50")), fmt_ratio(ratio(u, "full_p99")),
                fmt_ratio(ratio(u, "base_p50")), fmt_ratio(ratio(u, "base_p99")),
                "%.2f, %d" % (lost["lost_per_session_mean"], lost["lost_per_session_max"]) if lost else "-"))
    return out


def cpu_per_session(cpu):
    # Server and clients in two processes (server_ms_per_session); older runs: one process.
    if "server_ms_per_session" in cpu:
        return "%.1f + %.1f" % (cpu["server_ms_per_session"], cpu["clients_ms_per_session"])
    return "%.1f" % cpu["process_ms_per_session"]


def session_table(data):
    out = []
    conc = data["settings"]["concurrency"]
    out.append("| model | sessions | transport | n | failed | base p50 / p99 ms | server's open to base p50 / p99 ms "
               "| full p50 / p99 ms | base / Draco p50, p99 | full / Draco p50, p99 | Open to kComplete p50 / p99 ms "
               "| CPU ms per session: server + clients |")
    out.append("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        for c in conc:
            for kind, label, _, _ in KINDS:
                r = row(data, m, kind, c)
                if r is None:
                    continue
                fb, ff = times(r, "base"), times(r, "full")
                cpu = cpu_per_session(r["cpu"])
                if kind == "draco_export":
                    out.append("| %s | %d | Draco export | %d | %d | - | - | %s / %s (last byte) | - | - | - | %s |" % (
                        short(m), c, r["completed"], r["failures"], fmt_ms(ff["p50_ms"]) if ff else "-",
                        fmt_ms(ff["p99_ms"]) if ff else "-", cpu))
                    continue
                oc = r.get("open_to_complete_ms", {})
                sb = r.get("server_time_to_base_ms", {})
                out.append("| %s | %d | %s | %d | %d | %s / %s | %s / %s | **%s** / %s | %s, %s | %s, %s | %s / %s | %s |" % (
                    short(m), c, "UDP" if kind == "udp" else "TCP only", r["completed"], r["failures"],
                    fmt_ms(fb["p50_ms"]) if fb else "-", fmt_ms(fb["p99_ms"]) if fb else "-",
                    fmt_ms(sb.get("p50_ms")), fmt_ms(sb.get("p99_ms")),
                    fmt_ms(ff["p50_ms"]) if ff else "-", fmt_ms(ff["p99_ms"]) if ff else "-",
                    fmt_ratio(ratio(r, "base_p50")), fmt_ratio(ratio(r, "base_p99")),
                    fmt_ratio(ratio(r, "full_p50")), fmt_ratio(ratio(r, "full_p99")), fmt_ms(oc.get("p50_ms")),
                    fmt_ms(oc.get("p99_ms")), cpu))
    return out


def loss_table(data):
    out = []
    conc = data["settings"]["concurrency"]
    out.append("| model | sessions | transport | datagrams sent per session | lost per session mean / max "
               "| sessions with loss | rejected (sessions) | late or duplicate (sessions) "
               "| sessions ending with predicted vertices (mean per session) | full p50 ms without / with them "
               "| kernel RcvbufErrors | server rate decreases (sessions) | fallbacks to gRPC |")
    out.append("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in models(data):
        verts = model_info(data, m)["vertices"]
        for c in conc:
            for kind in ("udp", "tcp_only"):
                r = row(data, m, kind, c)
                if r is None or "datagrams" not in r:
                    continue
                d, p, s = r["datagrams"], r["predicted_vertices"], r["server"]
                k = r.get("kernel_udp", {})
                wo, wi = p.get("time_to_full_ms_without", {}), p.get("time_to_full_ms_with", {})
                out.append("| %s | %d | %s | %d | %.2f / %d | %d of %d | %d (%d) | %d (%d) | %d (%s of %s vertices) "
                           "| %s / %s | %s | %d (%d) | %d |" % (
                               short(m), c, "UDP" if kind == "udp" else "TCP only",
                               s["datagrams_sent_total"] / s["sessions_logged"] if s["sessions_logged"] else 0,
                               d["lost_per_session_mean"], d["lost_per_session_max"], d["sessions_with_loss"],
                               r["completed"], d["rejected_total"], d["sessions_with_rejected"], d["duplicate_total"],
                               d["sessions_with_duplicate"], p["sessions_with_predicted"],
                               fmt_int(p["per_session_mean"]), fmt_int(verts),
                               fmt_ms(wo.get("p50_ms")), fmt_ms(wi.get("p50_ms")), k.get("RcvbufErrors", "-"), s["rate_decreases_total"],
                               s["sessions_with_rate_decrease"], r["fallbacks"]))
    return out


def markdown(data, prefix):
    mach = data["machine"]
    st = data["settings"]
    out = []
    out.append("Measured %s on %d x %s (%s), %s build, gRPC %s, SQLite %s; store on %s (%s); "
               "net.core.rmem_max %s. Load average at start %s, at end %s; the run took %.0f s%s." % (
                   mach["date"], mach["nproc"], mach["cpu"], mach.get("kernel", ""), mach.get("build_type", ""),
                   mach["grpc"], mach["sqlite"], mach["work_dir"], " ".join(mach.get("work_dir_filesystem", "").split()),
                   mach.get("net_core_rmem_max", "?"), mach["loadavg_at_start"], mach.get("loadavg_at_end", "?"),
                   mach.get("run_seconds", 0), " (`--quick`)" if st.get("quick") else ""))
    if mach.get("git_commit"):
        out.append("Source: commit %s." % mach["git_commit"])
    srv = st["server"]
    out.append("Server: %d workers, --max-rate %.0f Mbit/s, --max-session-rate %.0f Mbit/s, --max-sessions %d "
               "(the defaults but the workers); UDP on %s." % (
                   st["workers"], srv["max_rate_bps"] / 1e6, srv["max_session_rate_bps"] / 1e6, srv["max_sessions"],
                   srv["udp"]))
    out.append("Models (ingested once, default encode options): " + "; ".join(
        "%s (%s, %s bytes; %s vertices, %d levels; %s reliable + %s unreliable bytes)" % (
            m["name"], "/".join(m["roles"]), fmt_int(m["bytes"]), fmt_int(m["vertices"]), m["levels"],
            fmt_int(m["reliable_bytes"]), fmt_int(m["unreliable_bytes"])) for m in st["models"]) + ".")
    out.append("Failures (kError, not the full mesh, timeouts, failed exports; counted, never timed): %d." %
               data["failures"])
    for r in data["sessions"]:
        for e in r.get("errors", []):
            out.append("- %s %s x%d: %s" % (r["model"], r["transport"], r["concurrency"], e))
    for e in data.get("warmup_failures", []):
        out.append("- warm-up: %s" % e)
    out.append("")
    out.append("### Headline")
    out.append("")
    out.extend(headline(data))
    out.append("")
    out.append("Ratios: the session's time (to the full mesh, to the base mesh) over the Draco GLB export's time "
               "to the last byte, at the same percentile and the same number of concurrent clients, measured in "
               "the same rounds. Below 1, meshstream is there first.")
    out.append("")
    out.append("### Time to base and full mesh")
    out.append("")
    rounds = sorted({(r["concurrency"], r["rounds"]) for r in data["sessions"]})
    out.extend(session_table(data))
    out.append("")
    out.append("Rounds per row (sessions x rounds = n): %s. `base` and `full`: the SDK's `time_to_base_ms` and "
               "`time_to_full_ms`. `server's open to base`: the server's own time from the OpenRequest's arrival to "
               "the SessionStart (every base mesh) handed to gRPC, from its session log lines. `Open to kComplete`: "
               "measured by the benchmark around the same session, from before `Session::Open` until `Poll` "
               "returned `kComplete` (what the application sees). `CPU ms per session`: the server's process and "
               "the clients' process (a child of the benchmark) over the rounds of the row, per session." % ", ".join("%d x %d" % (c, n) for c, n in rounds))
    out.append("")
    out.append("![time to base and full mesh](%sstream-time.png)" % prefix)
    out.append("")
    out.append("The Draco reference per model: the first export (decode the artifact, encode with Draco, store it "
               "in the export cache: what the first client of a version waits), the GLB's size, and what its "
               "client would pay after the last byte, decoding it (importers/, one thread, median of 10):")
    out.append("")
    out.append("| model | Draco GLB bytes | first export ms | client decode ms | progressive artifact bytes |")
    out.append("|---|---:|---:|---:|---:|")
    for m in models(data):
        ref = data["draco_reference"][m]
        out.append("| %s | %s | %s | %s | %s |" % (short(m), fmt_int(ref["bytes"]), fmt_ms(ref["first_call_ms"]),
                                                fmt_ms(ref["client_decode"]["median_ms"]),
                                                fmt_int(model_info(data, m)["progressive_bytes"])))
    out.append("")
    out.append("### Losses over loopback")
    out.append("")
    out.extend(loss_table(data))
    out.append("")
    out.append("`lost`: the SDK's `datagrams_lost` (announced by the control block, not there when the refinement "
               "was decoded). `rejected`: `datagrams_rejected` (malformed, forged, replayed, or not fitting: a "
               "datagram beyond the reconstructor's window is counted here). `late or duplicate`: "
               "`datagrams_duplicate` (copies, and datagrams of refinements already decoded). `predicted "
               "vertices`: `Session::predicted_vertices()` at kComplete. `kernel RcvbufErrors`: the delta of "
               "/proc/net/snmp over the rows' rounds: datagrams the kernel dropped because a socket's receive "
               "buffer was full (every socket of the machine; the benchmark is the only UDP user). `rate "
               "decreases`: the server's rate controller backing off (its session log lines).")
    out.append("")
    dr = data["datagram_rate"]
    m = dr["meshstream"]
    lb = dr["loopback_sendmmsg"]
    out.append("### Datagrams per second")
    out.append("")
    cl = m["client"]
    out.append("| | datagrams | wall s | **datagrams/s** | sender CPU s | **per sender CPU-s** | CPU s, both ends "
               "| per CPU-s, both ends |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|")
    out.append("| meshstream: %d UDP sessions of %s at a time, for %.1f s | %s DATA sent | %.2f | **%s** | %.2f (server "
               "process) | **%s** | %.2f (+ clients %.2f) | %s |" % (
                   m["concurrent_sessions"], short(m["model"]), m["seconds_asked"], fmt_int(m["data_datagrams_sent"]),
                   m["wall_s"], fmt_rate(m["datagrams_per_s_wall"]), m["server_cpu_s"],
                   fmt_rate(m["datagrams_per_server_cpu_s"]), m["server_cpu_s"] + m["client_cpu_s"], m["client_cpu_s"],
                   fmt_rate(m["datagrams_per_cpu_s_both"])))
    for when in ("before", "after"):
        r = lb[when]
        out.append("| sendmmsg loop, %s the sessions | %s sent, %s received | %.2f | %s | %.2f (sending thread) | %s "
                   "| %.2f | %s |" % (
                       when, fmt_int(r["sent"]), fmt_int(r["received"]), r["wall_s"],
                       fmt_rate(r["datagrams_per_s_wall"]), r["sender_thread_cpu_s"],
                       fmt_rate(r["sent_per_sender_cpu_s"]), r["process_cpu_s"], fmt_rate(r["datagrams_per_cpu_s"])))
    ra = dr["ratios"]
    out.append("| **meshstream / loop** | | | **%.4f** | | **%.4f** | | %.4f |" % (
        ra["wall"], ra["server_cpu_vs_sender_cpu"], ra["both_ends_cpu"]))
    out.append("")
    out.append("The run: %d sessions opened in the client process (%d failed, %d fell back to gRPC, %d ended with "
               "predicted vertices), --max-rate and --max-session-rate %.0f Gbit/s. DATA datagrams (data and END) "
               "as the server's session log lines count them for the sessions of the window; the endpoint's own "
               "total at shutdown, warm-up sessions included: `%s`. The clients received %s and counted %s lost "
               "(%s rejected); the kernel's UDP counters over the window: %s; the server's rate controller backed "
               "off %d times. CPU: getrusage of each process over the window: the server's (its gRPC threads "
               "running the sessions: plan, artifact read, pacing, sealing, sendmmsg; its UDP endpoint thread; "
               "gRPC) and the client process's (%.2f s of its %.2f s on the threads that call `Poll`, where the "
               "SDK decodes). The machine was %.0f %% busy. The loop's *datagrams/s* counts what the receiver "
               "got; its sending thread's CPU includes the kernel's loopback delivery into the receiving socket, "
               "which runs in the sender's system call." % (
                   cl["sessions_opened"], cl["sessions_failed"], cl["sessions_fallback_grpc"],
                   cl["sessions_with_predicted_vertices"], dr["server_options"]["max_rate_bps"] / 1e9,
                   m.get("server_udp_totals_line", "-"), fmt_int(cl["datagrams_received"]),
                   fmt_int(cl["datagrams_lost"]), fmt_int(cl["datagrams_rejected"]),
                   ", ".join("%s %d" % (k, v) for k, v in m.get("kernel_udp", {}).items()),
                   m["server_rate_decreases"], cl["session_threads_cpu_s"], cl["process_cpu_s"],
                   100 * m["machine_busy"]))
    out.append("")
    out.append("![datagram rate](%sstream-datagrams.png)" % prefix)
    out.append("")
    notable = data.get("server", {}).get("log_notable", [])
    odd = [l for l in notable if l.startswith("session ")]
    if odd:
        out.append("Server log lines of sessions that did not end `complete` (first %d):" % len(odd))
        out.append("")
        out.append("```")
        out.extend(odd)
        out.append("```")
        out.append("")
    return "\n".join(out)



# ------------------------------------------------------------ shaped link

SHAPED_BEGIN = "<!-- bench:stream-shaped:begin -->"
SHAPED_END = "<!-- bench:stream-shaped:end -->"
SHAPED_KINDS = [("udp", "meshstream, UDP", "C0"), ("udp_no_parity", "meshstream, UDP without parity", "C2"),
                ("tcp_only", "meshstream, TCP only", "C1"), ("draco_export", "Draco GLB over gRPC", "k")]
FLOOR = 1e-6  # distances below it (0: the lossless mesh itself) are drawn on it


def shaped(data):
    s = data.get("shaped")
    return s if s and "runs" in s else None


def shaped_models(sh):
    return [m["name"] for m in sh["models"]]


def shaped_model(sh, name):
    return next(m for m in sh["models"] if m["name"] == name)


def shaped_row(sh, loss, model, kind):
    for r in sh["summary"]:
        if r["loss_percent"] == loss and r["model"] == model and r["kind"] == kind:
            return r
    return None


def shaped_runs(sh, loss, model, kind):
    return [r for r in sh["runs"] if r["loss_percent"] == loss and r["model"] == model and r["kind"] == kind]


def med(s, key="median_ms"):
    return s.get(key) if s else None


def quality_steps(run, t_end):
    """(xs, ys) of the step curve of one run: 1 (nothing shown) until the first mesh, then each snapshot's
    Hausdorff distance (relative to the diagonal), held until the next, up to t_end."""
    xs, ys = [0.0], [1.0]
    for q in run.get("quality", []):
        if "hausdorff_rel" not in q or "t_ms" not in q:
            continue
        xs.append(q["t_ms"])
        ys.append(max(q["hausdorff_rel"], FLOOR))
    xs.append(max(t_end, xs[-1]))
    ys.append(ys[-1])
    return xs, ys


def plot_shaped_quality(sh, path):
    losses = sh["settings"]["losses_percent"]
    cols = [losses[0], losses[-1]] if len(losses) > 1 else losses
    ms_ = shaped_models(sh)
    fig, axes = plt.subplots(len(ms_), len(cols), figsize=(7 * len(cols), 4.2 * len(ms_)), squeeze=False)
    for row_i, m in enumerate(ms_):
        # One time axis per model: the slowest run of the model at these losses, plus a little.
        t_end = 0
        for loss in cols:
            for kind, _, _ in SHAPED_KINDS:
                for r in shaped_runs(sh, loss, m, kind):
                    if r.get("ok"):
                        t_end = max(t_end, r.get("full_ms", 0))
        t_end *= 1.08
        for col_i, loss in enumerate(cols):
            ax = axes[row_i][col_i]
            for kind, label, color in SHAPED_KINDS:
                runs = [r for r in shaped_runs(sh, loss, m, kind) if r.get("ok")]
                for i, r in enumerate(runs):
                    xs, ys = quality_steps(r, t_end)
                    ax.step(xs, ys, where="post", color=color, alpha=0.55, linewidth=1.3,
                            label="%s (%d runs)" % (label, len(runs)) if i == 0 else None)
            ax.set_yscale("log")
            ax.set_ylim(FLOOR / 2, 1.6)
            ax.set_xlim(0, t_end)
            ax.axhline(1.0, color="0.6", linewidth=0.6, linestyle=":")
            ax.text(t_end * 0.99, 1.1, "nothing shown", ha="right", fontsize=7, color="0.4")
            ax.text(t_end * 0.99, FLOOR * 1.15, "exact (the full lossless mesh; Draco's GLB: %.1e)" %
                    shaped_model(sh, m)["draco_vs_reference"].get("hausdorff_rel", 0), ha="right", fontsize=7,
                    color="0.4")
            style_axes(ax, xlabel="ms from the request (warm gRPC channel)",
                       ylabel="Hausdorff distance / bbox diagonal (log)",
                       title="%s, %d %% loss" % (short(m), loss), legend_size=7)
            ax.legend(fontsize=7, loc="center right")  # clear of "nothing shown" and "exact"
    st = sh["settings"]
    fig.suptitle("What is shown over time on a shaped link: %.0f Mbit/s, %.0f ms each way, nftables drop on "
                 "TCP and UDP; client in a network namespace" % (st["rate_mbit"], st["delay_ms_each_way"]))
    save_figure(fig, path, 100, rect=(0, 0, 1, 0.97))


def plot_shaped_times(sh, path):
    losses = sh["settings"]["losses_percent"]
    ms_ = shaped_models(sh)
    fig, axes = plt.subplots(2, len(ms_), figsize=(6 * len(ms_), 8), squeeze=False)
    for col, m in enumerate(ms_):
        for line, (key, what) in enumerate((("first_ms", "first visible mesh"),
                                            ("full_ms", "full mesh (kComplete; UDP with loss: not exact)"))):
            ax = axes[line][col]
            for k, (kind, label, color) in enumerate(SHAPED_KINDS):
                xs, ys, lo, hi = [], [], [], []
                for loss in losses:
                    r = shaped_row(sh, loss, m, kind)
                    s = r.get(key) if r else None
                    if not s or "median_ms" not in s:
                        continue
                    xs.append(loss + (k - 1.5) * 0.2)
                    ys.append(s["median_ms"])
                    lo.append(s["median_ms"] - s["min_ms"])
                    hi.append(s["max_ms"] - s["median_ms"])
                if xs:
                    ax.errorbar(xs, ys, yerr=[lo, hi], color=color, marker="o", capsize=3, label=label)
            ax.set_xticks(losses)
            ax.set_xticklabels(["%d %%" % l for l in losses])
            ax.set_ylim(bottom=0)
            style_axes(ax, xlabel="packets the namespace drops (TCP and UDP)",
                       ylabel="ms from the request: median, min-max", title="%s: time to the %s" % (short(m), what),
                       legend_size=7)
    st = sh["settings"]
    fig.suptitle("Shaped link, %.0f Mbit/s, %.0f ms each way, %d runs per point; Draco: last byte + decode" % (
        st["rate_mbit"], st["delay_ms_each_way"], st["runs"]))
    save_figure(fig, path, 100, rect=(0, 0, 1, 0.97))


def fmt_rel(v):
    if v is None:
        return "-"
    if v == 0:
        return "0"
    if v < 1e-4:
        return "%.1e" % v
    return "%.2f %%" % (100 * v) if v >= 1e-3 else "%.3f %%" % (100 * v)


def fmt_span(s):
    if not s or "median_ms" not in s:
        return "-"
    return "%s (%s-%s)" % (fmt_ms(s["median_ms"]), fmt_ms(s["min_ms"]), fmt_ms(s["max_ms"]))


def parity_table(sh):
    """Issue 27's test on this link: UDP with parity against UDP without (OpenRequest.no_parity)."""
    st = sh["settings"]
    rows = [(m, loss, shaped_row(sh, loss, m, "udp")) for m in shaped_models(sh) for loss in st["losses_percent"]]
    rows = [(m, loss, u) for m, loss, u in rows if u and u.get("vs_no_parity")]
    if not rows:
        return []
    out = ["#### Parity on this link", ""]
    out.append("| model | loss | full ms: with / without parity | difference | parity bytes (median) | their time "
               "at %.0f Mbit/s | runs' spread | time target | final distance with parity: median (max) | without | distance target | "
               "datagrams over UDP / lost / rebuilt (median) |" % st["rate_mbit"])
    out.append("|---|---:|---:|---:|---:|---:|---:|---|---:|---:|---|---:|")
    verdicts = {"met": "met", "within_noise": "within noise", "not_met": "**not met**",
                "no_parity": "none sent"}
    for m, loss, u in rows:
        v = u["vs_no_parity"]
        out.append("| %s | %d %% | %s / %s | %+.1f ms | %s | %.1f ms | %.1f ms | %s | %s (%s) | %s (%s) | %s | %s / %s / %s |" % (
            short(m), loss, fmt_ms(v["full_ms_with"]), fmt_ms(v["full_ms_without"]), v["full_ms_difference"],
            fmt_int(u.get("parity_bytes_median", 0)), v["parity_ms_at_link_rate"], v["run_spread_ms"],
            verdicts[v["time_verdict"]], fmt_rel(u["final_hausdorff_rel_median"]),
            fmt_rel(u["final_hausdorff_rel_max"]), fmt_rel(v["final_distance_median_without"]),
            fmt_rel(v["final_distance_max_without"]), "met" if v["distance_met"] else "**not met**",
            fmt_int(u.get("udp_datagrams_received_median", 0)), fmt_int(u.get("datagrams_lost_median", 0)),
            fmt_int(u.get("datagrams_recovered_median", 0))))
    out.append("")
    out.append("The targets (docs/design/loss-protection.md): the median time to full with parity at most the median "
               "without plus the parity's bytes at the link's rate; the final distance to the full lossless mesh "
               "at most 0.1 % of the diagonal in the median and 0.25 % in the worst run. *Runs' spread*: the larger "
               "median absolute deviation of the two kinds' times; an excess below it is *within noise*. *Without*: the same "
               "sessions asking for no parity (`OpenRequest.no_parity`, `fetch --no-parity`), their turns "
               "interleaved with the others. A session that finishes before its HELLO proves a UDP address sends "
               "every refinement on the stream (docs/spec/streaming-protocol.md, Sessions step 3): it has no UDP loss "
               "to protect, and its parity bytes are 0.")
    out.append("")
    return out


def shaped_markdown(data, prefix):
    sh = data.get("shaped")
    out = []
    if not sh:
        out.append("Not measured in this run (`--no-shaped`).")
        return "\n".join(out)
    if "skipped" in sh:
        out.append("Skipped in this run: %s" % sh["skipped"])
        return "\n".join(out)
    st = sh["settings"]
    mach = data["machine"]
    runs = sh["runs"]

    def median_of(values):
        v = sorted(x for x in values if x is not None)
        return v[len(v) // 2] if v else None
    grpc_rtt = median_of(r.get("grpc_rtt_ms") for r in runs if r.get("grpc_rtt_ms", -1) > 0)
    hello_rtt = median_of(r["stats"]["hello_rtt_ms"] for r in runs if r.get("stats", {}).get("hello_rtt_ms", 0) > 0)
    snap_ms = {m: median_of(r.get("snapshot_ms") for r in runs if r["model"] == m and r["kind"] != "draco_export")
               for m in shaped_models(sh)}
    mach = sh.get("machine", mach)  # the shaped part's own, when it has one
    quick = sh.get("quick", data["settings"].get("quick"))
    run = sh.get("run", "only_shaped" if data["settings"].get("only_shaped") else "with the loopback parts")
    if run.startswith("only_shaped"):
        when = "a run of the shaped part alone (`--only-shaped`%s%s)" % (
            ", `--quick`" if quick else "",
            "; the loopback results below are those of the earlier full run" if "merged" in run else "")
    else:
        when = "the same run as the loopback results below (%s)" % ("`--quick`" if quick else "default flags")
    out.append("Measured %s in %s, on %d x %s (%s), %s build; load average at start %s, at end %s%s; the shaped "
               "part took %.0f s (%.0f s of sessions and downloads, %.0f s of distances: %d distinct meshes of %d "
               "snapshots). Failures: %d." % (
                   mach["date"], when, mach["nproc"], mach["cpu"], mach.get("kernel", ""),
                   mach.get("build_type", ""), mach.get("loadavg_at_start", "?"), mach.get("loadavg_at_end", "?"),
                   "; commit %s" % mach["git_commit"] if mach.get("git_commit") else "", sh["wall_s"],
                   sh["sessions_s"], sh["distance_s"], sh["distinct_meshes_measured"], sh["snapshots"],
                   sh["failures"]))
    out.append("Link: tbf %.0f Mbit/s on both veth ends, %.0f ms one way on both channels (UDP relay, TCP proxy), "
               "nftables drop of %s %% of what the namespace receives (%s); %d runs per loss, model and kind; "
               "server HELLO timeout %d ms (the default); gRPC via %s, UDP via %s." % (
                   st["rate_mbit"], st["delay_ms_each_way"], ", ".join(str(l) for l in st["losses_percent"]),
                   "UDP only: `--shaped-loss-udp-only`" if st.get("loss_udp_only") else "TCP and UDP",
                   st["runs"], st["server"]["hello_timeout_ms"], st["grpc_via"], st["udp_via"]))
    out.append("Measured round trips (medians): a unary gRPC call through the proxy %s ms, the SDK's UDP HELLO "
               "through the relay %s ms. Snapshots taken during a session (`CurrentScene()` at the events; "
               "their time is part of the session's): median %s ms per session." % (
                   fmt_ms(grpc_rtt), fmt_ms(hello_rtt),
                   ", ".join("%s %s" % (short(m), fmt_ms(v)) for m, v in snap_ms.items())))
    out.append("")
    out.append("| model | vertices | levels | meshstream reliable + unreliable bytes | session bytes on the wire "
               "at 0 %: TCP + UDP | Draco GLB bytes (on the wire) | Draco GLB vs full | source file vs full |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|")
    loss0 = st["losses_percent"][0]
    for m in sh["models"]:
        def wire(kind):
            rs = [r for r in shaped_runs(sh, loss0, m["name"], kind) if "wire" in r]
            if not rs:
                return "-"
            t = sorted(r["wire"]["tcp"]["bytes_to_client"] for r in rs)[len(rs) // 2]
            u = sorted(r["wire"]["udp"]["bytes_to_client"] for r in rs)[len(rs) // 2]
            return "%s + %s" % (fmt_int(t), fmt_int(u)) if u else fmt_int(t)
        out.append("| %s (%s) | %s | %d | %s + %s | UDP: %s; TCP only: %s | %s (%s) | %s | %s |" % (
            short(m["name"]), "/".join(m["roles"]), fmt_int(m["vertices"]), m["levels"], fmt_int(m["reliable_bytes"]),
            fmt_int(m["unreliable_bytes"]), wire("udp"), wire("tcp_only"), fmt_int(m["draco_glb_bytes"]),
            wire("draco_export"), fmt_rel(m["draco_vs_reference"].get("hausdorff_rel")),
            fmt_rel(m["source_vs_reference"].get("hausdorff_rel"))))
    out.append("")
    out.append("Bytes on the wire: what the TCP proxy passed to the client on the child's connections (the session "
               "or download, its channel's set-up and two `GetVersion` probes) and what the UDP relay passed to it, "
               "median of the runs at %d %% loss. *vs full*: Hausdorff distance to the full lossless mesh, over its "
               "bounding-box diagonal." % loss0)
    out.append("")
    out.append("#### Time to the first visible mesh and to full quality")
    out.append("")
    out.append("| model | loss | first: UDP / TCP only / Draco ms | full: UDP / TCP only / Draco ms | UDP / Draco "
               "(first, full) | TCP only / Draco (first, full) | UDP final distance: median (max) | UDP vertices "
               "predicted (median) | UDP fallbacks to gRPC |")
    out.append("|---|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in shaped_models(sh):
        for loss in st["losses_percent"]:
            u, t, d = (shaped_row(sh, loss, m, k) for k in ("udp", "tcp_only", "draco_export"))

            def three(key):
                return " / ".join(fmt_ms(med(r.get(key))) if r else "-" for r in (u, t, d))

            def vs(r):
                v = r.get("vs_draco") if r else None
                return "%s, %s" % (fmt_ratio(v["first"]), fmt_ratio(v["full"])) if v else "-"
            out.append("| %s | %d %% | %s | %s | %s | %s | %s (%s) | %s | %d of %d |" % (
                short(m), loss, three("first_ms"), three("full_ms"), vs(u), vs(t),
                fmt_rel(u["final_hausdorff_rel_median"]), fmt_rel(u["final_hausdorff_rel_max"]),
                fmt_int(u.get("predicted_vertices_median", 0)), u.get("fallbacks", 0), u["runs"] - u["failures"]))
    out.append("")
    tcp_rows = [r for r in sh["summary"] if r["kind"] == "tcp_only" and r["runs"] > r["failures"]]
    tcp_exact = sum(1 for r in tcp_rows if r["final_hausdorff_rel_max"] == 0)
    out.append("Medians over the runs, from the request (a warm gRPC channel: `WaitForConnected` before the clock "
               "starts) to what the application sees: meshstream's `kBaseReady` and `kComplete` as `Poll` returns "
               "them, Draco's last byte plus its decode (importers/, `ImportGltfBytes`). Ratios below 1: meshstream "
               "is there first. *Final distance*: the mesh at `kComplete` against the full lossless mesh (0: "
               "identical); TCP only ends exact in every run of %d of its %d rows, Draco at its GLB's distance "
               "(table above)." % (tcp_exact, len(tcp_rows)))
    out.append("")
    out.append("![quality over time](%sstream-shaped-quality.png)" % prefix)
    out.append("")
    out.append("![time to first and full vs loss](%sstream-shaped-times.png)" % prefix)
    out.append("")
    out.extend(parity_table(sh))
    out.append("#### Every row")
    out.append("")
    out.append("| model | loss | kind | runs | failed | first ms: median (min-max) | full ms: median (min-max) "
               "| within 1 % of the diagonal ms | within 0.1 % ms | final distance median (max) | datagrams lost "
               "/ received (median) | server rate at the end, srtt, decreases (median) |")
    out.append("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for m in shaped_models(sh):
        for loss in st["losses_percent"]:
            for kind, label, _ in SHAPED_KINDS:
                r = shaped_row(sh, loss, m, kind)
                if r is None:
                    continue
                srv = "-"
                dg = "-"
                if kind != "draco_export":
                    srv = "%.0f Mbit/s, %.0f ms, %.0f" % (r["server_final_rate_mbps_median"],
                                                        r["server_srtt_ms_median"], r["server_rate_decreases_median"])
                    if kind.startswith("udp"):
                        dg = "%.0f / %.0f" % (r["datagrams_lost_median"], r["datagrams_received_median"])
                out.append("| %s | %d %% | %s | %d | %d | %s | %s | %s | %s | %s (%s) | %s | %s |" % (
                    short(m), loss, label, r["runs"], r["failures"], fmt_span(r["first_ms"]), fmt_span(r["full_ms"]),
                    fmt_ms(med(r["within_1pct_ms"])), fmt_ms(med(r["within_0_1pct_ms"])),
                    fmt_rel(r["final_hausdorff_rel_median"]), fmt_rel(r["final_hausdorff_rel_max"]), dg, srv))
                for e in r.get("errors", []):
                    out.append("| | | | | | %s | | | | | | |" % e.replace("|", "/"))
    out.append("")
    out.append("*within 1 %%* (*0.1 %%*): the first snapshot whose distance to the full lossless mesh is at most that "
               "share of the diagonal (medians of the runs that got there; the snapshots are the base, at most %d "
               "levels and `kComplete`, so this is the time of a snapshot, not of the exact level). The server's "
               "figures come from its log line of each session: over TCP only its rate controller does not run "
               "(the figure is its initial rate)." % (st["max_snapshots"] - 2))
    out.append("")
    out.append("#### The link, per loss level")
    out.append("")
    out.append("| loss | wall s | TCP connections | their srtt at close: median / max ms | segments the proxy "
               "retransmitted to clients | bytes to clients over TCP | datagrams to clients over UDP |")
    out.append("|---:|---:|---:|---:|---:|---:|---:|")
    for p in sh["per_loss"]:
        px, rl = p["proxy"], p["relay"]
        out.append("| %d %% | %.1f | %d | %.1f / %.1f | %s | %s | %s |" % (
            p["loss_percent"], p["wall_s"], px["connections_closed"], px["srtt_ms_median"], px["srtt_ms_max"],
            fmt_int(px["segments_retransmitted"]), fmt_int(px["bytes_to_clients"]), fmt_int(rl["to_client_forwarded"])))
    out.append("")
    out.append("The srtt is the kernel's (TCP_INFO) for the connection between the proxy and the client, the one "
               "that crosses the lossy link: it does not contain the proxy's %.0f ms each way (see above). Server "
               "UDP totals: `%s`." % (st["delay_ms_each_way"], sh["server"].get("udp_totals_line", "-")))
    odd = [l for l in sh["server"].get("log_notable", []) if l.startswith("session ")]
    if odd:
        out.append("")
        out.append("Server log lines of sessions that did not end `complete`:")
        out.append("")
        out.append("```")
        out.extend(odd)
        out.append("```")
    return "\n".join(out)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.dirname(here)
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?", default=os.path.join(root, "docs", "bench", "stream.json"))
    ap.add_argument("--out", default=None, help="folder for the PNGs (default: the JSON's folder)")
    ap.add_argument("--doc", default=os.path.join(root, "docs", "stream-benchmarks.md"),
                    help="Markdown file whose marked sections receive the tables ('' to skip)")
    a = ap.parse_args()
    data = load(a.results)
    out = output_dir(a.out, a.results)
    plots = 0
    sections = []
    if "sessions" in data:  # not there after --only-shaped
        plot_times(data, os.path.join(out, "stream-time.png"))
        plot_datagrams(data, os.path.join(out, "stream-datagrams.png"))
        plots += 2
        sections.append((BEGIN, END, lambda prefix: markdown(data, prefix)))
    sh = shaped(data)
    if sh:
        plot_shaped_quality(sh, os.path.join(out, "stream-shaped-quality.png"))
        plot_shaped_times(sh, os.path.join(out, "stream-shaped-times.png"))
        plots += 2
    if "shaped" in data:
        sections.append((SHAPED_BEGIN, SHAPED_END, lambda prefix: shaped_markdown(data, prefix)))
    if a.doc and os.path.exists(a.doc):
        for begin, end, render in sections:
            if update_doc(a.doc, begin, end, out, render):
                print("plot_stream.py: updated %s (%s)" % (a.doc, begin))
            else:
                print("plot_stream.py: %s has no %s ... %s markers; left alone" % (a.doc, begin, end))
    print("plot_stream.py: wrote %d plots into %s" % (plots, out))
    return 0


if __name__ == "__main__":
    sys.exit(main())
