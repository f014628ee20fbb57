#!/usr/bin/env bash
# Plot time against saxi (issue 23), by hand: for each drawing, saxi and ours plot the SAME polylines on the
# project's EBB emulator (`plotter sim --pty --ebb --fast`) with the same machine limits, and the board's motion
# time (the trace's `# busy_ticks`, µs: steps, pen servo moves and dwells, as the board executes them) is compared.
#
#   PLOTTER=target/release/plotter SAXI_DIR=target/ci-node/node_modules/saxi \
#     plotter-cli/benches/vs_saxi.sh [DRAWING ...]      (default: the drawings listed below)
#
# - The polylines: `plotter convert DRAWING --paper a4 --landscape --fit` (mm, laid out on the AxiDraw's page).
#   Both plot that file, so only path order and motion planning differ.
# - saxi: plotter-cli/benches/vs_saxi_drive.js (its default pipeline: optimize-paths `reorder` = greedy nearest
#   path end, either direction; `merge` of ends within 0.5 mm; its AxidrawFast limits: pen down 50 mm/s at
#   200 mm/s², cornering 0.127 mm; pen up 200 mm/s at 400 mm/s²; pen lift and drop 0.12 s each). saxi moves the
#   pen with raw S2 positions, so the emulator is told where the tip touches (--ebb-pen-contact 16725, between its
#   up 17750 and down 15700) to count its lifts.
# - ours: `plotter plot --firmware ebb --profile samples/axidraw-saxi.toml --pen-change none` (our optimizer's
#   order, our planner; no pauses between colours, as saxi plots them all with one pen).
# Prints one row per drawing (its paths, saxi's pen lifts / ours, both board times in seconds, ours/saxi, the lower
# bound `plotter stats` proves for our plan and its ratio to saxi's time) and the sums; then where the time goes,
# per drawing and summed, seconds: saxi's plan (pen-down drawing, pen-up travel with the trip home, pen moves),
# ours (`plotter stats`' optimized plan: drawing, travel, pen moves with their settle dwells; and the board's time
# beyond our plan, e.g. moves lengthened to what the board sustains) and the lower bound's parts.
set -euo pipefail
PLOTTER=${PLOTTER:-target/release/plotter}
SAXI_DIR=${SAXI_DIR:-target/ci-node/node_modules/saxi}
# node resolves a relative module path from the driver's folder, not from here: hand it an absolute one.
[ -d "$SAXI_DIR" ] || { echo "no saxi at $SAXI_DIR (npm install --ignore-scripts saxi@0.15.0)" >&2; exit 1; }
SAXI_DIR=$(cd "$SAXI_DIR" && pwd)
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/../.." && pwd)
PROFILE=${PROFILE:-$ROOT/samples/axidraw-saxi.toml}
OC=/usr/share/openclipart/svg
if [ $# -eq 0 ]; then
  set -- "$ROOT/samples/duck.svg" "$ROOT/samples/transforms.svg" "$ROOT/samples/stacked.svg" \
    "$OC/animals/bat_orlando_karam_.svg" "$OC/education/books/open_book_nae_02.svg" \
    "$OC/recreation/sports/volley-ball_andrea_bianc_01.svg" "$OC/computer/home13.svg" \
    "$OC/recreation/games/cards/simple/simple_h_k.svg" "$OC/people/chibi_character_rick_.svg" \
    "$OC/plants/sun_flower_ganson.svg" "$OC/food/desserts/cone2_ganson.svg" \
    "$OC/office/cassa_negozio_architetto_01.svg"
fi
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

# Start the emulator, run "$@" with its port substituted for PORT, stop it (SIGINT writes the trace), print the
# trace's busy time in seconds and its pen-up count.
on_board() {
  local trace=$WORK/trace.txt extra=$1
  shift
  rm -f "$trace"
  # shellcheck disable=SC2086
  coproc SIM { exec "$PLOTTER" sim --pty --ebb --fast --trace "$trace" $extra; }
  local sim_pid=$SIM_PID port
  read -r port <&"${SIM[0]}"
  local args=()
  for a in "$@"; do args+=("${a//PORT/$port}"); done
  "${args[@]}" >"$WORK/out.txt" 2>"$WORK/err.txt" || { cat "$WORK/err.txt" >&2; kill -INT "$sim_pid"; return 1; }
  kill -INT "$sim_pid"
  wait "$sim_pid" || true
  awk '/^# busy_ticks/ { printf "%.3f", $3 / 1e6 }' "$trace"
}

printf '%-38s %7s %7s %9s %9s %6s %8s %6s\n' drawing paths lifts saxi_s ours_s ratio bound_s b/saxi
sum_saxi=0
sum_ours=0
sum_lb=0
for f in "$@"; do
  name=$(basename "$f" .svg)
  conv=$WORK/$name.svg
  "$PLOTTER" convert "$f" --paper a4 --landscape --fit -o "$conv" 2>/dev/null
  t_saxi=$(on_board "--ebb-pen-contact 16725" node "$HERE/vs_saxi_drive.js" "$SAXI_DIR" PORT "$conv")
  read -r _ paths _ lifts _ _ _ s_draw _ s_travel _ s_pen _ <"$WORK/out.txt"
  t_ours=$(on_board "" "$PLOTTER" plot "$conv" --port PORT --firmware ebb --profile "$PROFILE" \
    --pen-change none)
  # Our optimized plan (`plotter stats --json`): its pen lifts, its time and its parts, and the plot-time lower
  # bound it proves for them (pen-down length at the draw feed and the profile's drawing acceleration with the
  # least corner losses, each lift's settles, the shortest hops at the travel feed and acceleration): no plan can
  # beat it.
  read -r ours_lifts lb plan_s parts < <("$PLOTTER" stats "$conv" --profile "$PROFILE" --json 2>/dev/null |
    python3 -c '
import json, sys
v = json.load(sys.stdin)
p = v["est_time_parts_optimized"]
print(v["pen_lifts_optimized"], v["est_time_lower_bound_s_optimized"], v["est_time_s_optimized"],
      *[p[k] for k in ("draw_s", "draw_lower_bound_s", "travel_s", "travel_lower_bound_s", "lifts_s",
                       "lifts_lower_bound_s")])')
  # The board's time beyond our plan's.
  pad=$(echo "$t_ours - $plan_s" | bc -l)
  printf '%-38s %7s %7s %9s %9s %6.3f %8.1f %6.3f\n' "${name:0:38}" "$paths" "$lifts/${ours_lifts:-?}" "$t_saxi" \
    "$t_ours" "$(echo "$t_ours / $t_saxi" | bc -l)" "${lb:-0}" "$(echo "${lb:-0} / $t_saxi" | bc -l)"
  echo "$name $s_draw $s_travel $s_pen $parts $pad" >>"$WORK/parts.txt"
  sum_saxi=$(echo "$sum_saxi + $t_saxi" | bc -l)
  sum_ours=$(echo "$sum_ours + $t_ours" | bc -l)
  sum_lb=$(echo "$sum_lb + ${lb:-0}" | bc -l)
done
printf '%-38s %7s %7s %9.3f %9.3f %6.3f %8.1f %6.3f\n' sum '' '' "$sum_saxi" "$sum_ours" \
  "$(echo "$sum_ours / $sum_saxi" | bc -l)" "$sum_lb" "$(echo "$sum_lb / $sum_saxi" | bc -l)"
echo
printf '%-30s %23s %31s %23s\n' '' 'saxi (plan)' 'ours (plan; board - plan)' 'lower bound'
printf '%-30s %7s %7s %7s %7s %7s %7s %7s %7s %7s %7s\n' drawing draw travel pen draw travel pen board+ draw \
  travel pen
awk '{ printf "%-30s %7.1f %7.1f %7.1f %7.1f %7.1f %7.1f %7.3f %7.1f %7.1f %7.1f\n", substr($1, 1, 30), $2, $3, $4,
    $5, $7, $9, $11, $6, $8, $10
    for (i = 2; i <= 11; i++) s[i] += $i }
  END { printf "%-30s %7.1f %7.1f %7.1f %7.1f %7.1f %7.1f %7.3f %7.1f %7.1f %7.1f\n", "sum", s[2], s[3], s[4], s[5],
    s[7], s[9], s[11], s[6], s[8], s[10] }' "$WORK/parts.txt"
