#!/usr/bin/env bash
# The fill tone bench: openclipart drawings with many fill colours, each laid out 180 mm wide and plotted with a
# 0.3 mm pen three ways (outlines only, --hatch 0.8, --hatch tone), scored against rsvg-convert's rendering in grey
# by benches/fills.rs (mean |ΔL*| / 100 after a 1 mm Gaussian blur, over the page and over the drawn part).
#
# Usage: plotter-path/benches/fills.sh [DRAWING.svg ...]   (default: the list below)
# Needs: apt-get install openclipart-svg librsvg2-bin. Writes target/fills-bench/results.tsv.
set -euo pipefail
cd "$(dirname "$0")/../.."
OUT="$PWD/target/fills-bench"
CLIP=/usr/share/openclipart/svg
mkdir -p "$OUT"
command -v rsvg-convert >/dev/null || { echo "fills bench: rsvg-convert missing (apt-get install librsvg2-bin)" >&2; exit 1; }
if [ $# -gt 0 ]; then
  FILES=("$@")
else
  # Many fill colours each (counted with grep), some with gradients.
  FILES=(
    "$CLIP/people/a_youngster_01.svg"
    "$CLIP/people/a_boy_plays_soccer_01.svg"
    "$CLIP/animals/birds/gabbiano_architetto_fran_01.svg"
    "$CLIP/food/desserts/pink_cake_gabrielle_now_r.svg"
    "$CLIP/people/a_happy_boy_01.svg"
    "$CLIP/food/beverages/tazza_di_caffe_architett_01.svg"
    "$CLIP/food/fruit/apple_mateya_01.svg"
    "$CLIP/computer/icons/digital_camera_nikon_co_.svg"
    "$CLIP/animals/mammals/housecats/gatto_cat_architetto_fra_01.svg"
    "$CLIP/people/grandpa_01.svg"
  )
fi
for f in "${FILES[@]}"; do [ -f "$f" ] || { echo "fills bench: no $f (apt-get install openclipart-svg)" >&2; exit 1; }; done
cargo bench -q -p plotter-path --bench fills -- "${FILES[@]}" | tee "$OUT/results.tsv"
# Summary: mean error per method, and tone against --hatch 0.8 per drawing.
awk -F'\t' 'NR > 1 { page[$2] += $3; drawn[$2] += $4; dark[$2] += $5; light[$2] += $6; ink[$2] += $7; n[$2]++
    e[$1, $2] = $4; names[$1] = 1 }
  END {
    for (m in n) printf "mean %-10s page %.4f  drawn %.4f (too dark %.4f, too light %.4f)  ink %.1f m  (%d drawings)\n",
      m, page[m] / n[m], drawn[m] / n[m], dark[m] / n[m], light[m] / n[m], ink[m] / n[m], n[m]
    worse = 0
    for (d in names) if (e[d, "hatch-tone"] > 0.5 * e[d, "hatch-0.8"]) { worse++; printf "above half of --hatch 0.8: %s\n", d }
    printf "drawings where tone > half of --hatch 0.8 (drawn part): %d\n", worse
  }' "$OUT/results.tsv"
