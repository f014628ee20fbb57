# Shared by plan_vs_bound.sh and travel_split.sh (sourced, not run): the plotter binary, the seven openclipart
# drawings (A4 landscape, one layer as drawn), the pen-plotter profiles of samples/ when none are given, and each
# profile's layout.
#
# The drawings come from the openclipart-svg package (apt-get install openclipart-svg).
PLOTTER=${PLOTTER:-target/release/plotter}
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
OC=/usr/share/openclipart/svg
DRAWINGS=(
  "$OC/animals/bat_orlando_karam_.svg" "$OC/education/books/open_book_nae_02.svg"
  "$OC/recreation/sports/volley-ball_andrea_bianc_01.svg" "$OC/computer/home13.svg"
  "$OC/people/chibi_character_rick_.svg" "$OC/plants/sun_flower_ganson.svg" "$OC/food/desserts/cone2_ganson.svg"
)
for d in "${DRAWINGS[@]}"; do
  [ -f "$d" ] || { echo "missing $d: apt-get install openclipart-svg" >&2; exit 1; }
done
# PROFILES: the arguments, or every sample profile but the printer's (it drives an extruder, not a pen).
PROFILES=("$@")
if [ ${#PROFILES[@]} -eq 0 ]; then
  for p in "$ROOT"/samples/*.toml; do
    grep -q '^\[axes\.e\]' "$p" || PROFILES+=("$p")
  done
fi

# The layout flags for a profile: A4 landscape within a 20 mm margin, or on a machine smaller than that (the
# MiniKit) paper its own size, 10 mm in.
layout_for() {
  python3 -c '
import sys, tomllib
axes = tomllib.load(open(sys.argv[1], "rb")).get("axes", {})
x, y = axes.get("x", {}).get("travel_mm", 1e9), axes.get("y", {}).get("travel_mm", 1e9)
print("--paper %gx%gmm --margin 10" % (x, y) if x < 297 or y < 210 else "--paper a4 --landscape --margin 20")
' "$1"
}
