"""Plot the tone bench's photos with the peers, hatched and plotline (PyPI), at a range of settings each, so the
bench can keep each peer's best. Every plot is written as an SVG whose page is the picture, WIDTH mm wide, drawn
with one pen of PEN mm.

Usage: peers.py PHOTOS_DIR OUT_DIR WIDTH PEN   (TONE_BENCH_QUICK=1: only the settings best on the first photos;
TONE_BENCH_HATCHED=0 leaves hatched out: on a textured photo its finest pitch runs for many minutes)

OUT_DIR/<photo>/<peer>-<style>-<setting>.svg; a peer that is missing or fails is reported and left out.
"""

import os
import subprocess
import sys
from pathlib import Path

from PIL import Image


def shapely2_lines(geom=None):
    """hatched 0.2 was written for shapely 1: its MultiLineString calls get an empty array or any geometry, which
    shapely 2 refuses; this takes both and keeps the lines."""
    import numpy as np
    from shapely.geometry import LineString, MultiLineString

    if geom is None or (isinstance(geom, np.ndarray) and geom.size == 0):
        return MultiLineString()
    if hasattr(geom, "geom_type"):
        if geom.is_empty:
            return MultiLineString()
        if geom.geom_type == "MultiLineString":
            return geom
        if geom.geom_type == "LineString":
            return MultiLineString([geom])
        parts = []
        for g in getattr(geom, "geoms", []):
            m = shapely2_lines(g)
            parts.extend(m.geoms)
        return MultiLineString([LineString(p) for p in parts])
    return MultiLineString(geom)


def hatched_runs(photo, out, width_mm):
    try:
        import hatched.hatched as hh
    except ImportError as e:  # the bench goes on without this peer
        print(f"peers: hatched is not installed ({e})", file=sys.stderr)
        return
    hh.MultiLineString = shapely2_lines
    w, h = Image.open(photo).size
    px_per_mm = w / width_mm
    # hatch_pitch is the densest spacing, in the image's pixels; its 3 levels (64, 128, 192) double it per level.
    # Its levels are gray thresholds (a pixel darker than each gets that level's lines); darker sets give more ink.
    level_sets = {
        "l3": (64, 128, 192),
        "l3d": (96, 160, 224),
        "l3dd": (128, 192, 240),
        "l5": (43, 85, 128, 170, 213),
        "l5d": (80, 130, 175, 215, 245),
    }
    quick = os.environ.get("TONE_BENCH_QUICK") == "1"
    if quick:  # the settings that were best on the first photos
        level_sets = {k: level_sets[k] for k in ("l3d", "l3dd")}
    for pitch_mm in (0.3, 0.45) if quick else (0.3, 0.45, 0.6, 0.9):
        for blur in (0,) if quick else (0, 4):
            for levels_name, levels in level_sets.items():
                label = f"hatched-hatch-p{pitch_mm}-b{blur}-{levels_name}"
                try:
                    img = hh._load_image(file_path=str(photo), blur_radius=blur, image_scale=1.0)
                    mls, *_ = hh._build_hatch(img, hatch_pitch=pitch_mm * px_per_mm, levels=levels)
                except Exception as e:  # noqa: BLE001 - a failing setting is reported, the rest go on
                    print(f"peers: hatched {label} on {photo.name}: {e}", file=sys.stderr)
                    continue
                height_mm = width_mm * h / w
                paths = []
                for ls in getattr(mls, "geoms", []):
                    pts = " L".join(f"{x:.3f},{y:.3f}" for x, y in ls.coords)
                    paths.append(f"M{pts}")
                svg = (
                    f'<svg xmlns="http://www.w3.org/2000/svg" width="{width_mm}mm" height="{height_mm}mm" '
                    f'viewBox="0 0 {w} {h}"><path fill="none" stroke="black" d="{" ".join(paths)}"/></svg>\n'
                )
                (out / f"{label}.svg").write_text(svg)


# (style, setting label, flags, tone responses tried). Gamma above 1 darkens plotline's mid-tones; 2.2 maps its
# gray-level coverage close to linear light.
PLOTLINE_RUNS = [
    ("halftone", f"s{s}-g{g}", ["--set", f"points.spacing_mm={s}", "--set", f"stipple.size_mm={s}",
                                "--set", f"tone.gamma={g}"], ("off", "auto"))
    for s in (0.8, 1.0, 1.2, 1.43, 1.7)
    for g in (1.0, 2.2, 3.0)
] + [
    ("hatch", f"s{s}-g{g}", ["--set", f"hatch.spacing_mm={s}", "--set", f"tone.gamma={g}"], ("off", "auto"))
    for s in (0.4, 0.5, 0.7)
    for g in (1.0, 2.2, 3.0)
] + [
    (style, f"{look}-g{g}", ["--look", look, "--set", f"tone.gamma={g}"], ("off",))
    for style in ("stipple", "waves", "spiral", "dither", "grid", "flow", "line", "scribble", "circles", "hilbert",
                  "sketch", "mosaic")
    for look in ("balanced", "fine", "faithful")
    for g in (1.0, 2.2)
]


def plotline_runs(photo, out, width_mm, pen_mm, exe):
    w, h = Image.open(photo).size
    height_mm = width_mm * h / w
    quick = os.environ.get("TONE_BENCH_QUICK") == "1"
    for style, setting, extra, responses in PLOTLINE_RUNS:
        if quick and not (style == "hatch" or setting.startswith(("s0.8", "s1.0"))):
            continue
        for response in responses:
            label = f"plotline-{style}-{setting}-r{response}"
            cmd = [exe, "run", style, str(photo), "--out", str(out / f"{label}.svg"), "--width", str(width_mm),
                   "--height", f"{height_mm:.4f}", "--margin", "0", "--fit", "fill", "--pen", f"Black:{pen_mm}:black",
                   "--set", f"tone.response={response}", *extra]
            try:
                r = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            except (OSError, subprocess.TimeoutExpired) as e:
                print(f"peers: plotline {label} on {photo.name}: {e}", file=sys.stderr)
                continue
            if r.returncode != 0:
                last = (r.stderr.strip().splitlines() or ["?"])[-1]
                print(f"peers: plotline {label} on {photo.name}: {last}", file=sys.stderr)


def main():
    photos, out_root = Path(sys.argv[1]), Path(sys.argv[2])
    width_mm, pen_mm = float(sys.argv[3]), float(sys.argv[4])
    exe = str(Path(sys.executable).parent / "plotline")
    for photo in sorted(photos.glob("*.png")):
        out = out_root / photo.stem
        out.mkdir(parents=True, exist_ok=True)
        if os.environ.get("TONE_BENCH_HATCHED", "1") != "0":
            hatched_runs(photo, out, width_mm)
        if Path(exe).exists():
            plotline_runs(photo, out, width_mm, pen_mm, exe)
        else:
            print("peers: plotline is not installed", file=sys.stderr)
        print(f"peers: {photo.stem} done", file=sys.stderr)


if __name__ == "__main__":
    main()
