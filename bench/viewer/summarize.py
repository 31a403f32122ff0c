#!/usr/bin/env python3
"""The viewer benchmark's JSON (bench/viewer/run.sh): the viewer's --stats of
every run, pooled per model and update policy. Frame times are pooled over
the runs: the median and the 99th percentile (nearest rank) of the frames
drawn while refining (from BASE_READY to the last level on the GPU) against
the median idle frame after COMPLETE, in the same runs; and, since a frame
while refining draws a smaller mesh than the idle one, per refining frame its
time against the same frame's time without the stream step (the same mesh
drawn): the cost of refining itself. Uploads: the bytes
written to the GPU buffers over the session against the final buffers' size,
and against uploading every level shown whole (the export-and-re-upload way).
usage: summarize.py --rate MBIT --size WxH --out OUT.json STATS.json..."""
import argparse
import json
import math
import os
import platform
import statistics
import subprocess
import time


def quantile(values, q):
    if not values:
        return 0.0
    s = sorted(values)
    k = max(1, math.ceil(q * len(s)))
    return s[k - 1]


def renderer():
    try:
        out = subprocess.run(["glxinfo", "-B"], capture_output=True, text=True, timeout=10).stdout
        for line in out.splitlines():
            if "OpenGL renderer" in line:
                return line.split(":", 1)[1].strip()
    except (OSError, subprocess.SubprocessError):
        pass
    return "Mesa llvmpipe (LIBGL_ALWAYS_SOFTWARE=1)"


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--rate", required=True)
    p.add_argument("--size", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("stats", nargs="+")
    a = p.parse_args()
    groups = {}
    for path in a.stats:
        s = json.load(open(path))
        if not s["complete"]:
            raise SystemExit(f"{path}: the session did not complete")
        groups.setdefault((s["asset"], s["min_update_ms"]), []).append(s)
    rows = []
    for (asset, update), runs in sorted(groups.items()):
        refining = [x for r in runs for x in r["refining_frame_ms"]]
        # Per refining frame: the frame against the same frame without its
        # stream step (poll and uploads), the same mesh drawn: what refining costs.
        per_frame = [f / d for r in runs for f, d in zip(r["refining_frame_ms"], r["refining_draw_ms"]) if d > 0]
        idle = [x for r in runs for x in r["idle_frame_ms"]]
        stream = [x for r in runs for x in r["stream_us"]]
        row = {
            "asset": asset,
            "min_update_ms": update,
            "runs": len(runs),
            "levels": runs[0]["levels"][-1]["level"],
            "levels_shown_median": statistics.median(len(r["levels"]) for r in runs),
            "final_vertices": runs[0]["final_vertices"],
            "final_indices": runs[0]["final_indices"],
            "refining_frames": len(refining),
            "idle_frames": len(idle),
            "refining_frame_ms_median": quantile(refining, 0.5),
            "refining_frame_ms_p99": quantile(refining, 0.99),
            "idle_frame_ms_median": quantile(idle, 0.5),
            "idle_frame_ms_p99": quantile(idle, 0.99),
            "stream_us_median": quantile(stream, 0.5),
            "stream_us_p99": quantile(stream, 0.99),
            "stream_us_max": max(stream) if stream else 0.0,
            "budget_us": runs[0]["budget_us"],
            "upload_ratio_median": statistics.median(r["upload_ratio"] for r in runs),
            "reupload_ratio_median": statistics.median(r["reupload_bytes"] / r["final_buffer_bytes"] for r in runs),
            "bytes_uploaded_median": statistics.median(r["bytes_uploaded"] for r in runs),
            "final_buffer_bytes": runs[0]["final_buffer_bytes"],
            "time_to_full_ms_median": statistics.median(r["time_to_full_ms"] for r in runs),
        }
        row["same_frame_ratio_median"] = quantile(per_frame, 0.5)
        row["same_frame_ratio_p99"] = quantile(per_frame, 0.99)
        row["frame_ratio_median"] = row["refining_frame_ms_median"] / row["idle_frame_ms_median"]
        row["frame_ratio_p99"] = row["refining_frame_ms_p99"] / row["idle_frame_ms_median"]
        rows.append(row)
    doc = {
        "benchmark": "viewer",
        "date": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "machine": {"cpus": os.cpu_count(), "platform": platform.platform(), "renderer": renderer()},
        "session_rate_mbit": float(a.rate),
        "size": a.size,
        "targets": {"frame_ratio_median": 1.5, "frame_ratio_p99": 3.0, "upload_ratio": 1.3},
        "results": rows,
    }
    json.dump(doc, open(a.out, "w"), indent=2)
    for r in rows:
        print("%-15s update %4d ms: the same frame with/without its stream step: median %.3f x, p99 %.3f x" %
              (r["asset"], r["min_update_ms"], r["same_frame_ratio_median"], r["same_frame_ratio_p99"]))
        print("%-15s update %4d ms: frames refining/idle median %.2f x, p99 %.2f x (%d refining frames); "
              "uploaded %.2f x the final buffers (whole levels: %.2f x)" %
              (r["asset"], r["min_update_ms"], r["frame_ratio_median"], r["frame_ratio_p99"], r["refining_frames"],
               r["upload_ratio_median"], r["reupload_ratio_median"]))


if __name__ == "__main__":
    main()
