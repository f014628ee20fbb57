#!/usr/bin/env python3
"""Does the plot draw the edges the browser shows? Ours against vpype's, on openclipart drawings (issue 24).

The measure, per SVG file:
  * visible edges: the file rendered by headless Chromium at a fixed pixel size (longest side --size px, default 800)
    after every stroke is made a 1 px hairline (an injected `* { stroke-width: 1px !important; vector-effect:
    non-scaling-stroke !important }`: a pen draws a stroke's centre line, not its width; strokes of zero width, which
    draw nothing, are turned off first so the hairline rule does not show them; dashed strokes keep their scale, so
    that their dashes keep their length, and are one pixel wide at the root's scale). A pixel is a visible-edge
    pixel when its painted colour differs from its right or lower neighbour's by more than --threshold (default 40 of
    255, the largest of the three channel differences); both pixels of such a pair are marked.
  * ink: what each side would draw, as 1 px lines (Bresenham, no smoothing) in the same pixel frame:
      ours:   plotter convert FILE -o OUT.svg   (a plain SVG of polylines in mm; its page is the document's frame)
      vpype:  vpype read FILE write OUT.svg     (polylines in CSS px; its page is the document's frame)
    Both outputs' viewBox spans the document's frame, which is mapped onto the browser's pixels (checked by --selftest
    on hand-made files whose coordinates are known).
  * precision = share of ink pixels within 3 px (Euclidean) of a visible-edge pixel;
    recall    = share of visible-edge pixels within 3 px of an ink pixel.
  Per file, then over the whole set two ways: pooled (pixel counts summed over files, so large drawings weigh more)
  and mean (the average of the per-file figures, every file weighing the same). Files the browser shows nothing for
  (no edge pixel) are excluded and counted; files our importer or vpype refuses are listed and left out of both
  sides' figures.

Known biases of the measure (each seen on the openclipart sample; see --keep):
  * Hairlines reveal what wide strokes hide: the browser draws every stroke 1 px wide, so a line passing under a
    wide opaque stroke painted later (a thick ring over spokes, a door frame over the door's backing) shows in the
    rendering although it is covered on the real page, where our hidden-line removal rightly cuts it. This counts
    against our recall only; --ours-arg=--no-occlusion bounds what occlusion costs in recall (and gains in
    precision).
  * Magnification: the rendering is --size px whatever the drawing's size, so a 10 mm icon is magnified ~80 times
    and our 0.05 mm chord error becomes pixels (see --match-tolerance).
  * Edges inside gradients (a radial gradient with a sharp stop) and half-transparent layers seen through are
    edges that no outline follows, for either side.

Measured on main at 1cfc22b (debug build; 130 files, all shown by the browser, none refused; pooled / mean):
  default:                                ours P 0.815/0.847 R 0.988/0.985   vpype P 0.724/0.774 R 0.971/0.971
  --match-tolerance:                      ours P 0.815/0.847 R 0.989/0.988
  --match-tolerance, ours --no-occlusion: ours P 0.741/0.787 R 0.995/0.992
On branch i-edges (tints in the edge rule): ours P 0.815/0.847 R 0.988/0.985 (4 files move, by < 0.003).
Our recall is below vpype's on 30 files (29 with --match-tolerance, 10 also without occlusion, none of those by
more than 0.025).

Inputs: every SVG under /usr/share/openclipart/svg (Debian's openclipart-svg package) of --min-kb..--max-kb
(default 2..250 KB), sorted by path, duplicates by content dropped, at most --per-folder (default 2) per folder
(picked by a hash of the path: series of near-identical files would fill the sample otherwise); then every k-th so
that --n (default 130) remain. A root without the SVG namespace (a browser would show the XML tree) gets it in the
rendered copy.

Set-up (not a CI dependency): Chromium at /usr/bin/chromium, vpype on PATH, and a venv with Pillow and numpy:
  python3 -m venv /tmp/edges-venv && /tmp/edges-venv/bin/pip install pillow numpy
  cargo build -p plotter-cli          # or --release; pass the binary with --plotter
  /tmp/edges-venv/bin/python plotter-path/benches/edges_vs_browser.py --plotter target/debug/plotter \
      [--n 130] [--cache DIR] [--keep DIR] [--json] [--selftest]
--cache DIR keeps the browser renderings and vpype's outputs between runs (they do not change when ours does);
--match-tolerance flattens ours to a quarter of a rendering pixel (at most the default 0.05 mm): a 16 mm icon shown
800 px wide magnifies our 0.05 mm chord error to 2.5 px, which the 3 px reach then counts against us although it is
invisible on paper (vpype cuts curves into 0.1 mm pieces, fine at any magnification). --keep DIR writes, per file, a PNG with the three renderings side by side (browser edges, ours, vpype; ink pixels
far from any edge in red, edges far from any ink in blue) for finding the causes of a loss.
"""

import argparse
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np
from PIL import Image, ImageDraw

ROOT = "/usr/share/openclipart/svg"
CHROMIUM = "/usr/bin/chromium"
HAIRLINE = (b"<style>*{stroke-width:1px !important;vector-effect:non-scaling-stroke !important}"
            b'[stroke-width="0"],[stroke-width="0"] *,[stroke-width="0px"],[stroke-width="0px"] *{stroke:none !important}'
            b"</style>")
# A zero stroke width draws nothing; the hairline rule must not make it visible (inline styles: rewritten).
ZERO_WIDTH = re.compile(rb"stroke-width\s*:\s*0*\.?0+(px)?\s*(?=;|\"|'|!)")
REACH = 3  # px: how near ink and edge must be to count
UNIT_PX = {"": 1.0, "px": 1.0, "mm": 96 / 25.4, "cm": 96 / 2.54, "in": 96.0, "pt": 96 / 72, "pc": 16.0}


# ---------------------------------------------------------------- the document's frame and the browser's rendering

ROOT_TAG = re.compile(rb"<svg\b[^>]*>", re.S)


def attr(tag, name):
    m = re.search(rb"\s" + name + rb"\s*=\s*(\"[^\"]*\"|'[^']*')", tag)
    return m.group(1)[1:-1].decode("utf-8", "replace").strip() if m else None


def length_px(text):
    """A root width/height in CSS px, or None when absent or relative (%)."""
    if text is None:
        return None
    m = re.fullmatch(r"([-+0-9.eE]+)\s*([a-z]*)", text)
    if not m or m.group(2) not in UNIT_PX:
        return None
    try:
        v = float(m.group(1)) * UNIT_PX[m.group(2)]
    except ValueError:
        return None
    return v if v > 0 else None


def frame(data):
    """(root tag span, viewBox (x, y, w, h), size (w, h) in CSS px) of an SVG document, or None when unknown."""
    m = ROOT_TAG.search(data)
    if not m:
        return None
    tag = m.group(0)
    vb = attr(tag, rb"viewBox")
    box = None
    if vb:
        try:
            box = [float(v) for v in re.split(r"[\s,]+", vb.strip())]
        except ValueError:
            box = None
        if box is None or len(box) != 4 or box[2] <= 0 or box[3] <= 0:
            box = None
    w, h = length_px(attr(tag, rb"width")), length_px(attr(tag, rb"height"))
    if box is None:
        if w is None or h is None:
            return None
        box = [0.0, 0.0, w, h]
    w = w if w is not None else box[2]
    h = h if h is not None else box[3]
    return m.span(), box, (w, h)


def pixel_size(size, longest):
    w, h = size
    s = longest / max(w, h)
    return max(1, round(w * s)), max(1, round(h * s))


def hairline_copy(data, px):
    """The document with its root sized to `px` (viewBox kept or made explicit) and every stroke a 1 px hairline."""
    (a, b), box, _ = frame(data)
    tag = data[a:b]
    tag = re.sub(rb"\s(width|height|viewBox)\s*=\s*(\"[^\"]*\"|'[^']*')", b"", tag)
    end = -2 if tag.endswith(b"/>") else -1
    extra = ' width="{}" height="{}" viewBox="{}"'.format(px[0], px[1], " ".join(repr(v) for v in box)).encode()
    if not re.search(rb"\sxmlns\s*=", tag):
        # Without the SVG namespace a browser shows the file as an XML tree; the drawing is what is meant.
        extra += b' xmlns="http://www.w3.org/2000/svg"'

    rest = re.sub(rb"\sstyle\s*=\s*(\"[^\"]*\"|'[^']*')", lambda m: ZERO_WIDTH.sub(b"stroke:none", m.group(0)), data[b:])
    style = HAIRLINE
    if attr(tag, rb"style") is not None:
        # The root's style stays (its fill and the like are inherited), but must not size the root again.
        style += b"<style>:root{width:%dpx !important;height:%dpx !important}</style>" % px
    if b"dasharray" in rest:
        # Under non-scaling-stroke a dash array is in screen pixels: dashed strokes keep their own scale instead,
        # one pixel wide at the root's scale (a transformed group widens or narrows them).
        width = min(px[0] / box[2], px[1] / box[3]) ** -1
        style += (b'<style>[stroke-dasharray]:not([stroke-dasharray="none"]),[style*="dasharray"]:not([style*="dasharray:none"])'
                  b"{vector-effect:none !important;stroke-width:%.6gpx !important}</style>" % width)
    return data[:a] + tag[:end] + extra + tag[end:] + style + rest


def browser_png(copy, px, out):
    with tempfile.TemporaryDirectory() as tmp:
        src = os.path.join(tmp, "in.svg")
        with open(src, "wb") as fh:
            fh.write(copy)
        cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", "--mute-audio",
               f"--user-data-dir={tmp}/profile", f"--window-size={px[0]},{px[1]}", f"--screenshot={out}",
               "file://" + src]
        try:
            subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=120)
        except subprocess.TimeoutExpired:
            return False
    return os.path.exists(out)


def edges(png, px, threshold):
    """Visible-edge mask of a rendering: colour steps above `threshold` between 4-neighbours."""
    im = Image.open(png).convert("RGBA")
    white = Image.new("RGBA", im.size, (255, 255, 255, 255))
    rgb = np.asarray(Image.alpha_composite(white, im).convert("RGB"), dtype=np.int16)[: px[1], : px[0]]
    e = np.zeros(rgb.shape[:2], dtype=bool)
    dx = np.abs(rgb[:, 1:] - rgb[:, :-1]).max(axis=2) > threshold
    dy = np.abs(rgb[1:, :] - rgb[:-1, :]).max(axis=2) > threshold
    e[:, 1:] |= dx
    e[:, :-1] |= dx
    e[1:, :] |= dy
    e[:-1, :] |= dy
    return e


# ---------------------------------------------------------------- ink: the polylines of a plain output SVG


def local(tag):
    return tag.rsplit("}", 1)[-1]


def numbers(text):
    return [float(v) for v in re.findall(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?", text or "")]


def ink(svg_file, px):
    """Mask of the polylines, polygons and lines of a plain SVG (ours or vpype's), its viewBox mapped onto `px`."""
    root = ET.parse(svg_file).getroot()
    box = numbers(root.get("viewBox"))
    sx, sy = px[0] / box[2], px[1] / box[3]
    im = Image.new("1", px, 0)
    draw = ImageDraw.Draw(im)
    for el in root.iter():
        name = local(el.tag)
        if el.get("transform"):
            raise ValueError(f"{svg_file}: unexpected transform on <{name}>")
        if name in ("polyline", "polygon"):
            v = numbers(el.get("points"))
            pts = list(zip(v[0::2], v[1::2]))
            if name == "polygon" and pts:
                pts.append(pts[0])
        elif name == "line":
            pts = [(float(el.get("x1", 0)), float(el.get("y1", 0))), (float(el.get("x2", 0)), float(el.get("y2", 0)))]
        elif name == "path":
            raise ValueError(f"{svg_file}: <path> in a plain output")
        else:
            continue
        pts = [((x - box[0]) * sx, (y - box[1]) * sy) for x, y in pts]
        if len(pts) == 1:
            draw.point(pts, fill=1)
        elif pts:
            draw.line(pts, fill=1, width=1)
    return np.asarray(im, dtype=bool)


# ---------------------------------------------------------------- the measure

DISC = [(dx, dy) for dx in range(-REACH, REACH + 1) for dy in range(-REACH, REACH + 1) if dx * dx + dy * dy <= REACH**2]


def near(mask):
    """Pixels within REACH px (Euclidean) of a set pixel of `mask`."""
    h, w = mask.shape
    pad = np.pad(mask, REACH)
    out = np.zeros_like(mask)
    for dx, dy in DISC:
        out |= pad[REACH + dy : REACH + dy + h, REACH + dx : REACH + dx + w]
    return out


def score(edge, inked):
    """(ink px, ink px near an edge, edge px, edge px near ink)."""
    return (int(inked.sum()), int((inked & near(edge)).sum()), int(edge.sum()), int((edge & near(inked)).sum()))


def ratio(a, b):
    return a / b if b else None


def run(cmd):
    try:
        r = subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, timeout=300)
    except subprocess.TimeoutExpired:
        return "timed out"
    return None if r.returncode == 0 else (r.stderr.decode("utf-8", "replace").strip().splitlines() or ["?"])[-1]


def side_by_side(edge, sides, out):
    """Browser edges | ours | vpype: ink near an edge black, ink far from every edge red, edges far from ink blue."""
    tiles = []
    e_near = near(edge)
    tile = np.full(edge.shape + (3,), 255, np.uint8)
    tile[edge] = (0, 0, 0)
    tiles.append(tile)
    for inked in sides:
        tile = np.full(edge.shape + (3,), 255, np.uint8)
        if inked is not None:
            tile[edge & ~near(inked)] = (80, 140, 255)
            tile[inked & e_near] = (0, 0, 0)
            tile[inked & ~e_near] = (230, 0, 0)
        tiles.append(tile)
    gap = np.full((edge.shape[0], 6, 3), 128, np.uint8)
    Image.fromarray(np.hstack([tiles[0], gap, tiles[1], gap, tiles[2]])).save(out)


def measure(path, a, cache, tmp):
    """One file's row, or a string saying why it has none."""
    with open(path, "rb") as fh:
        data = fh.read()
    fr = frame(data)
    if fr is None:
        return "no document size (neither viewBox nor absolute width/height)"
    px = pixel_size(fr[2], a.size)
    digest = hashlib.md5(data).hexdigest()
    copy = hairline_copy(data, px)
    png = os.path.join(cache, f"{hashlib.md5(copy).hexdigest()}-browser.png")
    if not os.path.exists(png) and not browser_png(copy, px, png):
        return "the browser rendered nothing"
    edge = edges(png, px, a.threshold)
    row = {"file": os.path.relpath(path, ROOT), "edge_px": int(edge.sum()), "px": px}
    if row["edge_px"] == 0:
        return "blank"
    ours = os.path.join(tmp, "ours.svg")
    if os.path.exists(ours):
        os.remove(ours)
    cmd = [a.plotter, "convert", path, "-o", ours]
    cmd += a.ours_arg
    if a.match_tolerance:
        mm_per_px = fr[2][0] * 25.4 / 96 / px[0]
        cmd += ["--tolerance", f"{min(0.05, 0.25 * mm_per_px):.6g}"]
    err = run(cmd)
    if err is None and not os.path.exists(ours):
        err = "exited 0 but wrote no file"
    vp = os.path.join(cache, f"{digest}-vpype.svg")
    vp_err_file = vp + ".err"
    if not os.path.exists(vp) and not os.path.exists(vp_err_file):
        verr = run([a.vpype, "read", path, "write", vp])
        if verr is None and not os.path.exists(vp):
            verr = "exited 0 but wrote no file"
        if verr:
            with open(vp_err_file, "w") as fh:
                fh.write(verr)
    verr = open(vp_err_file).read() if os.path.exists(vp_err_file) else None
    masks = []
    for side, out, e in (("ours", ours, err), ("vpype", vp, verr)):
        if e:
            row[side + "_error"] = e
            masks.append(None)
            continue
        m = ink(out, px)
        masks.append(m)
        n_ink, n_ink_near, n_edge, n_edge_near = score(edge, m)
        row[side] = {"ink_px": n_ink, "ink_near": n_ink_near, "edge_near": n_edge_near,
                     "precision": ratio(n_ink_near, n_ink), "recall": ratio(n_edge_near, n_edge)}
    if a.keep:
        stem = re.sub(r"[^A-Za-z0-9_.-]", "_", row["file"])[:-4]
        side_by_side(edge, masks, os.path.join(a.keep, stem + ".png"))
    return row


def choose(a):
    rows, seen = [], set()
    for d, _, files in os.walk(ROOT):
        for f in files:
            p = os.path.join(d, f)
            if not f.endswith(".svg") or not (a.min_kb * 1024 <= os.path.getsize(p) <= a.max_kb * 1024):
                continue
            rows.append(p)
    rows.sort()
    unique = []
    for p in rows:
        with open(p, "rb") as fh:
            digest = hashlib.md5(fh.read()).hexdigest()
        if digest not in seen:
            seen.add(digest)
            unique.append(p)
    # At most --per-folder files of a folder (picked by a hash of the path), so that a series of near-identical
    # files (e.g. 90 generated stars) does not fill the sample.
    by_folder = {}
    for p in unique:
        by_folder.setdefault(os.path.dirname(p), []).append(p)
    spread = sorted(
        p for ps in by_folder.values() for p in sorted(ps, key=lambda q: hashlib.md5(q.encode()).hexdigest())[: a.per_folder]
    )
    k = max(1, len(spread) // a.n)
    return spread[::k][: a.n]


def totals(rows, side):
    ok = [r for r in rows if side in r]
    ink_px = sum(r[side]["ink_px"] for r in ok)
    edge_px = sum(r["edge_px"] for r in ok)
    ps = [r[side]["precision"] for r in ok if r[side]["precision"] is not None]
    rs = [r[side]["recall"] for r in ok]
    return {
        "files": len(ok),
        "pooled_precision": ratio(sum(r[side]["ink_near"] for r in ok), ink_px),
        "pooled_recall": ratio(sum(r[side]["edge_near"] for r in ok), edge_px),
        "mean_precision": ratio(sum(ps), len(ps)),
        "mean_recall": ratio(sum(rs), len(rs)),
    }


def selftest(a):
    """Hand-made files whose ink is exactly the browser's edges (a black square; a mm-sized page whose viewBox is
    offset; a page sized by its viewBox alone), so both sides must score ~1: checks that the frames align."""
    cases = {
        "square": '<svg xmlns="http://www.w3.org/2000/svg" width="200" height="100">'
        '<rect x="20" y="10" width="50" height="60" fill="black"/></svg>',
        "offset-mm": '<svg xmlns="http://www.w3.org/2000/svg" width="100mm" height="50mm" viewBox="-50 -20 200 100">'
        '<rect x="-40" y="-10" width="50" height="30" fill="#123"/>'
        '<path d="M100 70 L140 20" stroke="red" stroke-width="9" fill="none"/></svg>',
        "no-size": '<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 300 400">'
        '<circle cx="150" cy="200" r="100" fill="none" stroke="blue" stroke-width="30"/></svg>',
    }
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        for name, text in cases.items():
            p = os.path.join(tmp, name + ".svg")
            with open(p, "w") as fh:
                fh.write(text)
            r = measure(p, a, tmp, tmp)
            figures = [r[side][k] for side in ("ours", "vpype") for k in ("precision", "recall")]
            ok = all(f is not None and f >= 0.98 for f in figures)
            failed |= not ok
            print(f"{name:10} ours P/R {figures[0]:.3f}/{figures[1]:.3f}  vpype P/R {figures[2]:.3f}/{figures[3]:.3f}  "
                  f"{'ok' if ok else 'FAILED (expected >= 0.98: the frames do not align)'}")
    sys.exit(1 if failed else 0)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    ap.add_argument("--plotter", default=os.path.join(here, "../../target/release/plotter"))
    ap.add_argument("--vpype", default=shutil.which("vpype") or "vpype")
    ap.add_argument("--n", type=int, default=130)
    ap.add_argument("--min-kb", type=float, default=2)
    ap.add_argument("--max-kb", type=float, default=250)
    ap.add_argument("--per-folder", type=int, default=2)
    ap.add_argument("--size", type=int, default=800)
    ap.add_argument("--threshold", type=int, default=40)
    ap.add_argument("--cache", default=os.path.join(tempfile.gettempdir(), "edges-vs-browser-cache"))
    ap.add_argument("--keep")
    ap.add_argument("--ours-arg", action="append", default=[],
                    help="one more argument for `plotter convert` (repeat for several), e.g. --ours-arg=--no-occlusion")
    ap.add_argument("--match-tolerance", action="store_true",
                    help="flatten ours to a quarter pixel of the rendering (at most 0.05 mm), so that small drawings "
                    "magnified to --size px are not judged by chord errors invisible on paper")
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--selftest", action="store_true")
    ap.add_argument("--worst", type=int, default=15, help="how many losing files to name")
    ap.add_argument("files", nargs="*", help="measure these files instead of the openclipart choice")
    a = ap.parse_args()
    os.makedirs(a.cache, exist_ok=True)
    if a.keep:
        os.makedirs(a.keep, exist_ok=True)
    if a.selftest:
        selftest(a)
        return
    files = a.files or choose(a)
    rows, blank, refused = [], [], []
    fmt = lambda v: "   -" if v is None else f"{v:.2f}"
    if not a.json:
        print(f"{'file':58} {'edges':>6} {'ours P':>6} {'ours R':>6} {'vp P':>6} {'vp R':>6}")
    with tempfile.TemporaryDirectory() as tmp:
        for p in files:
            r = measure(p, a, a.cache, tmp)
            if isinstance(r, str):
                (blank if r == "blank" else refused).append((p, r))
                continue
            for side in ("ours", "vpype"):
                if side + "_error" in r:
                    refused.append((p, f"{side}: {r[side + '_error']}"))
            rows.append(r)
            o, v = r.get("ours", {}), r.get("vpype", {})
            print(f"{r['file'][-58:]:58} {r['edge_px']:6} {fmt(o.get('precision')):>6} "
                  f"{fmt(o.get('recall')):>6} {fmt(v.get('precision')):>6} {fmt(v.get('recall')):>6}",
                  file=sys.stderr if a.json else sys.stdout, flush=True)
    both = [r for r in rows if "ours" in r and "vpype" in r]
    summary = {
        "chosen": len(files),
        "measured_both": len(both),
        "blank_in_browser": len(blank),
        "refused": [f"{os.path.relpath(p, ROOT)}: {why}" for p, why in refused],
        "ours": totals(both, "ours"),
        "vpype": totals(both, "vpype"),
    }
    losing = sorted(both, key=lambda r: r["ours"]["recall"] - r["vpype"]["recall"])
    summary["losing"] = [
        {"file": r["file"], "ours_recall": round(r["ours"]["recall"], 3), "vpype_recall": round(r["vpype"]["recall"], 3)}
        for r in losing[: a.worst] if r["ours"]["recall"] < r["vpype"]["recall"]
    ]
    summary["files_ours_recall_below_vpype"] = sum(1 for r in both if r["ours"]["recall"] < r["vpype"]["recall"])
    if a.json:
        print(json.dumps({"summary": summary, "rows": rows}, indent=1))
    else:
        print("\n" + json.dumps(summary, indent=1))


if __name__ == "__main__":
    main()
