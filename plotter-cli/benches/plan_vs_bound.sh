#!/usr/bin/env bash
# How close each machine's plans come to their own limits (issue 39): for every pen-plotter profile in samples/ and
# seven openclipart drawings (A4 landscape, fitted inside a 20 mm margin — on a machine smaller than that, its
# own work area 10 mm in —, one layer as drawn), `plotter stats --json`
# gives the optimized plan's time and the lower bound any order and planner must meet; this prints plan / bound per
# drawing, and per profile the ratio of the sums and the worst drawing, then where the time above the bound goes
# (seconds summed over the drawings, by cause, as `plotter stats --verbose` names them).
#
# A servo pen plans (and is bounded) otherwise on GRBL, whose M3 stops the carriage for the drop: a servo profile
# that drives no EiBotBoard gets a second row, `NAME@grbl`, planned with `--firmware grbl` (`PROFILE.toml:grbl`
# names one as an argument).
#
#   PLOTTER=target/release/plotter plotter-cli/benches/plan_vs_bound.sh [PROFILE.toml[:grbl] ...]
set -euo pipefail
# shellcheck source=bound_bench_drawings.sh
source "$(dirname "$0")/bound_bench_drawings.sh"
if [ $# -eq 0 ]; then
  for p in "${PROFILES[@]}"; do
    if grep -q '^command = "servo"' "$p" && ! grep -q '^\[ebb\]' "$p"; then
      PROFILES+=("$p:grbl")
    fi
  done
fi
CAUSES="axis_limits corners curves stroke_ends step_timing lifts drops settles hops travel_order"
printf '%-26s %-34s %9s %9s %7s\n' profile drawing plan_s bound_s ratio
for entry in "${PROFILES[@]}"; do
  profile=${entry%:grbl}
  name=$(basename "$profile")
  firmware=()
  if [ "$entry" != "$profile" ]; then
    firmware=(--firmware grbl)
    name="$name@grbl"
  fi
  layout=$(layout_for "$profile")
  rows=""
  for d in "${DRAWINGS[@]}"; do
    json=$("$PLOTTER" stats "$d" --profile "$profile" "${firmware[@]}" $layout --fit --json 2>/dev/null)
    row=$(printf '%s' "$json" | python3 -c '
import json, sys
v = json.load(sys.stdin)
g = v["est_time_parts_optimized"]["above_lower_bound_s"]
causes = sys.argv[1].split()
print(v["est_time_s_optimized"], v["est_time_lower_bound_s_optimized"], *[g[c + "_s"] for c in causes])
' "$CAUSES")
    rows+="$row"$'\n'
    read -r plan bound _ <<<"$row"
    printf '%-26s %-34s %9.2f %9.2f %7.3f\n' "$name" "$(basename "$d" .svg)" "$plan" "$bound" \
      "$(python3 -c "print($plan / $bound)")"
  done
  printf '%s' "$rows" | python3 -c '
import sys
name, causes = sys.argv[1], sys.argv[2].split()
rows = [list(map(float, l.split())) for l in sys.stdin if l.strip()]
plan, bound = sum(r[0] for r in rows), sum(r[1] for r in rows)
worst = max(r[0] / r[1] for r in rows)
print("%-26s %-34s %9.2f %9.2f %7.3f   worst %.3f" % (name, "SUM", plan, bound, plan / bound, worst))
parts = ["%s %.1f" % (c.replace("_", " "), round(sum(r[2 + i] for r in rows), 1) + 0.0) for i, c in enumerate(causes)]
print("%-26s above the bound, s: %s" % (name, ", ".join(parts)))
' "$name" "$CAUSES"
done
