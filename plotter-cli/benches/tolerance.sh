#!/usr/bin/env bash
# Whether a drawing's plan depends on how finely its curves were flattened (issue 39): for every pen-plotter
# profile in samples/ and the seven openclipart drawings of plan_vs_bound.sh (A4 landscape within a 20 mm margin,
# or the MiniKit's own area 10 mm in, --fit), `plotter stats --json` at --tolerance 0.05 (coarse) and 0.002 mm
# (fine) gives the optimized plan's time; this prints both per drawing and their difference (fine / coarse − 1),
# and that of the pen-down time alone (the curves' part: the travel between strokes also moves with the order the
# optimizer finds for the changed points), and per profile the sums and the drawing whose plan differs most.
# Curves planned by their centripetal acceleration plot alike at either tolerance; a plan that reads each vertex
# on its own does not.
#
#   PLOTTER=target/release/plotter plotter-cli/benches/tolerance.sh [PROFILE.toml ...]
set -euo pipefail
# shellcheck source=bound_bench_drawings.sh
source "$(dirname "$0")/bound_bench_drawings.sh"
COARSE=${COARSE:-0.05}
FINE=${FINE:-0.002}
printf '%-26s %-30s %10s %10s %8s %8s\n' profile drawing "${COARSE}_s" "${FINE}_s" diff_% draw_%
for profile in "${PROFILES[@]}"; do
  name=$(basename "$profile")
  layout=$(layout_for "$profile")
  rows=""
  for d in "${DRAWINGS[@]}"; do
    row=""
    for tol in "$COARSE" "$FINE"; do
      # shellcheck disable=SC2086
      row+=$("$PLOTTER" stats "$d" --profile "$profile" $layout --fit --tolerance "$tol" --json 2>/dev/null |
        python3 -c '
import json, sys
v = json.load(sys.stdin)
print(v["est_time_s_optimized"], v["est_time_parts_optimized"]["draw_s"], end=" ")')
    done
    rows+="$(basename "$d" .svg) $row"$'\n'
    read -r coarse coarse_draw fine fine_draw <<<"$row"
    printf '%-26s %-30s %10.2f %10.2f %+8.2f %+8.2f\n' "$name" "$(basename "$d" .svg)" "$coarse" "$fine" \
      "$(python3 -c "print(100 * ($fine / $coarse - 1))")" "$(python3 -c "print(100 * ($fine_draw / $coarse_draw - 1))")"
  done
  printf '%s' "$rows" | python3 -c '
import sys
name = sys.argv[1]
rows = [l.split() for l in sys.stdin if l.strip()]
coarse, fine = sum(float(r[1]) for r in rows), sum(float(r[3]) for r in rows)
draw = 100 * (sum(float(r[4]) for r in rows) / sum(float(r[2]) for r in rows) - 1)
worst = max(rows, key=lambda r: abs(float(r[3]) / float(r[1]) - 1))
w = 100 * (float(worst[3]) / float(worst[1]) - 1)
print("%-26s %-30s %10.2f %10.2f %+8.2f %+8.2f   worst %s %+.2f" % (name, "SUM", coarse, fine, 100 * (fine / coarse - 1), draw, worst[0], w))
' "$name"
done
