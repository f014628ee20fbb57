#!/usr/bin/env bash
# How much of the travel above the plot-time bound is order and how much is the bound's looseness (issue 39): for
# every pen-plotter profile in samples/ and the seven openclipart drawings of plan_vs_bound.sh, `plotter stats
# --json` at the default optimize budget and at a much larger one (--opt-work 0: until no move improves, with ten
# times the random kicks). Per profile it prints, summed over the drawings, seconds:
#
#   travel order, hops   the two travel causes at the default budget (as plan_vs_bound.sh prints them);
#   order found          what the larger search won on the plan (default plan less the searched one): order time
#                        any optimizer could win, at least;
#   order left           travel order + hops at the larger budget: the rest, which is the bound's looseness or
#                        order no search found (an exact solve of every small layer is part of the bound, so on a
#                        layer of up to a dozen paths it is looseness of the hop's time model alone).
#
#   PLOTTER=target/release/plotter plotter-cli/benches/travel_split.sh [PROFILE.toml ...]
set -euo pipefail
# shellcheck source=bound_bench_drawings.sh
source "$(dirname "$0")/bound_bench_drawings.sh"
printf '%-26s %12s %8s %12s %12s\n' profile "travel order" hops "order found" "order left"
for profile in "${PROFILES[@]}"; do
  name=$(basename "$profile")
  layout=$(layout_for "$profile")
  rows=""
  for d in "${DRAWINGS[@]}"; do
    for budget in "" "--opt-work 0 --opt-kicks 20"; do
      # shellcheck disable=SC2086
      rows+=$("$PLOTTER" stats "$d" --profile "$profile" $layout --fit --json $budget 2>/dev/null | python3 -c '
import json, sys
v = json.load(sys.stdin)
g = v["est_time_parts_optimized"]["above_lower_bound_s"]
print(v["est_time_s_optimized"], g["travel_order_s"], g["hops_s"], end=" ")
')
    done
    rows+=$'\n'
  done
  printf '%s' "$rows" | python3 -c '
import sys
rows = [list(map(float, l.split())) for l in sys.stdin if l.strip()]
order, hops = sum(r[1] for r in rows), sum(r[2] for r in rows)
found = sum(r[0] - r[3] for r in rows)
left = sum(r[4] + r[5] for r in rows)
print("%-26s %12.1f %8.1f %12.1f %12.1f" % (sys.argv[1], order, hops, found, left))
' "$name"
done
