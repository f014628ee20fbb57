#!/usr/bin/env python3
"""Wall time of our import + path ordering against vpype's `read linemerge linesort --two-opt`, side by side.

Inputs: the N (default 20) largest drawings of Debian's openclipart-svg package (`apt-get install openclipart-svg`,
files under /usr/share/openclipart/) that our importer reads, by imported path count. Candidates are the 4·N files
with the most drawing elements (duplicates by content or by file name dropped); each is imported once with
`plotter stats --json --no-optimize` and ranked by its `paths`.

Per file, ours and vpype's run alternately R times (default 3; the machine may be shared, so each side's median is
reported):
  ours:   plotter optimize FILE -o /dev/null     (import, merge, order, improve, and the SVG written: import + order)
  stats:  plotter stats FILE --json              (all that, plus both plot-time estimates — the input order's and the
                                                  result's, each a whole motion plan and a lower bound — and the
                                                  pen-up figure after ordering)
  vpype:  vpype read FILE linemerge linesort --two-opt
The ratio is vpype's time over ours (import + order, what vpype does); ratio_stats the same over `stats`.
With --base BIN, an older build of ours runs `stats` in the same rotation (its time is comparable with the stats
column), and its pen-up travel is shown next to ours
("before" / "after"): the ordering must not get worse.

Usage (after `cargo build --release -p plotter-cli`):
  plotter-path/benches/vs_vpype.py [--n 20] [--repeat 3] [--plotter target/release/plotter] [--base OLD_BIN]
                                   [--vpype vpype] [--list FILE] [--json]
--list FILE caches the chosen inputs (one path a line; read when it exists, written otherwise).
"""

import argparse
import hashlib
import json
import os
import re
import statistics
import subprocess
import sys
import time

ROOT = "/usr/share/openclipart"
ELEMENT = re.compile(rb"<(?:path|polyline|polygon|line|rect|circle|ellipse)[\s/>]")


def candidates(count):
    """The `count` SVG files with the most drawing elements, one per content and per file name."""
    rows = []
    for d, _, files in os.walk(ROOT):
        for f in files:
            if f.endswith(".svg"):
                p = os.path.join(d, f)
                with open(p, "rb") as fh:
                    data = fh.read()
                rows.append((len(ELEMENT.findall(data)), hashlib.md5(data).hexdigest(), f, p))
    rows.sort(key=lambda r: (-r[0], r[3]))
    seen, out = set(), []
    for n, digest, name, p in rows:
        if digest in seen or name in seen:
            continue
        seen.update((digest, name))
        out.append(p)
        if len(out) == count:
            break
    return out


def run(cmd):
    """Wall seconds and stdout of `cmd`, or None when it fails."""
    t = time.perf_counter()
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    dt = time.perf_counter() - t
    return (dt, r.stdout) if r.returncode == 0 else (None, r.stdout)


def choose(plotter, n, list_file):
    if list_file and os.path.exists(list_file):
        with open(list_file) as fh:
            return [l.strip() for l in fh if l.strip()][:n]
    ranked = []
    for p in candidates(4 * n):
        _, out = run([plotter, "stats", p, "--json", "--no-optimize"])
        try:
            ranked.append((json.loads(out)["paths"], p))
        except (ValueError, KeyError):
            print(f"skip {p} (our importer refused it)", file=sys.stderr)
    ranked.sort(key=lambda r: (-r[0], r[1]))
    chosen = [p for _, p in ranked[:n]]
    if list_file:
        with open(list_file, "w") as fh:
            fh.write("\n".join(chosen) + "\n")
    return chosen


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--plotter", default=os.path.join(here, "../../target/release/plotter"))
    ap.add_argument("--base", help="an older build of ours, for pen-up before/after")
    ap.add_argument("--vpype", default="vpype")
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--list")
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args()
    files = choose(a.plotter, a.n, a.list)
    rows = []
    if not a.json:
        print(f"{'input':36} {'paths':>6} {'ours s':>7} {'stats s':>7} {'base s':>7} {'vpype s':>8} {'ratio':>6} "
              f"{'pen-up before':>13} {'pen-up after':>12}")
    for f in files:
        ours, stats, base, vp = [], [], [], []
        pen_up, pen_up_base, paths = None, None, None
        for _ in range(a.repeat):
            dt, _ = run([a.plotter, "optimize", f, "-o", os.devnull])
            if dt is not None:
                ours.append(dt)
            dt, out = run([a.plotter, "stats", f, "--json"])
            if dt is not None:
                stats.append(dt)
                j = json.loads(out)
                pen_up, paths = j["pen_up_mm_optimized"], j["paths"]
            if a.base:
                dt, out = run([a.base, "stats", f, "--json"])
                if dt is not None:
                    base.append(dt)
                    pen_up_base = json.loads(out)["pen_up_mm_optimized"]
            dt, _ = run([a.vpype, "read", f, "linemerge", "linesort", "--two-opt"])
            if dt is not None:
                vp.append(dt)
        if not ours or not stats or not vp:
            print(f"skip {f} (a side failed)", file=sys.stderr)
            continue
        row = {
            "input": os.path.basename(f),
            "paths": paths,
            "ours_s": statistics.median(ours),
            "stats_s": statistics.median(stats),
            "base_s": statistics.median(base) if base else None,
            "vpype_s": statistics.median(vp),
            "pen_up_before_mm": pen_up_base,
            "pen_up_after_mm": pen_up,
        }
        row["ratio"] = row["vpype_s"] / row["ours_s"]
        row["ratio_stats"] = row["vpype_s"] / row["stats_s"]
        rows.append(row)
        if not a.json:
            fmt = lambda v, spec: "-" if v is None else format(v, spec)
            print(f"{row['input'][:36]:36} {paths:>6} {row['ours_s']:7.3f} {row['stats_s']:7.3f} "
                  f"{fmt(row['base_s'], '7.3f'):>7} "
                  f"{row['vpype_s']:8.3f} {row['ratio']:6.1f} {fmt(pen_up_base, '13.1f'):>13} {pen_up:12.1f}",
                  flush=True)
    total = {
        "drawings": len(rows),
        "ours_s": sum(r["ours_s"] for r in rows),
        "stats_s": sum(r["stats_s"] for r in rows),
        "vpype_s": sum(r["vpype_s"] for r in rows),
        "worst_ratio": min((r["ratio"] for r in rows), default=None),
        "median_ratio": statistics.median([r["ratio"] for r in rows]) if rows else None,
        "pen_up_worse_on": sum(1 for r in rows if r["pen_up_before_mm"] is not None
                               and r["pen_up_after_mm"] > r["pen_up_before_mm"] + 1e-6),
    }
    if a.base:
        total["base_s"] = sum(r["base_s"] or 0.0 for r in rows)
        total["pen_up_before_mm"] = sum(r["pen_up_before_mm"] or 0.0 for r in rows)
    total["pen_up_after_mm"] = sum(r["pen_up_after_mm"] for r in rows)
    if total["ours_s"] > 0 and total["stats_s"] > 0:
        total["ratio"] = total["vpype_s"] / total["ours_s"]
        total["ratio_stats"] = total["vpype_s"] / total["stats_s"]
    if a.json:
        print(json.dumps({"total": total, "rows": rows}, indent=1))
    else:
        print("\n" + json.dumps(total))


if __name__ == "__main__":
    main()
