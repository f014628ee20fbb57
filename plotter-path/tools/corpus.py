#!/usr/bin/env python3
"""Corpus check of the SVG importer: run every SVG under a folder through `plotter stats --json`.

Usage: plotter-path/tools/corpus.py [--dir /usr/share/openclipart/svg] [--plotter target/release/plotter]
                                    [--jobs 2] [--limit N] [-- EXTRA PLOTTER FLAGS]

Reports the number of files imported, rejected (grouped by the first words of the error), panics, timeouts,
and the slowest files. The corpus is Debian's `openclipart-svg` package (not a CI dependency:
`apt-get install openclipart-svg`). Targets: >= 99 % imported, 0 panics, no file over 2 s.
"""
import argparse, collections, concurrent.futures as cf, json, os, re, subprocess, sys, time

p = argparse.ArgumentParser()
p.add_argument("--dir", default="/usr/share/openclipart/svg")
p.add_argument("--plotter", default="target/release/plotter")
p.add_argument("--jobs", type=int, default=2)
p.add_argument("--limit", type=int, default=0)
p.add_argument("--timeout", type=float, default=20.0)
p.add_argument("--json-out", default="")
p.add_argument("extra", nargs="*")
a = p.parse_args()

files = sorted(os.path.join(r, f) for r, _, fs in os.walk(a.dir) for f in fs if f.lower().endswith((".svg", ".svgz")))
if a.limit:
    files = files[: a.limit]


def run(path):
    t0 = time.monotonic()
    try:
        r = subprocess.run([a.plotter, "stats", "--json", *a.extra, path], capture_output=True, text=True,
                           timeout=a.timeout)
    except subprocess.TimeoutExpired:
        return path, "timeout", a.timeout, ""
    dt = time.monotonic() - t0
    err = r.stderr
    if "panicked" in err or r.returncode == 101:
        return path, "panic", dt, err.strip().splitlines()[-1] if err.strip() else ""
    if r.returncode != 0:
        lines = [l for l in err.splitlines() if l.startswith("error")] or err.splitlines() or [""]
        return path, "error", dt, lines[0]
    try:
        stats = json.loads(r.stdout)
    except ValueError:
        return path, "error", dt, "stats output is not JSON"
    return path, "ok", dt, stats


results = []
with cf.ThreadPoolExecutor(a.jobs) as ex:
    for i, res in enumerate(ex.map(run, files)):
        results.append(res)
        if (i + 1) % 500 == 0:
            print(f"... {i + 1}/{len(files)}", file=sys.stderr, flush=True)

by = collections.Counter(r[1] for r in results)
n = len(results)
print(f"files: {n}")
for k in ("ok", "error", "panic", "timeout"):
    print(f"{k}: {by.get(k, 0)} ({100.0 * by.get(k, 0) / max(n, 1):.2f} %)")
slow = sorted(results, key=lambda r: -r[2])[:10]
print("slowest:")
for path, status, dt, _ in slow:
    print(f"  {dt:6.2f} s  {status:7s} {os.path.relpath(path, a.dir)}")
print(f"over 2 s: {sum(1 for r in results if r[2] > 2.0)}")
groups = collections.Counter()
examples = {}
for path, status, dt, msg in results:
    if status in ("error", "panic", "timeout"):
        # Drop the file name and numbers so similar errors group together.
        key = re.sub(r"^error: [^:]*: ", "", str(msg))
        key = re.sub(r"\d+", "N", key)[:110]
        groups[(status, key)] += 1
        examples.setdefault((status, key), os.path.relpath(path, a.dir))
print("error groups:")
for (status, key), c in groups.most_common():
    print(f"  {c:5d}  {status}: {key}   e.g. {examples[(status, key)]}")
if a.json_out:
    with open(a.json_out, "w") as f:
        json.dump([{"file": r[0], "status": r[1], "seconds": r[2],
                    "detail": r[3] if r[1] != "ok" else None} for r in results], f)
