"""Summarise the tone bench's results.tsv: per photo, every one of our styles and each peer style at its best
setting (lowest L* error), then the targets: our best style at most 0.7x the best peer's error with no more ink,
and the default style (hatch) at most the best peer's error.

Usage: report.py results.tsv
Columns of results.tsv: photo, label, L* error, SSIM, ink m, paths, plot time s.
"""

import math
import sys
from collections import defaultdict


def main():
    rows = defaultdict(list)
    with open(sys.argv[1]) as f:
        for line in f:
            parts = line.rstrip("\n").split("\t")
            if len(parts) < 7:
                continue
            photo, label, err, ssim, ink, paths, t = parts
            rows[photo].append((label, float(err), float(ssim), float(ink), int(paths), float(t)))
    verdicts = []
    for photo, rs in rows.items():
        ours = [r for r in rs if r[0].startswith("ours-")]
        best_peer_style = {}
        for r in rs:
            if r[0].startswith("ours-"):
                continue
            peer, style = r[0].split("-")[:2]
            key = f"{peer}-{style}"
            if key not in best_peer_style or r[1] < best_peer_style[key][1]:
                best_peer_style[key] = r
        print(f"\n{photo}")
        print(f"  {'style':<48} {'L* err':>7} {'SSIM':>6} {'ink m':>7} {'paths':>7} {'time s':>8}")
        for r in ours + sorted(best_peer_style.values(), key=lambda r: r[1]):
            print(f"  {r[0]:<48} {r[1]:>7.4f} {r[2]:>6.3f} {r[3]:>7.1f} {r[4]:>7} {r[5]:>8.1f}")
        if not ours or not best_peer_style:
            continue
        peer = min(best_peer_style.values(), key=lambda r: r[1])
        best = min(ours, key=lambda r: r[1])
        fits = [r for r in ours if r[3] <= peer[3] + 1e-9]
        best_fit = min(fits, key=lambda r: r[1]) if fits else None
        default = next((r for r in ours if r[0] == "ours-hatch"), None)
        ok1 = best_fit is not None and best_fit[1] <= 0.7 * peer[1]
        ok2 = default is not None and default[1] <= peer[1]
        verdicts.append((ok1, ok2))
        fit_text = (f"{best_fit[0]} {best_fit[1]:.4f} = {best_fit[1] / peer[1]:.2f}x at {best_fit[3]:.1f} m"
                    if best_fit else "none within the peer's ink")
        print(f"  best peer: {peer[0]} {peer[1]:.4f} at {peer[3]:.1f} m; our best: {best[0]} {best[1]:.4f} "
              f"({best[1] / peer[1]:.2f}x, {best[3]:.1f} m); within its ink: {fit_text} "
              f"[{'met' if ok1 else 'NOT met'}]; default hatch "
              f"{default[1] if default else math.nan:.4f} [{'met' if ok2 else 'NOT met'}]")
    if verdicts:
        print(f"\ntargets met: best style {sum(v[0] for v in verdicts)}/{len(verdicts)} photos, "
              f"default {sum(v[1] for v in verdicts)}/{len(verdicts)} photos")


if __name__ == "__main__":
    main()
