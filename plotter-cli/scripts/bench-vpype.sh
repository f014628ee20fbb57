#!/usr/bin/env bash
# Plot time of our pipeline vs the same drawing ordered by vpype and played on our firmware (simulated).
#
# For each input: our `convert` flattens it once (default tolerance) and fits it on A4, so both sides plot the very
# same polylines; then
#   ours:  plotter plot flat.svg                         (merge, bridges, order from home, curvature-aware plan)
#   vpype: vpype read --single-layer flat.svg linemerge linesort --two-opt gwrite -p xy_plotter v.gcode
#          plotter plot v.gcode --no-optimize            (vpype's order and merges, played on our firmware)
# Both run on the built-in simulated plotter with the XY plotter kit profile; the executed (simulated) times are
# compared, with our plot-time lower bound.
#
# Inputs: every 7th SVG of Debian's openclipart-svg package (sorted paths, 4–150 kB; apt-get install
# openclipart-svg, not a CI dependency) until N (default 24) of them plot on both sides — files our importer refuses
# (e.g. a DTD) are listed as skipped — plus generated figures. Our side reads the SVG as one layer, like vpype's
# --single-layer, so both may join and order all paths together.
# Needs vpype 1.15 with vpype-gcode on PATH (pip install "vpype==1.15.*" vpype-gcode).
#
# Usage: plotter-cli/scripts/bench-vpype.sh [N]      (after cargo build --release -p plotter-cli)
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
plotter="$root/target/release/plotter"
cfg="$here/vpype-plotter.toml"
n="${1:-24}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
command -v vpype >/dev/null || { echo "vpype not found on PATH" >&2; exit 1; }
[ -x "$plotter" ] || { echo "build first: cargo build --release -p plotter-cli" >&2; exit 1; }

inputs=()
while IFS= read -r f; do inputs+=("$f"); done < <(
  find /usr/share/openclipart/svg -name '*.svg' -size +4k -size -150k 2>/dev/null | LC_ALL=C sort | awk 'NR % 7 == 1')
gens=('gen:spirograph?r=36&q=105/36&d=30' 'gen:epicycloid?q=3&r=15' 'gen:mickey?harmonics=32&points=1000' 'gen:rose?n=5&d=3' 'gen:lissajous?a=3&b=4')
inputs+=("${gens[@]}")

executed() { sed -n 's/.*executed \([0-9.]*\) s.*/\1/p' "$1"; }
printf '%-48s %9s %9s %7s %9s %6s %6s\n' input ours_s vpype_s ratio bound_s lifts vlifts
sum_o=0; sum_v=0; sum_b=0; count=0; slower=0
clips=0
for f in "${inputs[@]}"; do
  name="$(basename "$f")"
  case "$f" in gen:*) ;; *) [ "$clips" -ge "$n" ] && continue ;; esac
  flat="$work/flat.svg"
  if ! "$plotter" convert "$f" -o "$flat" --paper a4 --fit --margin 10 2>/dev/null; then
    echo "skip $name (our importer refused it)"; continue
  fi
  if ! "$plotter" plot "$flat" --layer-by none --preview "$work/o.png" >"$work/o.txt" 2>"$work/o.err"; then
    echo "skip $name (plot failed: $(head -c 200 "$work/o.err"))"; continue
  fi
  if ! vpype -c "$cfg" read --single-layer "$flat" linemerge linesort --two-opt gwrite -p xy_plotter "$work/v.gcode" \
      >/dev/null 2>&1; then
    echo "skip $name (vpype failed)"; continue
  fi
  "$plotter" plot "$work/v.gcode" --no-optimize --preview "$work/v.png" >"$work/v.txt" 2>"$work/v.err"
  o="$(executed "$work/o.txt")"; v="$(executed "$work/v.txt")"
  b="$(sed -n 's/^lower bound \([0-9.]*\) s.*/\1/p' "$work/o.txt")"
  lo="$(sed -n 's/^\([0-9]*\) blocks.*/\1/p' "$work/o.txt")"
  vl="$(grep -c '^G1 Z0' "$work/v.gcode" || true)"
  ol="$(sed -n 's/.*, \([0-9]*\) lifts.*/\1/p' "$work/o.txt")"
  ratio="$(awk -v o="$o" -v v="$v" 'BEGIN{printf "%.3f", o/v}')"
  printf '%-48s %9.2f %9.2f %7s %9.2f %6s %6s\n' "${name:0:48}" "$o" "$v" "$ratio" "$b" "$ol" "$vl"
  sum_o="$(awk -v a="$sum_o" -v b="$o" 'BEGIN{print a+b}')"
  sum_v="$(awk -v a="$sum_v" -v b="$v" 'BEGIN{print a+b}')"
  sum_b="$(awk -v a="$sum_b" -v b="$b" 'BEGIN{print a+b}')"
  count=$((count + 1))
  case "$f" in gen:*) ;; *) clips=$((clips + 1)) ;; esac
  if awk -v o="$o" -v v="$v" 'BEGIN{exit !(o > v)}'; then slower=$((slower + 1)); fi
done
awk -v o="$sum_o" -v v="$sum_v" -v b="$sum_b" -v c="$count" -v s="$slower" 'BEGIN{
  printf "\n%d drawings: ours %.1f s, vpype order %.1f s, ratio %.3f; lower bound %.1f s (ours %.1f %% above); slower on %d\n",
    c, o, v, o / v, b, 100 * (o / b - 1), s }'
