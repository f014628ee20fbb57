#!/usr/bin/env bash
# The tone bench: our image styles against the peers (hatched and plotline, from PyPI), side by side on the same
# photos, at the same width (180 mm) and pen (0.3 mm), scored by the tone measure (benches/tone.rs: L* error after
# the eye's 1 mm blur, SSIM, ink length) and `plotter stats` (plot time, optimized order).
#
# Usage: plotter-path/benches/tone_bench/run.sh [PHOTO ...]   (default: every photo; see photos.py for the list)
# Environment: TONE_BENCH_PEERS=0 skips the peers, TONE_BENCH_PEERS=reuse measures the peers' plots already under
# target/tone-bench/peers without running them again; TONE_BENCH_OURS="label:flags;..." replaces our style list.
# Needs python3 with venv and pip; the photos of the landscape come from Debian's mate-backgrounds package (fetched
# with apt-get download, unpacked under target/, not installed). Everything is written under target/tone-bench/.
set -euo pipefail
cd "$(dirname "$0")/../../.."
HERE=plotter-path/benches/tone_bench
OUT="$PWD/target/tone-bench"
VENV=target/tone-venv
WIDTH=180
PEN=0.3
mkdir -p "$OUT"

# Python tools in a venv under target/ (guarded: without them, the bench runs ours on whatever photos exist).
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV" || echo "tone bench: no venv; photos and peers unavailable" >&2
fi
PEERS_OK=0
if [ -x "$VENV/bin/python" ]; then
  if "$VENV/bin/python" -c 'import skimage, PIL, hatched, plotline' 2>/dev/null \
     || "$VENV/bin/pip" install -q scikit-image hatched plotline >"$OUT/pip.log" 2>&1; then
    PEERS_OK=1
  else
    echo "tone bench: pip install failed (see $OUT/pip.log); peers left out" >&2
  fi
fi

# Photos.
MATE="$OUT/debs/usr/share/backgrounds/mate"
if [ ! -d "$MATE" ]; then
  mkdir -p "$OUT/debs"
  (cd "$OUT/debs" && apt-get download mate-backgrounds >/dev/null 2>&1 && dpkg-deb -x mate-backgrounds_*.deb .) \
    || echo "tone bench: mate-backgrounds not available; the landscape is left out" >&2
fi
if [ "$PEERS_OK" = 1 ]; then
  "$VENV/bin/python" "$HERE/photos.py" "$OUT/photos" "$MATE" >/dev/null
fi
if [ $# -gt 0 ]; then PHOTOS=("$@"); else PHOTOS=(); for f in "$OUT"/photos/*.png; do PHOTOS+=("$(basename "$f" .png)"); done; fi

# TONE_BENCH_NOBUILD=1 uses the plotter and tone measure binaries already built (target/release).
if [ "${TONE_BENCH_NOBUILD:-0}" != 1 ]; then
  cargo build -q --release -p plotter-cli
  cargo bench -q -p plotter-path --bench tone --no-run 2>/dev/null
fi
PLOTTER=target/release/plotter
TONE=$(ls -t target/release/deps/tone-* | grep -v '\.d$' | head -1)

# Our styles: label:flags (flags after `plotter trace PHOTO --width W --pen-width P`).
OURS="${TONE_BENCH_OURS:-hatch:--mode hatch;hatch-l8:--mode hatch --levels 8;stipple:--mode stipple;stipple-tsp:--mode stipple --tsp;squiggle:--mode squiggle;spiral:--mode spiral}"

: >"$OUT/results.tsv"
: >"$OUT/trace_times.tsv"
for photo in "${PHOTOS[@]}"; do
  pic="$OUT/photos/$photo.png"
  [ -f "$pic" ] || { echo "tone bench: no photo $pic" >&2; continue; }
  mkdir -p "$OUT/ours/$photo" "$OUT/norm/$photo"
  plots=()
  IFS=';' read -ra styles <<<"$OURS"
  for entry in "${styles[@]}"; do
    label="${entry%%:*}"; flags="${entry#*:}"
    start=$(date +%s.%N)
    # shellcheck disable=SC2086
    if "$PLOTTER" trace "$pic" --width "$WIDTH" --pen-width "$PEN" $flags -o "$OUT/ours/$photo/$label.svg" 2>"$OUT/ours/$photo/$label.log"; then
      printf '%s\t%s\t%.2f\n' "$photo" "ours-$label" "$(echo "$(date +%s.%N) - $start" | bc)" >>"$OUT/trace_times.tsv"
      plots+=("ours-$label=$OUT/ours/$photo/$label.svg")
    else
      echo "tone bench: ours $label on $photo failed: $(tail -1 "$OUT/ours/$photo/$label.log")" >&2
    fi
  done
  if [ "${TONE_BENCH_PEERS:-1}" = reuse ]; then
    for f in "$OUT/peers/$photo"/*.svg; do [ -f "$f" ] && plots+=("$(basename "$f" .svg)=$f"); done
  elif [ "$PEERS_OK" = 1 ] && [ "${TONE_BENCH_PEERS:-1}" != 0 ]; then
    mkdir -p "$OUT/peers-in/$photo"
    cp "$pic" "$OUT/peers-in/$photo/"
    "$VENV/bin/python" "$HERE/peers.py" "$OUT/peers-in/$photo" "$OUT/peers" "$WIDTH" "$PEN" 2>"$OUT/peers-$photo.log" || true
    for f in "$OUT/peers/$photo"/*.svg; do [ -f "$f" ] && plots+=("$(basename "$f" .svg)=$f"); done
  fi
  "$TONE" --picture "$pic" --width "$WIDTH" --pen "$PEN" \
    --out "$OUT/norm/$photo" "${plots[@]}" 2>"$OUT/measure-$photo.log" | tail -n +2 | while IFS=$'\t' read -r label err ssim ink paths; do
      t=$("$PLOTTER" stats --json "$OUT/norm/$photo/$label.svg" 2>/dev/null \
          | python3 -c 'import json,sys; print(round(json.load(sys.stdin)["est_time_s_optimized"], 1))' || echo nan)
      printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$photo" "$label" "$err" "$ssim" "$ink" "$paths" "$t" | tee -a "$OUT/results.tsv"
    done
done
python3 "$HERE/report.py" "$OUT/results.tsv" | tee "$OUT/report.txt"
