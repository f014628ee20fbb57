#!/usr/bin/env bash
# Plot time of our pipeline vs the same drawing ordered by vpype and played on our firmware (simulated).
#
# For each input: our `convert` flattens it once (default tolerance) and fits it on A4, so both sides plot the very
# same polylines; then
#   ours:  plotter plot flat.svg                         (merge, bridges, order from home, curvature-aware plan)
#   vpype: vpype read --single-layer flat.svg linemerge linesort --two-opt gwrite -p xy_plotter v.gcode
#          plotter plot v.gcode --as-written             (vpype's G-code played on our firmware as written: its
#                                                        order, its pen lifts and settles, as a G-code sender would)
#          plotter plot v.gcode --no-optimize            (vpype's order and merges read as a drawing, so our own
#                                                        overlapped pen hops and planner play it: column vpype_ours_s)
# Both run on the built-in simulated plotter with the XY plotter kit profile; the executed (simulated) times are
# compared, with our plot-time lower bound and the share of our plot time spent lifting and dropping the pen
# (lift_pct, from the plan's time parts). The ratio is ours / vpype as written; ratio2 is ours / vpype_ours.
#
# Inputs: every 7th SVG of Debian's openclipart-svg package (sorted paths, 4–150 kB; apt-get install
# openclipart-svg, not a CI dependency) until N (default 24) of them plot on both sides — files our importer refuses
# (e.g. a DTD) are listed as skipped — plus generated figures. Our side reads the SVG as one layer, like vpype's
# --single-layer, so both may join and order all paths together.
# Needs vpype 1.15 with vpype-gcode on PATH (pip install "vpype==1.15.*" vpype-gcode), or VPYPE=/path/to/vpype.
#
# Usage: plotter-cli/scripts/bench-vpype.sh [--json] [N]      (after cargo build --release -p plotter-cli)
#   --json      print one JSON object (per-file rows and the totals) instead of the table
#   PLOTTER     our binary [default: target/release/plotter]; the figures are simulated times, whatever the build
#   PLOT_ARGS   extra arguments for our `plotter plot` (e.g. PLOT_ARGS="--opt-cost distance"), split on spaces
#   CONVERT_ARGS  extra arguments for the shared `plotter convert` (e.g. CONVERT_ARGS=--no-occlusion: both sides
#               plot every outline in full, hidden lines included)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
plotter="${PLOTTER:-$root/target/release/plotter}"
cfg="$here/vpype-plotter.toml"
json=0
if [ "${1:-}" = "--json" ]; then json=1; shift; fi
n="${1:-24}"
vpype="${VPYPE:-vpype}"
read -r -a plot_args <<<"${PLOT_ARGS:-}"
read -r -a convert_args <<<"${CONVERT_ARGS:-}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
command -v "$vpype" >/dev/null || { echo "vpype not found (put it on PATH or set VPYPE)" >&2; exit 1; }
[ -x "$plotter" ] || { echo "build first: cargo build --release -p plotter-cli" >&2; exit 1; }

inputs=()
while IFS= read -r f; do inputs+=("$f"); done < <(
  find /usr/share/openclipart/svg -name '*.svg' -size +4k -size -150k 2>/dev/null | LC_ALL=C sort | awk 'NR % 7 == 1')
gens=('gen:spirograph?r=36&q=105/36&d=30' 'gen:epicycloid?q=3&r=15' 'gen:mickey?harmonics=32&points=1000' 'gen:rose?k=5/3' 'gen:lissajous?fx=3&fy=4')
inputs+=("${gens[@]}")

executed() { sed -n 's/.*executed \([0-9.]*\) s.*/\1/p' "$1"; }
# Table rows go to stdout, or with --json into rows.jsonl.
say() { if [ "$json" = 0 ]; then echo "$@"; fi; }
[ "$json" = 1 ] || printf '%-40s %8s %8s %6s %8s %6s %8s %6s %6s %6s\n' input ours_s vpype_s ratio vp_ours ratio2 bound_s lifts vlifts lift%
: >"$work/rows.jsonl"
: >"$work/skipped.txt"
sum_o=0; sum_v=0; sum_r=0; sum_b=0; sum_l=0; count=0; slower=0; worst=0; worst_name=""
clips=0
for f in "${inputs[@]}"; do
  case "$f" in gen:*) name="$f" ;; *) name="$(basename "$f")" ;; esac
  case "$f" in gen:*) ;; *) [ "$clips" -ge "$n" ] && continue ;; esac
  flat="$work/flat.svg"
  if ! "$plotter" convert "$f" -o "$flat" --paper a4 --fit --margin 10 "${convert_args[@]}" 2>/dev/null; then
    say "skip $name (our importer refused it)"; echo "$name" >>"$work/skipped.txt"; continue
  fi
  if ! "$plotter" plot "$flat" --layer-by none --preview "$work/o.png" "${plot_args[@]}" >"$work/o.txt" 2>"$work/o.err"
  then
    say "skip $name (plot failed: $(head -c 200 "$work/o.err"))"; echo "$name" >>"$work/skipped.txt"; continue
  fi
  if ! "$vpype" -c "$cfg" read --single-layer "$flat" linemerge linesort --two-opt gwrite -p xy_plotter "$work/v.gcode" \
      >/dev/null 2>&1; then
    say "skip $name (vpype failed)"; echo "$name" >>"$work/skipped.txt"; continue
  fi
  if ! "$plotter" plot "$work/v.gcode" --as-written >"$work/v.txt" 2>"$work/v.err"; then
    say "skip $name (vpype's G-code did not play: $(tail -c 200 "$work/v.err"))"; echo "$name" >>"$work/skipped.txt"
    continue
  fi
  "$plotter" plot "$work/v.gcode" --no-optimize --preview "$work/r.png" >"$work/r.txt" 2>"$work/r.err"
  o="$(executed "$work/o.txt")"; v="$(executed "$work/v.txt")"; r="$(executed "$work/r.txt")"
  # Our plan's lift time (planned) from its time parts.
  l="$(sed -n 's/^time parts.* lifts \([0-9.]*\) \/.*/\1/p' "$work/o.txt")"
  b="$(sed -n 's/^lower bound \([0-9.]*\) s.*/\1/p' "$work/o.txt")"
  lo="$(sed -n 's/^\([0-9]*\) blocks.*/\1/p' "$work/o.txt")"
  vl="$(grep -c '^G1 Z0' "$work/v.gcode" || true)"
  ol="$(sed -n 's/.*, \([0-9]*\) lifts.*/\1/p' "$work/o.txt")"
  ratio="$(awk -v o="$o" -v v="$v" 'BEGIN{printf "%.3f", o/v}')"
  ratio2="$(awk -v o="$o" -v r="$r" 'BEGIN{printf "%.3f", o/r}')"
  lpct="$(awk -v o="$o" -v l="${l:-0}" 'BEGIN{printf "%.1f", 100*l/o}')"
  if [ "$json" = 1 ]; then
    printf '{"input":"%s","ours_s":%s,"vpype_s":%s,"ratio":%s,"vpype_ours_s":%s,"ratio_ours":%s,"lower_bound_s":%s,"lifts":%s,"vpype_lifts":%s,"lift_s":%s}\n' \
      "${name//\"/\\\"}" "$o" "$v" "$ratio" "$r" "$ratio2" "$b" "${ol:-null}" "${vl:-null}" "${l:-null}" >>"$work/rows.jsonl"
  else
    printf '%-40s %8.2f %8.2f %6s %8.2f %6s %8.2f %6s %6s %6s\n' "${name:0:40}" "$o" "$v" "$ratio" "$r" "$ratio2" "$b" "$ol" "$vl" "$lpct"
  fi
  if awk -v r="$ratio" -v w="$worst" 'BEGIN{exit !(r > w)}'; then worst="$ratio"; worst_name="$name"; fi
  sum_o="$(awk -v a="$sum_o" -v b="$o" 'BEGIN{print a+b}')"
  sum_v="$(awk -v a="$sum_v" -v b="$v" 'BEGIN{print a+b}')"
  sum_b="$(awk -v a="$sum_b" -v b="$b" 'BEGIN{print a+b}')"
  sum_r="$(awk -v a="$sum_r" -v b="$r" 'BEGIN{print a+b}')"
  sum_l="$(awk -v a="$sum_l" -v b="${l:-0}" 'BEGIN{print a+b}')"
  count=$((count + 1))
  case "$f" in gen:*) ;; *) clips=$((clips + 1)) ;; esac
  if awk -v o="$o" -v v="$v" 'BEGIN{exit !(o > v)}'; then slower=$((slower + 1)); fi
done
if [ "$json" = 1 ]; then
  rows="$(paste -sd, "$work/rows.jsonl")"
  skipped="$(sed 's/"/\\"/g; s/.*/"&"/' "$work/skipped.txt" | paste -sd,)"
  # Strings go through the environment: awk -v would interpret their backslashes.
  WN="${worst_name//\"/\\\"}" ROWS="$rows" SKIPPED="$skipped" ARGS="${PLOT_ARGS:-}" \
  awk -v o="$sum_o" -v v="$sum_v" -v r="$sum_r" -v l="$sum_l" -v b="$sum_b" -v c="$count" -v s="$slower" -v w="$worst" 'BEGIN{
    printf "{\"drawings\":%d,\"ours_s\":%.3f,\"vpype_s\":%.3f,\"ratio\":%.4f,\"lower_bound_s\":%.3f,", c, o, v, o / v, b
    printf "\"vpype_ours_s\":%.3f,\"ratio_ours\":%.4f,\"lift_pct\":%.2f,", r, o / r, 100 * l / o
    printf "\"above_bound_pct\":%.2f,\"slower_on\":%d,\"worst_ratio\":%s,", 100 * (o / b - 1), s, w
    printf "\"worst_input\":\"%s\",\"plot_args\":\"%s\",", ENVIRON["WN"], ENVIRON["ARGS"]
    printf "\"skipped\":[%s],\"rows\":[%s]}\n", ENVIRON["SKIPPED"], ENVIRON["ROWS"] }'
else
  awk -v o="$sum_o" -v v="$sum_v" -v r="$sum_r" -v l="$sum_l" -v b="$sum_b" -v c="$count" -v s="$slower" -v w="$worst" -v wn="$worst_name" 'BEGIN{
    printf "\n%d drawings: ours %.1f s, vpype as written %.1f s, ratio %.3f; vpype order on our hops %.1f s, ratio %.3f\n",
      c, o, v, o / v, r, o / r
    printf "lower bound %.1f s (ours %.1f %% above); lifts %.1f %% of our time; slower than vpype on %d; worst %s (%s)\n",
      b, 100 * (o / b - 1), 100 * l / o, s, w, wn }'
fi
